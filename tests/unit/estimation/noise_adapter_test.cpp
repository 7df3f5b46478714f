// Bounded covariance matching of the measurement noise (daemon/estimation/noise_adapter.hpp):
// it finds the noise a sensor really has, within its bounds, from the innovations alone; it
// leaves faulty points out; and with the EKF on a random walk whose sensor is four times noisier
// than told it brings the filter's NIS back into its band and its sigma back to the truth.
#include "daemon/estimation/noise_adapter.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "daemon/estimation/chi_square.hpp"
#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "tests/unit/estimation/test_models.hpp"

using namespace hvac_twin;
using est::Measurement;
using est::MeasurementReport;
using est::NoiseAdapter;
using est::NoiseAdapterOptions;

namespace {

// n cycles of one point whose innovations have variance hph + actual, offered with `told`.
double learn(NoiseAdapter& a, std::mt19937_64& rng, double hph, double actual, double told, int n,
             bool faulty = false) {
  std::normal_distribution<double> g(0.0, std::sqrt(hph + actual));
  const std::vector<double> told_v{told};
  for (int k = 0; k < n; ++k) {
    const Measurement z{
        .output = 0, .value = 0.0, .variance = a.variance(0, told), .available = true};
    MeasurementReport r;
    r.available = true;
    r.faulty = faulty;
    r.innovation = g(rng);
    r.innovation_variance = hph + z.variance;
    r.test_ratio = r.innovation * r.innovation / r.innovation_variance;
    r.rejected = r.test_ratio > 10.83;
    r.fused = !r.rejected;
    a.observe({&z, 1}, {&r, 1}, told_v);
  }
  return a.factor(0);
}

}  // namespace

TEST_CASE("covariance matching finds the sensor's noise, within its bounds", "[noise_adapter]") {
  std::mt19937_64 rng(7);
  const NoiseAdapterOptions o{
      .window_cycles = 2000, .min_samples = 50, .min_factor = 0.25, .max_factor = 9.0};
  SECTION("four times the told variance") {
    NoiseAdapter a(1, o);
    CHECK(learn(a, rng, 0.5, 4.0, 1.0, 20, false) == 1.0);  // too few samples: told as is
    CHECK(learn(a, rng, 0.5, 4.0, 1.0, 4000) == Approx(4.0).epsilon(0.1));
  }
  SECTION("half the told variance, and far below the floor") {
    NoiseAdapter a(1, o);
    CHECK(learn(a, rng, 0.5, 0.5, 1.0, 4000) == Approx(0.5).epsilon(0.1));
    NoiseAdapter b(1, o);
    CHECK(learn(b, rng, 0.5, 0.01, 1.0, 4000) == 0.25);
  }
  SECTION("a hundred times: the bound") {
    NoiseAdapter a(1, o);
    CHECK(learn(a, rng, 0.5, 100.0, 1.0, 4000) == 9.0);
  }
  SECTION("a faulty point teaches nothing") {
    NoiseAdapter a(1, o);
    CHECK(learn(a, rng, 0.5, 100.0, 1.0, 4000, true) == 1.0);
  }
}

// The daemon holds each update's samples kLostAfterUpdates updates and discards them when the
// track turns out lost (unit_pipeline.cpp): absurd readings fused or clipped before the loss was
// declared taught the adapter a noise no sensor had, and the filter told that noise recovered
// slower (lost_track_test: the discharge pressure 2.3 sigma RMS off after the fault, 1.5 now).
TEST_CASE("held samples are learnt late, and not at all once discarded", "[noise_adapter]") {
  const NoiseAdapterOptions o{.window_cycles = 500,
                              .min_samples = 20,
                              .min_factor = 1.0,
                              .max_factor = 9.0,
                              .clip = 10.83,
                              .hold_updates = 2};
  const std::vector<double> told_v{1.0};
  // One update of one point, offered with its told variance 1 and H P- H' 0.5.
  const auto feed = [&](NoiseAdapter& a, double innovation) {
    const Measurement z{.output = 0, .value = 0.0, .variance = 1.0, .available = true};
    MeasurementReport r;
    r.available = true;
    r.innovation = innovation;
    r.innovation_variance = 1.5;
    r.test_ratio = innovation * innovation / 1.5;
    r.rejected = r.test_ratio > 10.83;
    r.fused = !r.rejected;
    a.observe({&z, 1}, {&r, 1}, told_v);
  };
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, std::sqrt(2.5));  // the sensor's noise twice as told
  std::vector<double> normal(150);
  for (double& v : normal)
    v = g(rng);
  NoiseAdapter clean(1, o), lost(1, o), kept(1, o);
  for (std::size_t k = 0; k < 100; ++k)
    for (NoiseAdapter* a : {&clean, &lost, &kept})
      feed(*a, normal[k]);
  for (NoiseAdapter* a : {&lost, &kept})  // the fault: two absurd readings
    for (int k = 0; k < 2; ++k)
      feed(*a, 1e3);
  feed(clean, normal[100]);
  feed(clean, normal[101]);
  // `clean` has now learnt the 100 normal samples, and so has `lost`: the absurd ones are held.
  CHECK(lost.factor(0) == clean.factor(0));
  lost.discard_held();
  for (std::size_t k = 102; k < 150; ++k)
    feed(clean, normal[k]);
  for (std::size_t k = 100; k < 150; ++k)
    for (NoiseAdapter* a : {&lost, &kept})
      feed(*a, normal[k]);
  // Both have learnt normal[0..147] (the last two held), in the same order; `kept` also learnt the
  // two absurd readings, each clipped at the gate (10.83 S): 0.18 more on a factor of 2.
  CHECK(lost.factor(0) == clean.factor(0));
  CHECK(lost.factor(0) == Approx(2.0).epsilon(0.3));
  CHECK(kept.factor(0) > clean.factor(0) + 0.1);
}

