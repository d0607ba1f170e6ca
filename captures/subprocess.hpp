// Runs a helper program with an argument vector (never a shell) and reads its standard output.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace modtap::captures {

class Subprocess {
 public:
  // Throws CaptureError when the program cannot be started.
  explicit Subprocess(const std::vector<std::string>& argv);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  FILE* output() const { return out_; }
  // Waits for the program; returns its exit status (or -1) and what it wrote to stderr.
  int wait(std::string& error_text);

 private:
  int pid_ = -1;
  FILE* out_ = nullptr;
  FILE* err_ = nullptr;  // a temporary file, so a chatty stderr never blocks the program
};

// Runs a program to completion and returns its standard output; throws CaptureError on failure.
std::string run_to_string(const std::vector<std::string>& argv, const std::string& context);

}  // namespace modtap::captures
