#include "dds_test_support.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <stdexcept>

#include "tests/support/spawn_tied.hpp"

extern char** environ;

namespace hvac_twin::dds::test {

ChildProcess::ChildProcess(const std::vector<std::string>& argv) {
  int out[2];
  int err[2];
  if (pipe2(out, O_CLOEXEC) != 0 || pipe2(err, O_CLOEXEC) != 0) {
    throw std::runtime_error("pipe2 failed");
  }
  std::vector<char*> args;
  for (const std::string& a : argv)
    args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = hvac_twin::test::spawn_tied(args[0], args.data(), environ, out[1], err[1]);
  close(out[1]);
  close(err[1]);
  out_fd_ = out[0];
  err_fd_ = err[0];
  if (pid < 0) throw std::runtime_error("cannot start " + argv[0]);
  pid_ = pid;
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !reaped_) {
    kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
  if (out_fd_ >= 0) close(out_fd_);
  if (err_fd_ >= 0) close(err_fd_);
}

bool ChildProcess::pump(std::chrono::nanoseconds timeout) {
  pollfd fds[2] = {{out_fd_, POLLIN, 0}, {err_fd_, POLLIN, 0}};
  const int ms =
      static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(timeout).count());
  if (poll(fds, 2, ms) <= 0) return false;
  bool got = false;
  char buffer[4096];
  for (int i = 0; i < 2; ++i) {
    if ((fds[i].revents & (POLLIN | POLLHUP)) == 0) continue;
    const ssize_t n = read(fds[i].fd, buffer, sizeof buffer);
    if (n > 0) {
      (i == 0 ? out_ : err_).append(buffer, static_cast<std::size_t>(n));
      got = true;
    } else {  // EOF: stop polling this pipe
      close(fds[i].fd);
      (i == 0 ? out_fd_ : err_fd_) = -1;
    }
  }
  return got;
}

std::vector<std::string> ChildProcess::read_lines(std::size_t lines,
                                                  std::chrono::nanoseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  const auto complete = [&] {
    std::vector<std::string> result;
    std::size_t start = 0;
    for (std::size_t nl; (nl = out_.find('\n', start)) != std::string::npos; start = nl + 1) {
      result.push_back(out_.substr(start, nl - start));
    }
    return result;
  };
  while (complete().size() < lines && out_fd_ >= 0 && std::chrono::steady_clock::now() < end) {
    pump(std::chrono::milliseconds(100));
  }
  return complete();
}

bool ChildProcess::wait_for_stderr(const std::string& text, std::chrono::nanoseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (err_.find(text) == std::string::npos) {
    if (err_fd_ < 0 || std::chrono::steady_clock::now() >= end) return false;
    pump(std::chrono::milliseconds(100));
  }
  return true;
}

void ChildProcess::send_signal(int signal) {
  if (pid_ > 0 && !reaped_) kill(pid_, signal);
}

int ChildProcess::wait(std::chrono::nanoseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!reaped_) {
    int status = 0;
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      reaped_ = true;
      // What the child wrote just before it exited may still be in the pipes: read to EOF
      // (bounded, since a grandchild could hold a write end open).
      while ((out_fd_ >= 0 || err_fd_ >= 0) && std::chrono::steady_clock::now() < end) {
        pump(std::chrono::milliseconds(20));
      }
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    if (std::chrono::steady_clock::now() >= end) return -1;
    pump(std::chrono::milliseconds(20));  // keep draining so the child never blocks on a pipe
  }
  return -1;
}

}  // namespace hvac_twin::dds::test
