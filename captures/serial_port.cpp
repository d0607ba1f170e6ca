#include "captures/serial_port.hpp"

#include <fcntl.h>
#include <linux/serial.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"

namespace modtap::captures {
namespace {

speed_t speed_of(uint32_t baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 921600:
      return B921600;
    default:
      return B0;
  }
}

}  // namespace

SerialPort::SerialPort(const std::string& path, const SerialFormat& format) : path_(path) {
  // O_RDONLY: the tap cannot transmit. O_NOCTTY: the port never becomes our terminal.
  fd_ = ::open(path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    // Serial ports belong to the dialout group: membership is all modtap needs, never root.
    throw CaptureError(fmt::format("{}: cannot open: {}{}", path, std::strerror(error),
                                   error == EACCES ? " (is the user in the dialout group?)" : ""));
  }
  if (!isatty(fd_)) {
    ::close(fd_);
    throw CaptureError(fmt::format("{}: not a serial port", path));
  }
  // Another program reading the same port would steal bytes: refuse rather than share.
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0 || ioctl(fd_, TIOCEXCL) != 0) {
    const int error = errno;
    ::close(fd_);
    throw CaptureError(
        fmt::format("{}: busy: {}", path,
                    error == EWOULDBLOCK ? "another program has it open" : std::strerror(error)));
  }
  try {
    configure(format);
  } catch (...) {
    ::close(fd_);
    throw;
  }
  lower_latency();
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

void SerialPort::configure(const SerialFormat& f) {
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0)
    throw CaptureError(
        fmt::format("{}: cannot read its settings: {}", path_, std::strerror(errno)));
  cfmakeraw(&tio);
  const speed_t speed = speed_of(f.baud);
  if (speed == B0) throw CaptureError(fmt::format("{}: unsupported baud rate {}", path_, f.baud));
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS | HUPCL);
  tio.c_cflag |= (f.data_bits == 7 ? CS7 : CS8) | CREAD | CLOCAL;  // CLOCAL: ignore modem lines
  if (f.parity != Parity::none) tio.c_cflag |= PARENB;
  if (f.parity == Parity::odd) tio.c_cflag |= PARODD;
  if (f.stop_bits == 2) tio.c_cflag |= CSTOPB;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (tcsetattr(fd_, TCSANOW, &tio) != 0 && !(errno == EINVAL && is_pty() && set_pty(tio)))
    throw CaptureError(
        fmt::format("{}: cannot set {} baud: {}", path_, f.baud, std::strerror(errno)));
}

// A pseudo-terminal (UNIX98 slaves have majors 136-143) has no wire: no parity bit and no
// 7-bit characters. Linux refuses some such settings on one with EINVAL; the bytes are the
// same without them, and the baud still sets modtap's timing.
bool SerialPort::is_pty() const {
  struct stat st {};
  return fstat(fd_, &st) == 0 && major(st.st_rdev) >= 136 && major(st.st_rdev) <= 143;
}

bool SerialPort::set_pty(termios tio) {
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD);
  tio.c_cflag |= CS8;
  return tcsetattr(fd_, TCSANOW, &tio) == 0;
}

// USB adapters hold bytes back to fill a packet; ask for them as soon as they come.
void SerialPort::lower_latency() {
  serial_struct serial{};
  bool low_latency = false;
  if (ioctl(fd_, TIOCGSERIAL, &serial) == 0) {
    serial.flags |= ASYNC_LOW_LATENCY;
    low_latency = ioctl(fd_, TIOCSSERIAL, &serial) == 0;
  }
  const std::string name = std::filesystem::path(std::filesystem::canonical(path_)).filename();
  const std::string timer = "/sys/class/tty/" + name + "/device/latency_timer";
  std::string ftdi;
  if (std::filesystem::exists(timer))
    ftdi = std::ofstream(timer) << "1" ? ", FTDI latency timer 1 ms"
                                       : ", FTDI latency timer not writable (16 ms bursts)";
  clock_note_ =
      fmt::format("time stamped per read{}{}", low_latency ? ", low-latency mode" : "", ftdi);
}

size_t SerialPort::read(std::span<uint8_t> into) {
  const ssize_t n = ::read(fd_, into.data(), into.size());
  if (n > 0) return static_cast<size_t>(n);
  if (n < 0 && (errno == EAGAIN || errno == EINTR)) return 0;
  throw CaptureError(fmt::format("{}: the port is gone: {}", path_,
                                 n == 0 ? "end of file" : std::strerror(errno)));
}

}  // namespace modtap::captures
