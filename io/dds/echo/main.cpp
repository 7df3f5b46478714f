// hvac-twin-echo: print every hvac-twin DDS sample as a JSON (or text) line. See --help.
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "io/dds/cli/options.hpp"
#include "io/dds/echo/format.hpp"
#include "io/dds/echo/options.hpp"
#include "io/dds/participant.hpp"
#include "io/dds/security.hpp"
#include "io/dds/subscriber.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 64;  // EX_USAGE

volatile std::sig_atomic_t g_stop = 0;

extern "C" void on_signal(int /*signal*/) {
  g_stop = 1;
}

void install_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

std::string topic_list(const hvac_twin::dds::echo::Options& options) {
  std::string list;
  for (const auto topic : hvac_twin::dds::kAllTopics) {
    if (!options.topics.contains(topic)) continue;
    if (!list.empty()) list += ", ";
    list += hvac_twin::dds::topic_name(options.dds.topic_prefix, topic);
  }
  return list;
}

int run(const hvac_twin::dds::echo::Options& options) {
  using namespace hvac_twin::dds;
  using Clock = std::chrono::steady_clock;
  const std::unique_ptr<Participant> participant = make_participant(options.dds);
  Subscriber subscriber(*participant, options.dds.topic_prefix, options.topics);
  std::fprintf(stderr, "hvac-twin-echo: domain %d, interface %s, topics %s%s\n",
               participant->domain_id(), participant->interface_name().c_str(),
               topic_list(options).c_str(), options.dds.security ? ", DDS Security on" : "");

  const auto start = Clock::now();
  const auto end = options.duration_s
                       ? start + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(*options.duration_s))
                       : Clock::time_point::max();
  // Short waits so a signal or the end of --duration is noticed promptly.
  constexpr std::chrono::nanoseconds kPoll = std::chrono::milliseconds(100);
  std::vector<Record> records;
  std::uint64_t printed = 0;
  while (g_stop == 0) {
    const auto now = Clock::now();
    if (now >= end) break;
    const auto wait = std::min<std::chrono::nanoseconds>(kPoll, end - now);
    records.clear();
    if (subscriber.wait_and_take(wait, records) < 0) {
      std::fprintf(stderr, "hvac-twin-echo: DDS error %d while reading\n", subscriber.last_error());
      return kExitFailure;
    }
    for (const Record& record : records) {
      const std::string line = options.format == echo::Format::kJson ? echo::to_json_line(record)
                                                                     : echo::to_text_line(record);
      std::fputs(line.c_str(), stdout);
      std::fputc('\n', stdout);
      std::fflush(stdout);
      if (options.count && ++printed >= *options.count) return kExitOk;
    }
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  namespace echo = hvac_twin::dds::echo;
  echo::Options options;
  try {
    options = echo::parse_options(argc, argv);
  } catch (const echo::UsageError& e) {
    std::fprintf(stderr, "hvac-twin-echo: %s\n", e.what());
    return kExitUsage;
  }
  if (options.help) {
    std::fputs(echo::usage_text().c_str(), stdout);
    return kExitOk;
  }
  install_signal_handlers();
  hvac_twin::dds::cli::make_security_paths_absolute(options.dds);
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-echo: %s\n", e.what());
    return kExitFailure;
  }
}
