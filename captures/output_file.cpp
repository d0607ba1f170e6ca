#include "captures/output_file.hpp"

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

namespace modtap::captures {

WriteError::WriteError(const std::string& name, int error)
    : std::runtime_error(fmt::format("{}: {}", name, std::strerror(error))),
      broken_pipe_(error == EPIPE) {}

std::string output_name(const std::string& path) {
  return path == "-" ? "standard output" : path;
}

OutputFile::OutputFile(const std::string& path, bool buffered)
    : file_(path == "-" ? stdout : std::fopen(path.c_str(), "wb")),
      owned_(path != "-"),
      name_(output_name(path)) {
  if (!file_) throw WriteError(fmt::format("{}: cannot create", name_), errno);
  // The C library's own buffer is a disk block (4 KiB): a pcapng writer hands it a block of
  // about 200 bytes at a time, and it made a system call every twenty of them. glibc takes a
  // size only with a buffer it is given.
  if (owned_ && !buffered) {
    std::setvbuf(file_, nullptr, _IONBF, 0);
  } else if (owned_) {
    buffer_ = std::make_unique<char[]>(buffer_size);
    std::setvbuf(file_, buffer_.get(), _IOFBF, buffer_size);
  }
}

OutputFile::OutputFile(FILE* stream, std::string name)
    : file_(stream), owned_(false), name_(std::move(name)) {}

OutputFile::~OutputFile() {
  if (!file_) return;
  if (owned_) {
    std::fclose(file_);
  } else {
    std::fflush(file_);
  }
}

void OutputFile::write(std::span<const uint8_t> bytes) {
  if (bytes.empty() || !file_) return;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) fail();
  written_ += bytes.size();
}

void OutputFile::flush() {
  if (file_ && std::fflush(file_) != 0) fail();
}

void OutputFile::close() {
  if (!file_) return;
  FILE* file = file_;
  if (!owned_) {
    flush();
    return;
  }
  file_ = nullptr;
  const bool flushed = std::fflush(file) == 0;
  const int error = errno;
  if (std::fclose(file) != 0 || !flushed) throw WriteError(name_, flushed ? errno : error);
}

void OutputFile::fail() {
  const int error = errno ? errno : EIO;
  // Nothing more is written to a file that failed once; what it holds stays as it was.
  if (owned_) std::fclose(file_);
  file_ = nullptr;
  throw WriteError(name_, error);
}

}  // namespace modtap::captures
