// estimator.type and the ensemble settings.
#include <catch2/catch.hpp>

#include "config_test_support.hpp"

using namespace hvac_twin::config;
using namespace hvac_twin::config::test;

TEST_CASE("estimator.type selects the filter; the default is the constrained EKF", "[config]") {
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
