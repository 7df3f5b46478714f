#include "io/dds/echo/format.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>

namespace hvac_twin::dds::echo {
namespace {

using Json = nlohmann::ordered_json;

std::string dump(const Json& json) {
  // Replace invalid UTF-8 from a foreign publisher instead of throwing.
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

Json flag_names(std::uint32_t flags) {
  Json names = Json::array();
  for (std::uint32_t bit = 1; bit != 0; bit <<= 1) {
    if ((flags & bit) == 0) continue;
    const std::string_view name = flag_name(bit);
    if (name.empty()) {
      names.push_back("bit" + std::to_string(std::countr_zero(bit)));  // not (yet) named
    } else {
      names.push_back(name);
    }
  }
  return names;
}

Json to_json(const VirtualSensorRecord& r) {
  return Json{{"topic", "virtual_sensor"},
              {"site", r.site},
              {"unit", r.unit},
              {"name", r.name},
              {"value", r.value},
              {"sigma", r.sigma},
              {"eng_unit", r.eng_unit},
              {"quality", to_string(r.quality)},
              {"flags", r.flags},
              {"flag_names", flag_names(r.flags)},
              {"fused_points", r.fused_points},
              {"timestamp_ns", r.timestamp_ns},
              {"cycle", r.cycle}};
}

Json to_json(const ObservationRecord& r) {
  return Json{{"topic", "observation"},
              {"site", r.site},
              {"unit", r.unit},
              {"point", r.point},
              {"value", r.value},
              {"quality", to_string(r.quality)},
              {"exception_code", r.exception_code},
              {"predicted", r.predicted},
              {"innovation", r.innovation},
              {"innovation_variance", r.innovation_variance},
              {"test_ratio", r.test_ratio},
              {"fused", r.fused},
              {"timestamp_ns", r.timestamp_ns},
              {"cycle", r.cycle}};
}

Json to_json(const HealthRecord& r) {
  return Json{{"topic", "estimator_health"},
              {"site", r.site},
              {"unit", r.unit},
              {"cycle", r.cycle},
              {"cycle_time_ms", r.cycle_time_ms},
              {"cycle_time_max_ms", r.cycle_time_max_ms},
              {"overruns", r.overruns},
              {"degraded_cycles", r.degraded_cycles},
              {"gate_rejections", r.gate_rejections},
              {"numerical_resets", r.numerical_resets},
              {"publish_rejections", r.publish_rejections},
              {"quality", to_string(r.quality)},
              {"modbus_connected", r.modbus_connected},
              {"modbus_polls_ok", r.modbus_polls_ok},
              {"modbus_polls_exception", r.modbus_polls_exception},
              {"modbus_polls_failed", r.modbus_polls_failed},
              {"modbus_reconnects", r.modbus_reconnects},
              {"modbus_last_error", r.modbus_last_error},
              {"timestamp_ns", r.timestamp_ns}};
}

Json to_json(const LeakDiagnosticRecord& r) {
  return Json{{"topic", "leak_diagnostic"},
              {"site", r.site},
              {"unit", r.unit},
              {"state", to_string(r.state)},
              {"hold", to_string(r.hold)},
              {"charge", r.charge},
              {"charge_sigma", r.charge_sigma},
              {"nameplate_charge", r.nameplate_charge},
              {"leak_rate", r.leak_rate},
              {"leak_rate_sigma", r.leak_rate_sigma},
              {"cusum", r.cusum},
              {"rate_cusum", r.rate_cusum},
              {"charge_cusum", r.charge_cusum},
              {"charge_reference", r.charge_reference},
              {"threshold", r.threshold},
              {"false_alarm_interval_days", r.false_alarm_interval_days},
              {"decisions", r.decisions},
              {"suspect_since_ns", r.suspect_since_ns},
              {"leak_since_ns", r.leak_since_ns},
              {"quality", to_string(r.quality)},
              {"timestamp_ns", r.timestamp_ns},
              {"cycle", r.cycle}};
}

Json to_json(const ConsistencyRecord& r) {
  return Json{{"topic", "estimator_consistency"},
              {"site", r.site},
              {"unit", r.unit},
              {"point", r.point},
              {"window_cycles", r.window_cycles},
              {"samples", r.samples},
              {"mean_nis", r.mean_nis},
              {"band_low", r.band_low},
              {"band_high", r.band_high},
              {"verdict", to_string(r.verdict)},
              {"rejected_share", r.rejected_share},
              {"timestamp_ns", r.timestamp_ns},
              {"cycle", r.cycle}};
}

Json to_json(const UnitEstimateRecord& r) {
  Json estimates = Json::array();
  for (const auto& e : r.estimates)
    estimates.push_back(
        Json{{"name", e.name}, {"value", e.value}, {"sigma", e.sigma}, {"eng_unit", e.eng_unit}});
  return Json{{"topic", "unit_estimate"},
              {"site", r.site},
              {"unit", r.unit},
              {"quality", to_string(r.quality)},
              {"flags", r.flags},
              {"flag_names", flag_names(r.flags)},
              {"fused_points", r.fused_points},
              {"estimates", estimates},
              {"timestamp_ns", r.timestamp_ns},
              {"cycle", r.cycle}};
}

// "HH:MM:SS" of a CLOCK_REALTIME timestamp in local time.
std::string clock_time(std::int64_t timestamp_ns) {
  const std::time_t seconds = static_cast<std::time_t>(timestamp_ns / 1'000'000'000);
  std::tm local{};
  char text[16] = "??:??:??";
  if (localtime_r(&seconds, &local) != nullptr)
    std::strftime(text, sizeof text, "%H:%M:%S", &local);
  return text;
}

// Decimals that show the 1-sigma uncertainty to one significant digit (2 if unknown).
int decimals_for(double sigma) {
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return 2;
  return std::clamp(static_cast<int>(-std::floor(std::log10(sigma))), 0, 6);
}

// The value as printed with `decimals`: a value that rounds to zero is 0, not "-0".
double rounded_sign(double value, int decimals) {
  return std::abs(value) < 0.5 * std::pow(10.0, -decimals) ? 0.0 : value;
}

// The text snprintf wrote into `line` (cut at its size).
template <std::size_t N>
std::string written(const char (&line)[N], int n) {
  return std::string(line, static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(N) - 1)));
}

std::string flags_suffix(std::uint32_t flags) {
  if (flags == 0) return {};
  std::string out = "  [";
  for (const auto& name : flag_names(flags)) {
    if (out.size() > 3) out += ',';
    out += name.get<std::string>();
  }
  return out + "]";
}

std::string to_text(const VirtualSensorRecord& r) {
  const int d = decimals_for(r.sigma);
  char line[512];
  const int n =
      std::snprintf(line, sizeof line, "%s %-8s %-32s %12.*f ± %-9.*f %-8s %s%s",
                    clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), r.name.c_str(), d,
                    rounded_sign(r.value, d), d, r.sigma, r.eng_unit.c_str(),
                    std::string(to_string(r.quality)).c_str(), flags_suffix(r.flags).c_str());
  return written(line, n);
}

std::string to_text(const ObservationRecord& r) {
  const int d = decimals_for(std::sqrt(std::max(r.innovation_variance, 0.0)));
  std::string quality(to_string(r.quality));
  if (r.quality == PointQuality::kDeviceException) {
    quality += '(';  // appended piecewise: GCC 12 warns falsely on "(" + std::string
    quality += std::to_string(r.exception_code);
    quality += ')';
  }
  char line[512];
  const int n = std::snprintf(
      line, sizeof line, "%s %-8s obs %-28s %12.*f pred %.*f  innov %+.*f  NIS %.2f  %s  %s",
      clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), r.point.c_str(), d, r.value, d,
      r.predicted, d, r.innovation, r.test_ratio, r.fused ? "fused" : "  -  ", quality.c_str());
  return written(line, n);
}

