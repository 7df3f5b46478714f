// Helpers for the io/dds tests: loopback-only DDS configuration, polling with timeouts, and a
// child process with captured output.
//
// Every TEST_CASE uses its own DDS domain id (see kDomain* in each file; ids 101..120 belong to
// these tests) so test cases that ctest runs in parallel never see each other's samples.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "io/dds/subscriber.hpp"

namespace hvac_twin::dds::test {

// Pinned to lo, multicast off, unicast discovery to 127.0.0.1 only.
inline config::DdsConfig loopback_config(int domain_id) {
  config::DdsConfig config;
  config.domain_id = domain_id;
  config.interface = "lo";
  config.allow_multicast = false;
  config.peers = {"127.0.0.1"};
  config.topic_prefix = "hvac_twin_test";
  return config;
}

inline std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Generous: the suite may run on two busy cores under a sanitizer.
inline constexpr std::chrono::seconds kTimeout{30};

// Polls `condition` every 10 ms until it holds or `timeout` passes; returns its last value.
template <typename Condition>
bool eventually(Condition condition, std::chrono::nanoseconds timeout = kTimeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= end) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

// Takes from `subscriber` into `records` until at least `count` records are there or the
// timeout passes. Returns records.size() >= count.
inline bool collect(Subscriber& subscriber, std::vector<Record>& records, std::size_t count,
                    std::chrono::nanoseconds timeout = kTimeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (records.size() < count) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= end) return false;
    if (subscriber.wait_and_take(
            std::min<std::chrono::nanoseconds>(end - now, std::chrono::milliseconds(100)),
            records) < 0) {
      return false;
    }
  }
  return true;
}

template <typename T>
std::vector<T> only(const std::vector<Record>& records) {
  std::vector<T> out;
  for (const Record& r : records) {
    if (const T* t = std::get_if<T>(&r)) out.push_back(*t);
  }
  return out;
}

// A child process with stdout and stderr captured through pipes.
class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv);
  ~ChildProcess();  // kills (SIGKILL) and reaps the child if still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Reads stdout until `lines` complete lines are there, stdout closes, or the timeout passes.
  std::vector<std::string> read_lines(std::size_t lines, std::chrono::nanoseconds timeout);
  // Reads stderr until it contains `text` or the timeout passes.
  bool wait_for_stderr(const std::string& text, std::chrono::nanoseconds timeout);
  void send_signal(int signal);
  // Waits for exit; returns the exit status, or -1 on timeout / abnormal termination.
  int wait(std::chrono::nanoseconds timeout);
  const std::string& stderr_text() const { return err_; }

 private:
  bool pump(std::chrono::nanoseconds timeout);  // reads what is available on both pipes
  int pid_ = -1;
  int out_fd_ = -1;
  int err_fd_ = -1;
  std::string out_;
  std::string err_;
  bool reaped_ = false;
};

}  // namespace hvac_twin::dds::test
