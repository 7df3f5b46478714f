// The heat-pump scenario: a summer day for a split unit in cooling mode.
//  - outdoor temperature: 30 degC mean, +-6 K daily sine, warmest at 15:00
//  - internal gains: a new level every 3 h, uniform in [200, 1200] W (seeded)
//  - thermostat: zone setpoint 24 degC from 08:00 to 22:00, 26 degC at night; a PI loop sets
//    the compressor speed in [20, 90] Hz
//  - expansion valve: a PI loop holds 6 K of superheat, opening within [0.1, 0.8]
//  - stops: a caller may stop the unit (speed 0 in u after drive(), as leak_bench's night
//    set-back does). While it stands both loops hold their integrators and the valve goes to its
//    start opening; a start ramps the speed from 30 Hz at 2 Hz/s, as inverter units start.
//    Without this the valve loop wound down to its 0.1 floor during a stop (no superheat at
//    rest) and the thermostat restarted at 90 Hz: the compressor emptied the starved evaporator
//    within 2 s, the discharge passed 162 degC (the R32 equation of state's limit; a real
//    compressor trips its discharge-temperature protection first) and the truth failed.
//  - fans: indoor at rated flow by day, 70 % at night; outdoor following the compressor speed
//  - optional leak: leak_g_per_h from leak_start_s on; optional truth charge
//  - commissioning (optional): no thermostat or superheat loop; six operating points held for
//    45 min each, in turn (kCommissioningPoints), the weather and gains as on any day
// The day starts at 08:00 (t = 0), from the model's start-up state at the scenario's conditions.
#include <algorithm>
#include <array>
#include <cmath>
#include <istream>
#include <numbers>
#include <ostream>
#include <random>
#include <stdexcept>

#include "plant_models/core/ad_model.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"
#include "tests/simulator/scenario.hpp"

namespace hvac_twin::sim {
namespace {

using namespace plant::hp;
constexpr double kDay = 86400.0;
constexpr double kStartOfDay = 8.0 * 3600.0;

class HeatPumpScenario final : public Scenario {
 public:
  HeatPumpScenario(const plant::HeatPumpR32& model, const ScenarioOptions& o)
      : model_(model), o_(o), rng_(o.seed) {}

  std::vector<double> initial_state() override {
    const double charge = o_.charge_kg > 0.0 ? o_.charge_kg : model_.params().nameplate_charge;
    return model_.initial_state(outdoor(0.0), 26.0, charge);
  }

  void drive(double t, double dt, std::span<double> x, std::span<const double> y,
             std::span<double> u) override {
    const auto& L = model_.slots();
    const double clock = std::fmod(kStartOfDay + t, kDay);
    const bool day = clock >= 8.0 * 3600.0 && clock < 22.0 * 3600.0;
    u[kOutdoorTemperature] = outdoor(t);

    const auto block = static_cast<long>(t / (3.0 * 3600.0));
    if (block != gain_block_) {
      gain_block_ = block;
      gains_ = std::uniform_real_distribution<double>(200.0, 1200.0)(rng_);
    }
    if (L.q_int != kNone) x[L.q_int] = gains_;
    if (L.leak != kNone)
      x[L.leak] = t >= o_.leak_start_s && t < o_.leak_end_s ? o_.leak_g_per_h : 0.0;

    if (o_.commissioning) {
      const auto& point = kCommissioningPoints[static_cast<std::size_t>(t / kCommissioningHoldS) %
                                               kCommissioningPoints.size()];
      u[kCompressorSpeed] = point[0];
      u[kValveOpening] = point[1];
      u[kIndoorFan] = point[2];
      u[kOutdoorFan] = point[3];
      return;
    }
    // Whether the unit stood over the last period: u holds what the caller applied (the day
    // starts with the unit running, from the model's start-up state).
    const bool stood = t > 0.0 && u[kCompressorSpeed] < kStoppedBelowHz;
    if (stood) started_ = t;

    // Thermostat: PI on the zone temperature, anti-windup by integrating only when unsaturated
    // and running; the start ramp caps the speed.
    const double error = y[kZoneAirTemperature] - (day ? 24.0 : 26.0);
    const double speed = 45.0 + 25.0 * error + 0.02 * (speed_integral_ + error * dt);
    const double clamped = std::clamp(speed, 20.0, 90.0);
    if (clamped == speed && !stood) speed_integral_ += error * dt;
    u[kCompressorSpeed] = std::min(clamped, kStartHz + kRampHzPerS * (t - started_));
    // Superheat: integral action on the opening (6 K target); the start opening while standing.
    valve_ =
        stood ? kStartOpening : std::clamp(valve_ + dt * 0.0008 * (y[kSuperheat] - 6.0), 0.1, 0.8);
    u[kValveOpening] = valve_;
    u[kIndoorFan] = day ? 1.0 : 0.7;
    u[kOutdoorFan] = 0.6 + 0.4 * (u[kCompressorSpeed] - 20.0) / 70.0;
  }

  void save(std::ostream& out) const override {
    out << rng_ << ' ' << gain_block_ << ' ' << gains_ << ' ' << speed_integral_ << ' ' << valve_
        << ' ' << started_;
  }
  bool restore(std::istream& in) override {
    return static_cast<bool>(in >> rng_ >> gain_block_ >> gains_ >> speed_integral_ >> valve_ >>
                             started_);
  }

 private:
  static constexpr double kStartHz = 30.0, kRampHzPerS = 2.0, kStartOpening = 0.35;
  // Speed [Hz], valve opening, indoor and outdoor fan: rated, part and high load, each fan
  // turned down, a closed-in valve.
  static constexpr double kCommissioningHoldS = 2700.0;
  static constexpr std::array<std::array<double, 4>, 6> kCommissioningPoints{
      {{50.0, 0.374, 1.0, 1.0},
       {35.0, 0.28, 1.0, 1.0},
       {65.0, 0.46, 1.0, 1.0},
       {50.0, 0.374, 0.7, 1.0},
       {50.0, 0.374, 1.0, 0.6},
       {50.0, 0.33, 1.0, 1.0}}};

  static double outdoor(double t) {
    const double clock = std::fmod(kStartOfDay + t, kDay);
    return 30.0 + 6.0 * std::sin(2.0 * std::numbers::pi * (clock - 9.0 * 3600.0) / kDay);
  }

  const plant::HeatPumpR32& model_;
  ScenarioOptions o_;
  std::mt19937_64 rng_;
  long gain_block_ = -1;
  double gains_ = 0.0;
  double speed_integral_ = 0.0;
  double valve_ = kStartOpening;
  double started_ = 0.0;  // when the unit last started [s]
};

}  // namespace

std::unique_ptr<Scenario> make_heat_pump_scenario(const plant::ContinuousModel& model,
                                                  const ScenarioOptions& options) {
  const auto* hp = dynamic_cast<const plant::AdModel<plant::HeatPumpR32>*>(&model);
  if (hp == nullptr) throw std::invalid_argument("heat-pump scenario needs a heat_pump_r32 model");
  return std::make_unique<HeatPumpScenario>(hp->model(), options);
}

}  // namespace hvac_twin::sim
