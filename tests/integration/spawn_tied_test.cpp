// The test children's tie to their test (tests/support/spawn_tied.hpp): a child started so is
// killed by the kernel when the process that started it dies, so a test killed mid-run (ctest's
// timeout, a crash) leaves no simulator or daemon behind on its port and DDS domain.
#include "tests/support/spawn_tied.hpp"

#include <catch2/catch.hpp>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

namespace {

// Whether `pid` runs: its /proc entry exists and it is not a zombie (a killed child whose new
// parent has not reaped it yet).
bool running(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const auto paren = line.rfind(')');
  if (paren == std::string::npos || paren + 2 >= line.size()) return false;
  const char state = line[paren + 2];
  return state != 'Z' && state != 'X';
}

}  // namespace

TEST_CASE("a tied child dies with the process that started it", "[process]") {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  const pid_t helper = ::fork();
  REQUIRE(helper >= 0);
  if (helper == 0) {  // the helper: start a long sleep tied to itself, report its pid, wait
    ::close(fds[0]);
    char program[] = "sleep", seconds[] = "600";
    char* argv[] = {program, seconds, nullptr};
    char* envp[] = {nullptr};
    const pid_t child = hvac_twin::test::spawn_tied("/bin/sleep", argv, envp, -1, -1);
    (void)!::write(fds[1], &child, sizeof child);
    ::pause();
    ::_exit(0);
  }
  ::close(fds[1]);
  pid_t child = -1;
  const auto n = ::read(fds[0], &child, sizeof child);
  ::close(fds[0]);
  REQUIRE(n == static_cast<ssize_t>(sizeof child));
  REQUIRE(child > 0);
  CHECK(running(child));

  ::kill(helper, SIGKILL);  // as ctest's timeout or a crash ends a test
  int status = 0;
  REQUIRE(::waitpid(helper, &status, 0) == helper);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (running(child) && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool survived = running(child);
  if (survived) ::kill(child, SIGKILL);  // leave nothing behind when the tie failed
  CHECK_FALSE(survived);
}

TEST_CASE("a program that cannot be started is an error with its errno", "[process]") {
  char program[] = "no-such-program";
  char* argv[] = {program, nullptr};
  char* envp[] = {nullptr};
  errno = 0;
  CHECK(hvac_twin::test::spawn_tied("/nonexistent/no-such-program", argv, envp, -1, -1) == -1);
  CHECK(errno == ENOENT);
}
