#include "config/units.hpp"

#include <array>

namespace hvac_twin::config {
namespace {

// Exact by construction where the factors are exact (powers of ten, 60, 3600).
constexpr double kZeroCelsius = 273.15;  // K
constexpr double kFahrenheit = 5.0 / 9.0;

constexpr std::array kUnits{
    UnitInfo{"K", "temperature", 1.0, 0.0, "kelvin (absolute temperature)"},
    UnitInfo{"degC", "temperature", 1.0, kZeroCelsius, "degree Celsius"},
    UnitInfo{"degF", "temperature", kFahrenheit, kZeroCelsius - 32.0 * kFahrenheit,
             "degree Fahrenheit"},
    UnitInfo{"Pa", "pressure", 1.0, 0.0, "pascal (absolute)"},
    UnitInfo{"hPa", "pressure", 1e2, 0.0, "hectopascal (absolute)"},
    UnitInfo{"kPa", "pressure", 1e3, 0.0, "kilopascal (absolute)"},
    UnitInfo{"MPa", "pressure", 1e6, 0.0, "megapascal (absolute)"},
    UnitInfo{"mbar", "pressure", 1e2, 0.0, "millibar (absolute)"},
    UnitInfo{"bar", "pressure", 1e5, 0.0, "bar (absolute)"},
    UnitInfo{"W", "power", 1.0, 0.0, "watt"},
    UnitInfo{"kW", "power", 1e3, 0.0, "kilowatt"},
    UnitInfo{"MW", "power", 1e6, 0.0, "megawatt"},
    UnitInfo{"J", "energy", 1.0, 0.0, "joule"},
    UnitInfo{"kJ", "energy", 1e3, 0.0, "kilojoule"},
    UnitInfo{"MJ", "energy", 1e6, 0.0, "megajoule"},
    UnitInfo{"Wh", "energy", 3600.0, 0.0, "watt hour"},
    UnitInfo{"kWh", "energy", 3.6e6, 0.0, "kilowatt hour"},
    UnitInfo{"1", "ratio", 1.0, 0.0, "dimensionless ratio (0.5 = half)"},
    UnitInfo{"%", "ratio", 1e-2, 0.0, "percent (50 = half)"},
    UnitInfo{"Hz", "rotational speed", 1.0, 0.0, "revolutions per second"},
    UnitInfo{"rpm", "rotational speed", 1.0 / 60.0, 0.0, "revolutions per minute"},
    UnitInfo{"kg", "mass", 1.0, 0.0, "kilogram"},
    UnitInfo{"g", "mass", 1e-3, 0.0, "gram"},
    UnitInfo{"kg/s", "mass flow", 1.0, 0.0, "kilogram per second"},
    UnitInfo{"g/s", "mass flow", 1e-3, 0.0, "gram per second"},
    UnitInfo{"kg/h", "mass flow", 1.0 / 3600.0, 0.0, "kilogram per hour"},
    UnitInfo{"g/h", "mass flow", 1e-3 / 3600.0, 0.0, "gram per hour (refrigerant leaks)"},
    UnitInfo{"m3/s", "volume flow", 1.0, 0.0, "cubic metre per second"},
    UnitInfo{"m3/h", "volume flow", 1.0 / 3600.0, 0.0, "cubic metre per hour"},
    UnitInfo{"L/s", "volume flow", 1e-3, 0.0, "litre per second"},
    UnitInfo{"J/kg", "specific enthalpy", 1.0, 0.0, "joule per kilogram"},
    UnitInfo{"kJ/kg", "specific enthalpy", 1e3, 0.0, "kilojoule per kilogram"},
    UnitInfo{"J/K", "heat capacity", 1.0, 0.0, "joule per kelvin"},
    UnitInfo{"kJ/K", "heat capacity", 1e3, 0.0, "kilojoule per kelvin"},
    UnitInfo{"MJ/K", "heat capacity", 1e6, 0.0, "megajoule per kelvin"},
    UnitInfo{"W/K", "thermal conductance", 1.0, 0.0, "watt per kelvin"},
    UnitInfo{"kW/K", "thermal conductance", 1e3, 0.0, "kilowatt per kelvin"},
    UnitInfo{"W/(m2 K)", "heat transfer coefficient", 1.0, 0.0, "watt per square metre kelvin"},
    UnitInfo{"m2", "area", 1.0, 0.0, "square metre"},
    UnitInfo{"m3", "volume", 1.0, 0.0, "cubic metre"},
    UnitInfo{"L", "volume", 1e-3, 0.0, "litre"},
    UnitInfo{"cm3", "volume", 1e-6, 0.0, "cubic centimetre"},
    UnitInfo{"s", "time", 1.0, 0.0, "second"},
    UnitInfo{"min", "time", 60.0, 0.0, "minute"},
    UnitInfo{"h", "time", 3600.0, 0.0, "hour"},
};

}  // namespace

std::span<const UnitInfo> known_units() {
  return kUnits;
}

const UnitInfo* find_unit(std::string_view name) {
  for (const auto& u : kUnits)
    if (u.name == name) return &u;
  return nullptr;
}

std::optional<Conversion> conversion(std::string_view from, std::string_view to) {
  const UnitInfo* a = find_unit(from);
  const UnitInfo* b = find_unit(to);
  if (a == nullptr || b == nullptr || a->quantity != b->quantity) return std::nullopt;
  if (a == b) return Conversion{1.0, 0.0};
  // si = v * a.scale + a.offset;  v_to = (si - b.offset) / b.scale
  return Conversion{a->si_scale / b->si_scale, (a->si_offset - b->si_offset) / b->si_scale};
}

}  // namespace hvac_twin::config
