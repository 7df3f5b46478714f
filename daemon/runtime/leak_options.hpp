// The leak detector's options from the unit's configuration: what the daemon runs, and what
// leak_bench validates (tests/bench/leak_scenario.hpp builds its detector with this too).
#pragma once

#include "config/config.hpp"
#include "daemon/estimation/leak_detector.hpp"

namespace hvac_twin::runtime {

// The allowance and the charge noise are configured as fractions of the nameplate charge [kg]; the
// detector takes them in the charge's unit.
inline est::LeakDetectorOptions leak_detector_options(const config::LeakDetectionConfig& c,
                                                      double nameplate_charge_kg) {
  est::LeakDetectorOptions o;
  o.interval_s = c.interval_s;
  o.design_shift_sigma = c.design_shift_sigma;
  o.false_alarm_interval_days = c.false_alarm_interval_days;
  o.warm_up_s = c.warm_up_s;
  o.startup_s = c.startup_s;
  o.min_compressor_speed_hz = c.min_compressor_speed_hz;
  o.max_starts_per_hour = c.max_starts_per_hour;
  o.sigma_floor = c.leak_sigma_floor;
  o.rate_allowance = c.leak_rate_allowance;
  o.charge_allowance = c.charge_allowance * nameplate_charge_kg;
  o.charge_noise = c.charge_noise * nameplate_charge_kg;
  o.reference_s = c.reference_s;
  o.reference_band_hz = c.reference_band_hz;
  return o;
}

}  // namespace hvac_twin::runtime
