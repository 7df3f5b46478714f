// The published sigma of an output carries the model's structural error in it
// (SignalInfo::model_error, model_error_rel) in quadrature with the filter's own, in both filters.
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
