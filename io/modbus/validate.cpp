#include "io/modbus/validate.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "io/modbus/decode.hpp"
#include "io/modbus/plan.hpp"

namespace hvac_twin::modbus {
namespace {

bool finite_positive(double v) noexcept {
  return std::isfinite(v) && v > 0.0;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("modbus: " + what);
}

}  // namespace

void validate_device(const config::ModbusDeviceConfig& d,
                     std::span<const config::PointConfig> points) {
  require(d.unit_id >= 0 && d.unit_id <= 255, "unit_id must be in 0..255");
  require(d.port != 0, "port must be in 1..65535");
  require(finite_positive(d.poll_period_s) && d.poll_period_s <= 86400.0,
          "poll_period_s must be in (0, 86400] s");
  require(finite_positive(d.response_timeout_s) && d.response_timeout_s < d.poll_period_s / 2.0,
          "response_timeout_s must be positive and below half of poll_period_s");
  require(finite_positive(d.byte_timeout_s) && d.byte_timeout_s < d.poll_period_s,
          "byte_timeout_s must be positive and below poll_period_s");
  require(finite_positive(d.backoff_initial_s) && d.backoff_initial_s <= 3600.0,
          "backoff_initial_s must be in (0, 3600] s");
  require(std::isfinite(d.backoff_max_s) && d.backoff_max_s >= d.backoff_initial_s &&
              d.backoff_max_s <= 3600.0,
          "backoff_max_s must be in [backoff_initial_s, 3600] s");
  require(d.max_registers_per_request >= 1 && d.max_registers_per_request <= kMaxRegistersPerRead,
          "max_registers_per_request must be in 1..125");
  require(!points.empty(), "a device needs at least one point");
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    const std::string where = "point " + std::to_string(i) + " (\"" + p.name + "\"): ";
    require(is_valid_word_order(p.type, p.word_order),
            where + "word order CDAB/DCBA is invalid for a 16-bit type");
    require(std::isfinite(p.scale) && p.scale != 0.0, where + "scale must be finite and non-zero");
    require(std::isfinite(p.offset), where + "offset must be finite");
    require(std::isfinite(p.range_min) && std::isfinite(p.range_max) && p.range_min <= p.range_max,
            where + "range must be finite with range_min <= range_max");
    require(finite_positive(p.stale_after_s), where + "stale_after_s must be positive");
  }
  const RequestPlan plan = make_plan(points, PlanOptions{d.max_registers_per_request, 0});
  if (!plan.rejected.empty()) {
    const auto& p = points[plan.rejected.front()];
    require(false, "point \"" + p.name + "\" at address " + std::to_string(p.address) +
                       " does not fit the register space or one request");
  }
}

}  // namespace hvac_twin::modbus
