#include "daemon/runtime/logging.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace hvac_twin::runtime {

std::shared_ptr<spdlog::logger> make_logger(std::string_view level) {
  const auto lvl = spdlog::level::from_str(std::string(level));
  if (lvl == spdlog::level::off && level != "off")
    throw std::invalid_argument("unknown log level \"" + std::string(level) + "\"");
  std::shared_ptr<spdlog::logger> log;
  if (std::getenv("JOURNAL_STREAM") != nullptr) {
    auto sink = std::make_shared<spdlog::sinks::systemd_sink_mt>("hvac-twind");
    log = std::make_shared<spdlog::logger>("hvac-twind", sink);
    log->set_pattern("%v");  // the journal stamps and tags every line itself
  } else {
    log = std::make_shared<spdlog::logger>("hvac-twind",
                                           std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    log->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%-5l%$ %v");
  }
  log->set_level(lvl);
  log->flush_on(spdlog::level::warn);
  return log;
}

}  // namespace hvac_twin::runtime
