// estimator.type and the ensemble settings.
#include <catch2/catch.hpp>

#include "config_test_support.hpp"

using namespace hvac_twin::config;
using namespace hvac_twin::config::test;

TEST_CASE("estimator.type selects the filter, the default is the constrained EKF", "[config]") {
  auto j = demo_json();
  {
    const auto r = load_json(j);
    require_ok(r);
    CHECK(r.config->units[0].estimator.type == EstimatorType::kConstrainedEkf);
  }
  j["units"][0]["estimator"]["type"] = "constrained_enkf";
  j["units"][0]["estimator"]["ensemble_members"] = 48;
  j["units"][0]["estimator"]["threads"] = 3;
  {
    const auto r = load_json(j);
    require_ok(r);
    const auto& e = r.config->units[0].estimator;
    CHECK(e.type == EstimatorType::kConstrainedEnkf);
    CHECK(e.ensemble_members == 48);
    CHECK(e.threads == 3);
  }
  j["units"][0]["estimator"]["type"] = "ukf";
  require_single_error(load_json(j), "/units/0/estimator/type",
                       {"\"ekf\"", "\"constrained_ekf\"", "\"constrained_enkf\"", "\"ukf\""});
  j["units"][0]["estimator"]["type"] = "ekf";
  j["units"][0]["estimator"]["ensemble_members"] = 2;
  require_single_error(load_json(j), "/units/0/estimator/ensemble_members", {"[4, 1000]"});
}

TEST_CASE("estimator.leak_detection and checkpoint_every_cycles: values, defaults, errors",
          "[config]") {
  auto j = demo_json();
  {
    const auto r = load_json(j);
    require_ok(r);
    const auto& e = r.config->units[0].estimator;
    CHECK(e.checkpoint_every_cycles == 60);
    CHECK(e.leak_detection.interval_s == 1800.0);
    CHECK(e.leak_detection.false_alarm_interval_days == 3650.0);
    CHECK(e.leak_detection.charge_allowance == 0.02);
    CHECK(e.leak_detection.charge_noise == 0.006);
    CHECK(e.leak_detection.reference_s == 64800.0);
  }
  auto& est = j["units"][0]["estimator"];
  est["checkpoint_every_cycles"] = 0;
  est["leak_detection"] = {{"interval_s", 600},         {"false_alarm_interval_days", 365},
                           {"max_starts_per_hour", 6},  {"charge_allowance", 0},
                           {"reference_s", 7200},       {"reference_band_hz", 10},
                           {"leak_sigma_floor", 0.5},   {"charge_noise", 0.01},
                           {"leak_rate_allowance", 2.5}};
  {
    const auto r = load_json(j);
    require_ok(r);
    const auto& e = r.config->units[0].estimator;
    CHECK(e.checkpoint_every_cycles == 0);
    CHECK(e.leak_detection.interval_s == 600.0);
    CHECK(e.leak_detection.false_alarm_interval_days == 365.0);
    CHECK(e.leak_detection.max_starts_per_hour == 6.0);
    CHECK(e.leak_detection.design_shift_sigma == 2.0);  // not given: the default
    CHECK(e.leak_detection.charge_allowance == 0.0);    // 0: the deficit statistic off
    CHECK(e.leak_detection.reference_s == 7200.0);
    CHECK(e.leak_detection.reference_band_hz == 10.0);
    CHECK(e.leak_detection.leak_sigma_floor == 0.5);
    CHECK(e.leak_detection.charge_noise == 0.01);
    CHECK(e.leak_detection.leak_rate_allowance == 2.5);
  }
  est["leak_detection"]["charge_allowance"] = 1.5;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/charge_allowance",
                       {"[0, 1]", "got 1.5"});
  est["leak_detection"]["charge_allowance"] = 0.02;
  est["leak_detection"]["charge_noise"] = -0.01;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/charge_noise",
                       {"[0, 1]", "got -0.01"});
  est["leak_detection"]["charge_noise"] = 0.006;
  est["leak_detection"]["leak_rate_allowance"] = -1;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/leak_rate_allowance",
                       {"[0, 10000]", "got -1"});
  est["leak_detection"]["leak_rate_allowance"] = 2.5;
  est["leak_detection"]["reference_band_hz"] = 0.5;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/reference_band_hz",
                       {"[1, 1000]", "got 0.5"});
  est["leak_detection"]["reference_band_hz"] = 20;
  est["leak_detection"]["interval_s"] = -1;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/interval_s",
                       {"(0, 86400]", "got -1"});
  est["leak_detection"]["interval_s"] = 600;
  est["leak_detection"]["intervall_s"] = 600;
  require_single_error(load_json(j), "/units/0/estimator/leak_detection/intervall_s",
                       {"interval_s"});
  est["leak_detection"].erase("intervall_s");
  est["checkpoint_every_cycles"] = 1.5;
  require_single_error(load_json(j), "/units/0/estimator/checkpoint_every_cycles", {"integer"});
}

