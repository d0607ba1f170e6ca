#include "captures/subprocess.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "captures/chunk_source.hpp"

extern char** environ;

namespace modtap::captures {

Subprocess::Subprocess(const std::vector<std::string>& argv) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw CaptureError(fmt::format("pipe: {}", std::strerror(errno)));
  err_ = std::tmpfile();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  if (err_) posix_spawn_file_actions_adddup2(&actions, fileno(err_), STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[1]);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  if (rc != 0) {
    close(pipe_fds[0]);
    if (err_) std::fclose(err_);
    err_ = nullptr;
    pid_ = -1;
    throw CaptureError(fmt::format("cannot run {}: {}", argv[0], std::strerror(rc)));
  }
  out_ = fdopen(pipe_fds[0], "r");
}

Subprocess::~Subprocess() {
  std::string ignored;
  if (pid_ > 0) wait(ignored);
  if (err_) std::fclose(err_);
}

int Subprocess::wait(std::string& error_text) {
  if (out_) {
    std::fclose(out_);  // a program still writing gets SIGPIPE and ends
    out_ = nullptr;
  }
  int status = 0;
  if (pid_ > 0 && waitpid(pid_, &status, 0) < 0) status = -1;
  pid_ = -1;
  if (err_) {
    std::rewind(err_);
    char buf[4096];
    const size_t n = std::fread(buf, 1, sizeof buf, err_);
    error_text.assign(buf, n);
    while (!error_text.empty() && (error_text.back() == '\n' || error_text.back() == '\r'))
      error_text.pop_back();
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string run_to_string(const std::vector<std::string>& argv, const std::string& context) {
  Subprocess process(argv);
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, process.output())) > 0) out.append(buf, n);
  std::string error_text;
  if (process.wait(error_text) != 0)
    throw CaptureError(fmt::format("{}: {} failed: {}", context, argv[0], error_text));
  return out;
}

}  // namespace modtap::captures
