// libFuzzer target: configuration loading (config::load_config_text with the real model
// catalog) and error formatting. Input: the configuration text, any bytes.
// Invariants: no crash, no exception but std::bad_alloc, no sanitizer report; a result is either
// a configuration or at least one error, never both; format_errors writes exactly one line per
// error up to kMaxShownErrors (control characters escaped).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "config/load.hpp"
#include "plant_models/catalog.hpp"
#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto& catalog = hvac_twin::plant::model_schemas();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto result = hvac_twin::config::load_config_text(text, catalog);
  HVAC_TWIN_FUZZ_CHECK(result.config.has_value() == result.errors.empty());
  for (const auto& e : result.errors) {
    HVAC_TWIN_FUZZ_CHECK(!e.message.empty());
    HVAC_TWIN_FUZZ_CHECK(e.pointer.empty() || e.pointer.front() == '/');
  }
  const std::string lines = hvac_twin::config::format_errors(result.errors, "fuzz");
  const auto newlines = static_cast<std::size_t>(std::count(lines.begin(), lines.end(), '\n'));
  HVAC_TWIN_FUZZ_CHECK(newlines ==
                       std::min(result.errors.size(), hvac_twin::config::kMaxShownErrors));
  if (!result.config) return 0;
  // A loaded configuration satisfies the rules config.hpp states.
  const auto& c = *result.config;
  HVAC_TWIN_FUZZ_CHECK(!c.units.empty() && !c.site_id.empty());
  HVAC_TWIN_FUZZ_CHECK(std::isfinite(c.runtime.time_scale) && c.runtime.time_scale > 0);
  for (const auto& u : c.units) {
    const auto& m = u.modbus;
    HVAC_TWIN_FUZZ_CHECK(m.port >= 1 && m.unit_id >= 0 && m.unit_id <= 255);
    HVAC_TWIN_FUZZ_CHECK(m.poll_period_s > 0 && std::isfinite(m.poll_period_s));
    HVAC_TWIN_FUZZ_CHECK(m.response_timeout_s > 0 && m.response_timeout_s < m.poll_period_s / 2);
    HVAC_TWIN_FUZZ_CHECK(m.byte_timeout_s > 0 && m.byte_timeout_s <= m.response_timeout_s);
    HVAC_TWIN_FUZZ_CHECK(m.backoff_initial_s > 0 && m.backoff_initial_s <= m.backoff_max_s);
    HVAC_TWIN_FUZZ_CHECK(m.max_registers_per_request >= 1 && m.max_registers_per_request <= 125);
    HVAC_TWIN_FUZZ_CHECK(!u.points.empty() && !u.model.type.empty());
    for (const auto& p : u.points) {
      HVAC_TWIN_FUZZ_CHECK(std::isfinite(p.scale) && p.scale != 0 && std::isfinite(p.offset));
      HVAC_TWIN_FUZZ_CHECK(std::isfinite(p.range_min) && std::isfinite(p.range_max));
      HVAC_TWIN_FUZZ_CHECK(p.range_min < p.range_max);
      HVAC_TWIN_FUZZ_CHECK(p.stale_after_s > m.poll_period_s);
    }
    const auto& e = u.estimator;
    HVAC_TWIN_FUZZ_CHECK(e.period_s > 0 && e.deadline_s > 0 && e.nis_gate > 0);
    HVAC_TWIN_FUZZ_CHECK(e.deadline_s <= e.period_s / c.runtime.time_scale * (1 + 1e-12));
    for (const auto& [name, v] : e.measurement_noise)
      HVAC_TWIN_FUZZ_CHECK(std::isfinite(v) && v > 0);
    for (const auto& [name, v] : u.model.parameters)
      HVAC_TWIN_FUZZ_CHECK(std::isfinite(v));
  }
  return 0;
}
