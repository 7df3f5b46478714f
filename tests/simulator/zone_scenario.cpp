// The zone scenario: a day of weather, occupancy and a thermostat.
//  - outdoor temperature: 4 degC mean, +-6 K daily sine, coldest at 05:00
//  - internal gains: a new level every 3 h, uniform in [100, 1000] W (seeded)
//  - heat pump: PI thermostat on the air temperature, setpoint 21 degC from 06:00 to 22:00 and
//    18 degC at night, heat limited to [0, 6] kW, with anti-windup
// The simulation starts at 06:00 (t = 0).
#include <algorithm>
#include <cmath>
#include <istream>
#include <numbers>
#include <ostream>
#include <random>
#include <stdexcept>
#include <string>

#include "tests/simulator/scenario.hpp"

namespace hvac_twin::sim {
namespace {

constexpr double kDay = 86400.0;
constexpr double kStartOfDay = 6.0 * 3600.0;

class ZoneScenario final : public Scenario {
 public:
  ZoneScenario(const plant::ModelLayout& layout, std::uint64_t seed) : layout_(layout), rng_(seed) {
    const auto need = [](auto idx, const char* name) {
      if (!idx) throw std::invalid_argument(std::string("zone scenario needs ") + name);
      return *idx;
    };
    t_air_ = need(layout.state("T_air"), "state T_air");
    q_int_ = need(layout.state("Q_int"), "state Q_int");
    q_hp_ = need(layout.input("heat_pump_heat"), "input heat_pump_heat");
    t_out_ = need(layout.input("outdoor_temperature"), "input outdoor_temperature");
  }

  // The layout's defaults, away from them by half their standard deviation (seeded), so the
  // filter's default guess must converge.
  std::vector<double> initial_state() override {
    std::normal_distribution<double> g(0.0, 1.0);
    std::vector<double> x;
    for (const auto& s : layout_.states)
      x.push_back(s.augmented ? s.initial : s.initial + 0.5 * s.initial_std * g(rng_));
    return x;
  }

  void drive(double t, double dt, std::span<double> x, std::span<const double> /*y*/,
             std::span<double> u) override {
    const double clock = std::fmod(kStartOfDay + t, kDay);
    u[t_out_] = 4.0 + 6.0 * std::sin(2.0 * std::numbers::pi * (clock - 11.0 * 3600.0) / kDay);

    const auto block = static_cast<long>(t / (3.0 * 3600.0));
    if (block != gain_block_) {
      gain_block_ = block;
      gains_ = std::uniform_real_distribution<double>(100.0, 1000.0)(rng_);
    }
    x[q_int_] = gains_;

    const double setpoint = clock >= 6.0 * 3600.0 && clock < 22.0 * 3600.0 ? 21.0 : 18.0;
    const double error = setpoint - x[t_air_];
    const double unclamped = kKp * error + kKi * (integral_ + error * dt);
    const double q = std::clamp(unclamped, 0.0, kMaxHeat);
    if (q == unclamped) integral_ += error * dt;  // anti-windup: integrate only when unsaturated
    u[q_hp_] = q;
  }

  void save(std::ostream& out) const override {
    out << rng_ << ' ' << gain_block_ << ' ' << gains_ << ' ' << integral_;
  }
  bool restore(std::istream& in) override {
    return static_cast<bool>(in >> rng_ >> gain_block_ >> gains_ >> integral_);
  }

 private:
  static constexpr double kKp = 1500.0;        // W/K
  static constexpr double kKi = kKp / 1800.0;  // W/(K s)
  static constexpr double kMaxHeat = 6000.0;   // W
  plant::ModelLayout layout_;
  std::mt19937_64 rng_;
  std::size_t t_air_ = 0, q_int_ = 0, q_hp_ = 0, t_out_ = 0;
  long gain_block_ = -1;
  double gains_ = 0.0;
  double integral_ = 0.0;
};

}  // namespace

std::unique_ptr<Scenario> make_zone_scenario(const plant::ContinuousModel& model,
                                             const ScenarioOptions& options) {
  return std::make_unique<ZoneScenario>(model.layout(), options.seed);
}

}  // namespace hvac_twin::sim