std::string to_text(const HealthRecord& r) {
  char line[512];
  const int n = std::snprintf(
      line, sizeof line,
      "%s %-8s health cycle %-8llu %7.1f ms (max %.1f)  %-9s modbus %s ok %llu exception %llu "
      "fail %llu reconnects %llu  overruns %llu gated %llu resets %llu",
      clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), static_cast<unsigned long long>(r.cycle),
      r.cycle_time_ms, r.cycle_time_max_ms, std::string(to_string(r.quality)).c_str(),
      r.modbus_connected ? "up  " : "DOWN", static_cast<unsigned long long>(r.modbus_polls_ok),
      static_cast<unsigned long long>(r.modbus_polls_exception),
      static_cast<unsigned long long>(r.modbus_polls_failed),
      static_cast<unsigned long long>(r.modbus_reconnects),
      static_cast<unsigned long long>(r.overruns),
      static_cast<unsigned long long>(r.gate_rejections),
      static_cast<unsigned long long>(r.numerical_resets));
  std::string text = written(line, n);
  if (!r.modbus_last_error.empty()) text += "  last error: " + r.modbus_last_error;
  return text;
}

std::string to_text(const LeakDiagnosticRecord& r) {
  char line[512];
  const int n = std::snprintf(
      line, sizeof line,
      "%s %-8s leak   %-7s charge %.4f ± %.4f kg (nameplate %.3f)  leak %.2f ± %.2f g/h  "
      "CUSUM rate %.2f charge %.2f / %.2f  %s%s%s",
      clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), std::string(to_string(r.state)).c_str(),
      r.charge, r.charge_sigma, r.nameplate_charge, r.leak_rate, r.leak_rate_sigma, r.rate_cusum,
      r.charge_cusum, r.threshold, std::string(to_string(r.quality)).c_str(),
      r.hold == LeakHold::kNone ? "" : "  held: ",
      r.hold == LeakHold::kNone ? "" : std::string(to_string(r.hold)).c_str());
  return written(line, n);
}

std::string to_text(const ConsistencyRecord& r) {
  char line[512];
  const int n = std::snprintf(
      line, sizeof line,
      "%s %-8s nis %-28s mean %6.2f  band [%.2f, %.2f]  %5u samples / %u cycles  rejected "
      "%4.1f %%  %s",
      clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), r.point.c_str(), r.mean_nis, r.band_low,
      r.band_high, static_cast<unsigned>(r.samples), static_cast<unsigned>(r.window_cycles),
      100.0 * r.rejected_share, std::string(to_string(r.verdict)).c_str());
  return written(line, n);
}

// One line per sample, the estimates' names only: their values are on virtual_sensor's lines.
std::string to_text(const UnitEstimateRecord& r) {
  char line[512];
  const int n = std::snprintf(
      line, sizeof line, "%s %-8s unit   cycle %-8llu %zu estimates  %s%s",
      clock_time(r.timestamp_ns).c_str(), r.unit.c_str(), static_cast<unsigned long long>(r.cycle),
      r.estimates.size(), std::string(to_string(r.quality)).c_str(), flags_suffix(r.flags).c_str());
  return written(line, n);
}

}  // namespace

std::string to_json_line(const Record& record) {
  return std::visit([](const auto& r) { return dump(to_json(r)); }, record);
}

std::string to_text_line(const Record& record) {
  return std::visit([](const auto& r) { return to_text(r); }, record);
}

}  // namespace hvac_twin::dds::echo