TEST_CASE("a report's test ratio against the told noise", "[noise_adapter]") {
  MeasurementReport r;
  r.innovation = 3.0;
  r.innovation_variance = 1.0 + 4.0;  // H P H' 1, adapted R 4
  CHECK(NoiseAdapter::told_test_ratio(r, 4.0, 1.0) == Approx(9.0 / 2.0));
}

TEST_CASE("with the EKF: a sensor four times noisier than told, NIS back in band",
          "[noise_adapter]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const double sigma_q = 0.05, dt = 10.0, told = 0.25, actual = 1.0;
  const int n = 3000, scored_from = 1000;
  const auto run = [&](double max_factor, double& mean_nis, double& rms_z) {
    est::Ekf ekf(model, std::vector<double>{sigma_q}, 1, est::EkfOptions{});
    ekf.reset(std::vector<double>{0.0}, std::vector<double>{1.0});
    NoiseAdapter adapter(
        1,
        NoiseAdapterOptions{
            .window_cycles = 500, .min_samples = 50, .min_factor = 1.0, .max_factor = max_factor});
    std::mt19937_64 rng(11);
    std::normal_distribution<double> g(0.0, 1.0);
    double truth = 0.0, nis = 0.0, z2 = 0.0;
    const std::vector<double> told_v{told};
    for (int k = 0; k < n; ++k) {
      truth += sigma_q * std::sqrt(dt) * g(rng);
      REQUIRE(ekf.predict({}, dt) == est::StepStatus::kOk);
      const Measurement m{.output = 0,
                          .value = truth + std::sqrt(actual) * g(rng),
                          .variance = adapter.variance(0, told),
                          .available = true};
      MeasurementReport rep;
      REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      adapter.observe({&m, 1}, {&rep, 1}, told_v);
      if (k < scored_from) continue;
      nis += rep.test_ratio;
      const double e = ekf.state()(0) - truth;
      z2 += e * e / ekf.covariance()(0, 0);
    }
    mean_nis = nis / (n - scored_from);
    rms_z = std::sqrt(z2 / (n - scored_from));
    return adapter.factor(0);
  };
  const double k = n - scored_from;  // the 95 % band of the mean of k NIS
  const struct {
    double low, high;
  } band{est::chi_square_quantile(k, 0.025) / k, est::chi_square_quantile(k, 0.975) / k};
  double nis_off = 0.0, z_off = 0.0, nis_on = 0.0, z_on = 0.0;
  CHECK(run(1.0, nis_off, z_off) == 1.0);  // off: as told
  const double f = run(9.0, nis_on, z_on);
  INFO("factor " << f << "; NIS off " << nis_off << ", on " << nis_on << " [" << band.low << ", "
                 << band.high << "]; RMS error/sigma off " << z_off << ", on " << z_on);
  CHECK(nis_off > band.high);
  CHECK(f == Approx(actual / told).epsilon(0.15));
  // Not the exact band: the innovations of the adapting filter are mildly autocorrelated.
  CHECK(nis_on > 0.85);
  CHECK(nis_on < 1.15);
  CHECK(z_off > 1.3);
  CHECK(z_on == Approx(1.0).epsilon(0.15));
}
