// Engineering units and their affine conversions.
#include <catch2/catch.hpp>
#include <set>
#include <string>

#include "config/units.hpp"

namespace hvac_twin::config {
namespace {

double convert(std::string_view from, std::string_view to, double v) {
  const auto c = conversion(from, to);
  REQUIRE(c.has_value());
  return c->apply(v);
}

TEST_CASE("absolute temperatures convert with an offset", "[config][units]") {
  CHECK(convert("degC", "K", 20.0) == Approx(293.15));
  CHECK(convert("K", "degC", 273.15) == Approx(0.0).margin(1e-12));
  CHECK(convert("degC", "K", -273.15) == Approx(0.0).margin(1e-12));
  CHECK(convert("degF", "degC", 212.0) == Approx(100.0));
  CHECK(convert("degF", "degC", 32.0) == Approx(0.0).margin(1e-12));
  CHECK(convert("degC", "degF", -40.0) == Approx(-40.0));
  const auto c = conversion("degC", "K");
  REQUIRE(c);
  CHECK(c->scale == 1.0);
  CHECK(c->offset == 273.15);  // exact
}

TEST_CASE("scaled units convert by their factor", "[config][units]") {
  CHECK(convert("kW", "W", 2.5) == 2500.0);
  CHECK(convert("W", "kW", 2500.0) == Approx(2.5));
  CHECK(convert("kPa", "MPa", 2500.0) == Approx(2.5));
  CHECK(convert("bar", "Pa", 1.0) == 1e5);
  CHECK(convert("bar", "kPa", 1.01325) == Approx(101.325));
  CHECK(convert("%", "1", 50.0) == Approx(0.5));
  CHECK(convert("rpm", "Hz", 3000.0) == Approx(50.0));
  CHECK(convert("g/s", "kg/s", 25.0) == Approx(0.025));
  CHECK(convert("kg/h", "kg/s", 36.0) == Approx(0.01));
  CHECK(convert("kJ/kg", "J/kg", 420.5) == Approx(420500.0));
  CHECK(convert("kWh", "J", 1.0) == 3.6e6);
  CHECK(convert("g", "kg", 1500.0) == Approx(1.5));
}

TEST_CASE("identical units convert exactly", "[config][units]") {
  for (const auto& u : known_units()) {
    const auto c = conversion(u.name, u.name);
    REQUIRE(c);
    CHECK(c->scale == 1.0);
    CHECK(c->offset == 0.0);
  }
}

TEST_CASE("incompatible or unknown units do not convert", "[config][units]") {
  CHECK_FALSE(conversion("degC", "W"));
  CHECK_FALSE(conversion("kPa", "kW"));
  CHECK_FALSE(conversion("J", "W"));   // energy is not power
  CHECK_FALSE(conversion("kw", "W"));  // spellings are case-sensitive
  CHECK_FALSE(conversion("W", "furlong"));
  CHECK_FALSE(conversion("", "W"));
}

TEST_CASE("the unit table is consistent: unique names, round trips", "[config][units]") {
  std::set<std::string_view> names;
  for (const auto& u : known_units()) {
    INFO(u.name);
    CHECK(names.insert(u.name).second);
    CHECK(find_unit(u.name) == &u);
    CHECK(u.si_scale > 0.0);
    for (const auto& v : known_units()) {
      if (v.quantity != u.quantity) continue;
      INFO(u.name << " -> " << v.name << " -> " << u.name);
      const double x = 12.345;
      CHECK(convert(v.name, u.name, convert(u.name, v.name, x)) == Approx(x).epsilon(1e-12));
    }
  }
}

}  // namespace
}  // namespace hvac_twin::config
