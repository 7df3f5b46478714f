// The published sigma of an output carries the model's structural error in it
// (SignalInfo::model_error, model_error_rel) in quadrature with the filter's own, in both filters;
// the EKF tests and fuses a measured output with its timing error in a transient
// (SignalInfo::model_lag_s).
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

using namespace hvac_twin;

TEST_CASE("published sigmas add each output's structural model error", "[ekf][enkf]") {
  const plant::AdModel<test::StructuralError> model{test::StructuralError{}};
  const std::vector<double> q{0.0}, x0{4.0}, s0{0.5};
  est::Ekf ekf(model, q, 1, est::EkfOptions{});
  est::EnkfOptions eo;
  eo.members = 400;
  eo.threads = 1;
  est::ConstrainedEnkf enkf(model, q, 1, eo);
  for (est::Estimator* f :
       {static_cast<est::Estimator*>(&ekf), static_cast<est::Estimator*>(&enkf)}) {
    f->reset(x0, s0);
    std::vector<double> y(2), sigma(2), part(2);
    REQUIRE(f->output_estimates({}, y, sigma, part) == plant::kModelOk);
    CHECK(part[1] == Approx(2.0 * part[0]).epsilon(1e-12));  // the filter's part alone
    CHECK(part[0] == sigma[0]);
    // The measured-type output carries the filter's sigma only; "twice" adds 0.3 and 10 % of 8.
    const double own = 2.0 * sigma[0];
    CHECK(sigma[1] == Approx(std::hypot(own, 0.3, 0.1 * y[1])).epsilon(1e-12));
    CHECK(sigma[1] > own + 0.3);
    CHECK(sigma[0] == Approx(0.5).epsilon(0.1));  // the EnKF's sample spread, 400 members
  }
}

// y = 3x, x' = rate, a 5 s timing error on y: S = 9 P + r + (5 * 3 * rate)^2 at the prior, and
// nothing added while the model stands still. A reading 0.6 off, 6 sigma of the prior with r
// alone, is then fused, as a transient's reading should be, with the smaller gain that S gives.
TEST_CASE("the EKF adds an output's timing error in a transient to its measurement variance",
          "[ekf]") {
  const plant::AdModel<test::LaggingRamp> model{test::LaggingRamp{}};
  const std::vector<double> q{0.0}, x0{1.0}, s0{0.03};
  const double r = 0.01;
  for (const double rate : {0.0, 0.01}) {
    INFO("rate " << rate);
    est::Ekf ekf(model, q, 1, est::EkfOptions{});
    ekf.reset(x0, s0);
    const std::vector<double> u{rate};
    est::Measurement m{.output = 0, .value = 3.0 + 0.6, .variance = r, .available = true};
    est::MeasurementReport rep;
    REQUIRE(ekf.update({&m, 1}, u, {&rep, 1}) == est::StepStatus::kOk);
    const double lag = 5.0 * 3.0 * rate;
    CHECK(rep.innovation_variance == Approx(9.0 * 0.03 * 0.03 + r + lag * lag).epsilon(1e-12));
    CHECK(rep.fused == (rate > 0.0));  // 0.36 / 0.0181 = 19.9 without, 0.36 / 0.0406 = 8.9 with
    if (rep.fused) {                   // the gain with the timing error in R: 3 P / S
      const double s = 9.0 * 0.03 * 0.03 + r + lag * lag;
      CHECK(ekf.state()(0) == Approx(1.0 + 3.0 * 0.03 * 0.03 / s * 0.6).epsilon(1e-9));
    }
  }
}
