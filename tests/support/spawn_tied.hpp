// Child processes of tests that die with the test: the kernel sends the child SIGKILL when the
// thread that started it ends (PR_SET_PDEATHSIG), so a test killed by ctest's timeout or by a
// crash leaves no simulator, daemon or echo behind holding its port and DDS domain (they used to
// survive and disturb the next run). Start children from a thread that outlives them (the test's
// own thread).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

namespace hvac_twin::test {

// Starts `program` with the null-terminated argv and envp; out_fd and err_fd (>= 0) become its
// stdout and stderr. Returns the child's pid, or -1 with errno set (e.g. ENOENT) when it could
// not be started or its program not executed. The caller's descriptors stay open.
inline pid_t spawn_tied(const char* program, char* const argv[], char* const envp[], int out_fd,
                        int err_fd) {
  int report[2];  // the exec's errno, if it fails; closed by a successful exec
  if (::pipe2(report, O_CLOEXEC) != 0) return -1;
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(report[0]);
    ::close(report[1]);
    errno = e;
    return -1;
  }
  if (pid == 0) {  // the child: async-signal-safe calls only, until the exec
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before the prctl
    if ((out_fd >= 0 && ::dup2(out_fd, STDOUT_FILENO) < 0) ||
        (err_fd >= 0 && ::dup2(err_fd, STDERR_FILENO) < 0)) {
      const int e = errno;
      (void)!::write(report[1], &e, sizeof e);
      ::_exit(127);
    }
    ::execve(program, argv, envp);
    const int e = errno;
    (void)!::write(report[1], &e, sizeof e);
    ::_exit(127);
  }
  ::close(report[1]);
  int child_errno = 0;
  ssize_t n = 0;
  do {
    n = ::read(report[0], &child_errno, sizeof child_errno);
  } while (n < 0 && errno == EINTR);
  ::close(report[0]);
  if (n == static_cast<ssize_t>(sizeof child_errno)) {  // the exec failed: reap, report
    int status = 0;
    ::waitpid(pid, &status, 0);
    errno = child_errno;
    return -1;
  }
  return pid;
}

}  // namespace hvac_twin::test
