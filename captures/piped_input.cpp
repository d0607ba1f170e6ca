#include "captures/piped_input.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

namespace modtap::captures {

namespace {

// The first bytes of the stream: `wanted` of them or as many as arrive before its end.
std::vector<uint8_t> read_head(int fd, const std::string& name, size_t wanted) {
  std::vector<uint8_t> head(capture_head_size);
  size_t got = 0;
  while (got < wanted) {
    const ssize_t n = ::read(fd, head.data() + got, head.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      throw CaptureError(fmt::format("{}: offset {}: {}", name, got, std::strerror(errno)));
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  head.resize(got);
  return head;
}

bool write_all(int fd, const uint8_t* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;  // the reader closed its end: it has what it wants
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

// The reader reads `/dev/fd/N` of a pipe this source fills: the head first, then the rest of
// the input as it comes. Messages and channels name the stream as the user did.
class PipedSource final : public ChunkSource {
 public:
  PipedSource(int input, std::string name, const OpenOptions& options) : name_(std::move(name)) {
    // A format to find needs the head that tells it; a format given, only the first bytes,
    // so a slow writer's first frames are not held back.
    std::vector<uint8_t> head =
        read_head(input, name_, options.format == Format::automatic ? capture_head_size : 1);
    if (head.empty()) throw CaptureError(fmt::format("{}: the input is empty", name_));
    const Format format =
        options.format == Format::automatic ? detect_format(head, name_) : options.format;
    if (format == Format::sigrok)
      throw CaptureError(fmt::format("{}: a sigrok capture is a zip file: give its name", name_));
    const std::vector<uint8_t> kept_head = head;
    int ends[2];
    if (::pipe2(ends, O_CLOEXEC) != 0)
      throw CaptureError(fmt::format("{}: {}", name_, std::strerror(errno)));
    read_end_ = ends[0];
    inner_path_ = fmt::format("/dev/fd/{}", read_end_);
    pump_ = std::thread([this, input, write_end = ends[1], head = std::move(head)] {
      pump(input, write_end, head);
    });
    try {
      source_ = open_reader(inner_path_, kept_head, format, options);
    } catch (const CaptureError& e) {
      stop();
      throw CaptureError(renamed(e.what()));
    }
    follow_channels();
  }
  ~PipedSource() override { stop(); }

  bool next(Chunk& chunk) override {
    try {
      const bool more = source_->next(chunk);
      follow_channels();
      return more;
    } catch (const CaptureError& e) {
      throw CaptureError(renamed(e.what()));
    }
  }
  ClockQuality clock() const override { return source_->clock(); }
  bool absolute_time() const override { return source_->absolute_time(); }
  const std::vector<ChannelInfo>& channels() const override { return channels_; }
  uint64_t parity_errors() const override { return source_->parity_errors(); }

 private:
  // A hex log names its channels as it meets them: the list grows, renamed as the user named
  // the stream (the sinks keep a reference to it).
  void follow_channels() {
    const auto& inner = source_->channels();
    for (size_t i = channels_.size(); i < inner.size(); ++i) {
      channels_.push_back(inner[i]);
      if (channels_.back().name == inner_path_) channels_.back().name = name_;
    }
  }

  void pump(int input, int write_end, const std::vector<uint8_t>& head) {
    std::vector<uint8_t> block(1 << 16);
    bool open = write_all(write_end, head.data(), head.size());
    while (open && !stopping_) {
      pollfd wait{input, POLLIN, 0};
      if (::poll(&wait, 1, 100) == 0) continue;  // wake now and then to see whether to stop
      const ssize_t n = ::read(input, block.data(), block.size());
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      open = write_all(write_end, block.data(), static_cast<size_t>(n));
    }
    ::close(write_end);
  }

  // Closes the reading end first, so a pump blocked on a full pipe fails its write and ends.
  void stop() {
    stopping_ = true;
    source_.reset();
    if (read_end_ >= 0) ::close(read_end_);
    read_end_ = -1;
    if (pump_.joinable()) pump_.join();
  }

  std::string renamed(std::string message) const {
    if (message.starts_with(inner_path_)) message.replace(0, inner_path_.size(), name_);
    return message;
  }

  std::string name_;
  std::string inner_path_;
  int read_end_ = -1;
  std::thread pump_;
  std::atomic<bool> stopping_{false};
  std::unique_ptr<ChunkSource> source_;
  std::vector<ChannelInfo> channels_;
};

}  // namespace

bool is_piped(const std::string& path) {
  if (path == "-") return true;
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISFIFO(info.st_mode);
}

std::unique_ptr<ChunkSource> open_piped_capture(const std::string& path,
                                                const OpenOptions& options) {
  if (path == "-") return std::make_unique<PipedSource>(STDIN_FILENO, "standard input", options);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw CaptureError(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  // Read to its end like standard input, and left open for the process's life as that is.
  return std::make_unique<PipedSource>(fd, path, options);
}

}  // namespace modtap::captures
