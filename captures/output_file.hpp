// A file modtap writes: standard output, -w, --save-raw. Every write is checked, because a
// full disk or a closed pipe must stop the run with a message, never leave a cut file behind
// an exit status of 0.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

namespace modtap::captures {

// A write that failed: the message names the file and the system's reason.
class WriteError : public std::runtime_error {
 public:
  WriteError(const std::string& name, int error);
  // The reader of a pipe went away (`modtap ... | head -1`): the run ends quietly.
  bool broken_pipe() const { return broken_pipe_; }

 private:
  bool broken_pipe_;
};

class OutputFile {
 public:
  // "-" is standard output. Throws WriteError when the file cannot be created.
  // `buffered`: small writes are gathered in a buffer; a caller that writes large pieces
  // itself (the pcapng writer) has each go to the system as it is, not copied again.
  explicit OutputFile(const std::string& path, bool buffered = true);
  // A stream someone else opened (an extcap FIFO); it is flushed, never closed, here.
  OutputFile(FILE* stream, std::string name);
  ~OutputFile();  // closes without reporting: call close() to learn of a failure
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  // After a failure the file takes nothing more, so what it holds stays as it was.
  void write(std::span<const uint8_t> bytes);
  void write(std::string_view text) {
    write({reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  }
  void flush();
  // Flushes and closes; throws WriteError if anything written did not reach the file.
  void close();
  const std::string& name() const { return name_; }
  uint64_t bytes_written() const { return written_; }  // handed to the stream so far

 private:
  [[noreturn]] void fail();

  static constexpr size_t buffer_size = 1 << 16;

  FILE* file_;
  std::unique_ptr<char[]> buffer_;  // the stream's, so it outlives the stream
  uint64_t written_ = 0;
  bool owned_;
  std::string name_;
};

// "-" for standard output, else the path as the user gave it: how messages name a file.
std::string output_name(const std::string& path);

}  // namespace modtap::captures