TEST_CASE("estimator.consistency_window_s: default, value, range and the window in cycles",
          "[config]") {
  auto j = demo_json();
  {
    const auto r = load_json(j);
    require_ok(r);
    CHECK(r.config->units[0].estimator.consistency_window_s == 3600.0);
  }
  auto& est = j["units"][0]["estimator"];
  est["consistency_window_s"] = 86400;
  {
    const auto r = load_json(j);
    require_ok(r);
    CHECK(r.config->units[0].estimator.consistency_window_s == 86400.0);
  }
  est["consistency_window_s"] = 0;
  require_single_error(load_json(j), "/units/0/estimator/consistency_window_s",
                       {"(0, 2592000]", "got 0"});
  est["consistency_window_s"] = "1h";
  require_single_error(load_json(j), "/units/0/estimator/consistency_window_s", {"number"});
  // demo.json's period is 60 s: 7 days would be 10080 cycles, fine; at 1 s, 604800: too many.
  est["consistency_window_s"] = 7 * 86400;
  require_ok(load_json(j));
  est["period_s"] = 1;
  est["deadline_s"] = 0.01;  // within period_s / runtime.time_scale
  require_single_error(load_json(j), "/units/0/estimator/consistency_window_s",
                       {"604800 cycles", "at most 100000"});
  // The default window is checked too, and reported at the estimator that omits it.
  est.erase("consistency_window_s");
  est["period_s"] = 0.01;
  est["deadline_s"] = 0.0001;
  require_single_error(load_json(j), "/units/0/estimator",
                       {"consistency_window_s / period_s", "360000 cycles"});
}

TEST_CASE("estimator.adaptive_noise_min/max: inflation only by default, values, ranges",
          "[config]") {
  auto j = demo_json();
  {
    const auto r = load_json(j);
    require_ok(r);
    CHECK(r.config->units[0].estimator.adaptive_noise_min == 1.0);
    CHECK(r.config->units[0].estimator.adaptive_noise_max == 9.0);
  }
  auto& est = j["units"][0]["estimator"];
  est["adaptive_noise_min"] = 0.25;
  est["adaptive_noise_max"] = 9;
  {
    const auto r = load_json(j);
    require_ok(r);
    CHECK(r.config->units[0].estimator.adaptive_noise_min == 0.25);
    CHECK(r.config->units[0].estimator.adaptive_noise_max == 9.0);
  }
  est["adaptive_noise_max"] = 0.5;
  require_single_error(load_json(j), "/units/0/estimator/adaptive_noise_max",
                       {"[1, 100]", "got 0.5"});
  est["adaptive_noise_max"] = 9;
  est["adaptive_noise_min"] = 2;
  require_single_error(load_json(j), "/units/0/estimator/adaptive_noise_min",
                       {"[0.01, 1]", "got 2"});
}
