// Starting the checkpoint writer program from a test: posix_spawn with an argument vector (no
// shell, no quoting), stdout to /dev/null or captured. Test code.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <string>
#include <vector>

extern char** environ;

namespace hvac_twin::test {

struct ChildResult {
  int status = -1;  // as from waitpid
  std::string out;  // stdout
  [[nodiscard]] bool exited_ok() const { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }
};

// Starts argv[0] (a path) with stdout to `stdout_fd`, or to /dev/null when -1. Returns the pid,
// or -1.
inline pid_t spawn_child(const std::vector<std::string>& args, int stdout_fd = -1) {
  std::vector<char*> argv;
  for (const std::string& a : args)
    argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (stdout_fd >= 0)
    posix_spawn_file_actions_adddup2(&actions, stdout_fd, STDOUT_FILENO);
  else
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  if (posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

inline int wait_child(pid_t pid) {
  int status = -1;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

// Runs to completion, capturing stdout.
inline ChildResult run_child(const std::vector<std::string>& args) {
  ChildResult result;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return result;
  const pid_t pid = spawn_child(args, fds[1]);
  ::close(fds[1]);
  char buffer[4096];
  for (ssize_t r; (r = ::read(fds[0], buffer, sizeof buffer)) != 0;) {
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) break;
    result.out.append(buffer, static_cast<std::size_t>(r));
  }
  ::close(fds[0]);
  if (pid > 0) result.status = wait_child(pid);
  return result;
}

}  // namespace hvac_twin::test
