// Child processes for integration tests: spawn a built program with arguments and environment,
// its stdout and stderr going to files; signal it; wait for it with a timeout. The child dies
// with the test (spawn_tied.hpp).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/spawn_tied.hpp"

extern char** environ;

namespace hvac_twin::test {

class Process {
 public:
  // Starts `program` with `args`; stdout to `out_file`, stderr to `err_file` (appending);
  // `env` entries "NAME=value" are added to this process's environment.
  Process(const std::string& program, const std::vector<std::string>& args,
          const std::string& out_file, const std::string& err_file,
          const std::vector<std::string>& env = {})
      : out_file_(out_file), err_file_(err_file) {
    std::vector<std::string> argv_s{program};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_s;
    for (char** e = environ; *e != nullptr; ++e)
      env_s.emplace_back(*e);
    env_s.insert(env_s.end(), env.begin(), env.end());
    std::vector<char*> envp;
    for (auto& e : env_s)
      envp.push_back(e.data());
    envp.push_back(nullptr);
    const int out = ::open(out_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    const int err = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (out >= 0 && err >= 0)
      pid_ = spawn_tied(program.c_str(), argv.data(), envp.data(), out, err);
    const int spawn_errno = errno;
    if (out >= 0) ::close(out);
    if (err >= 0) ::close(err);
    if (pid_ < 0)
      throw std::runtime_error("cannot start " + program + ": " + std::strerror(spawn_errno));
  }
  ~Process() {
    if (pid_ > 0 && !status_) {
      ::kill(pid_, SIGKILL);
      int st = 0;
      ::waitpid(pid_, &st, 0);
    }
  }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) const { ::kill(pid_, sig); }

  // The exit status (or 128 + signal) once the process ended within `timeout`, else nullopt.
  std::optional<int> wait(std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (!status_) {
      int st = 0;
      const pid_t r = ::waitpid(pid_, &st, WNOHANG);
      if (r == pid_) {
        status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        break;
      }
      if (std::chrono::steady_clock::now() >= end) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return status_;
  }
  bool running() { return !wait(std::chrono::milliseconds(0)).has_value(); }

  std::string out() const { return read(out_file_); }
  std::string err() const { return read(err_file_); }

  static std::string read(const std::string& path) {
    std::ifstream f(path);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }

 private:
  std::string out_file_, err_file_;
  pid_t pid_ = -1;
  std::optional<int> status_;
};

// Polls `condition` every 20 ms until it holds or `timeout` passes.
template <class F>
bool eventually(F condition, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return condition();
}

}  // namespace hvac_twin::test
