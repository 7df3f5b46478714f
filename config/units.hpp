// Engineering units and affine conversions between them. Used at start-up: configuration
// validation checks that a point's unit converts to its model signal's unit, and the runtime
// builds one Conversion per point to turn decoded values into model units.
//
// Every unit of a ParameterInfo, StateInfo or SignalInfo in the model catalog is spelled as in
// this table (a test checks it). The spellings are case-sensitive ("kW", "kPa", "degC").
//
// All conversions are for ABSOLUTE values. Temperatures convert with an offset (20 degC ->
// 293.15 K), so a temperature DIFFERENCE must carry the same unit as the signal it feeds (a
// difference of 5 degC is 5 K, not 278.15 K). Likewise pressures are absolute: a gauge sensor
// needs the atmospheric pressure added through the point's `offset`.
//
// Pure functions over a constant table: any thread, no allocation, never throw.
#pragma once

#include <optional>
#include <span>
#include <string_view>

namespace hvac_twin::config {

// value_in_to = value_in_from * scale + offset
struct Conversion {
  double scale = 1.0;
  double offset = 0.0;
  [[nodiscard]] constexpr double apply(double value) const { return value * scale + offset; }
};

struct UnitInfo {
  std::string_view name;      // the spelling used in configuration and model descriptions
  std::string_view quantity;  // units convert only within one quantity, e.g. "pressure"
  double si_scale;            // value in the quantity's SI unit = value * si_scale + si_offset
  double si_offset;
  std::string_view description;
};

// Every known unit, grouped by quantity.
std::span<const UnitInfo> known_units();

// The unit named `name` (exact, case-sensitive), or nullptr.
const UnitInfo* find_unit(std::string_view name);

// The conversion from `from` to `to`, or nullopt when either is unknown or they measure
// different quantities. Identical units give exactly {1, 0}.
std::optional<Conversion> conversion(std::string_view from, std::string_view to);

}  // namespace hvac_twin::config
