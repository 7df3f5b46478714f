// The daemon's logger: to the journal (with priorities) when systemd runs us with
// JOURNAL_STREAM set, otherwise to stderr. Start-up only.
#pragma once

#include <spdlog/logger.h>

#include <memory>
#include <string_view>

namespace hvac_twin::runtime {

// level: trace|debug|info|warn|error. Throws std::invalid_argument for another name.
std::shared_ptr<spdlog::logger> make_logger(std::string_view level);

}  // namespace hvac_twin::runtime
