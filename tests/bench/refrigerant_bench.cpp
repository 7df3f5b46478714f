// refrigerant_bench: accuracy and speed of the R32 (p, h) tables against the reference EOS.
//
//   refrigerant_bench           long run (dense validation grid, ~1 min in Release)
//   refrigerant_bench --short   CI run (seconds)
//
// Prints: table build time and size; the largest relative errors of rho and T and of the h round
// trip (EOS enthalpy of the table's (T, rho)) per region on a validation grid that avoids the
// table nodes, plus a band hugging the saturation curve; calls per second of the table (double
// and Dual<8>) and of the EOS flash. Exit code 1 if density misses the 0.1 % target outside
// the near-critical region.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "plant_models/core/dual.hpp"
#include "plant_models/refrigerant/r32_eos.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

namespace r32 = hvac_twin::plant::r32;
using hvac_twin::plant::Dual;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

enum Bucket { kLiquid, kTwoPhase, kVapour, kNearCritical, kBuckets };
const char* const kBucketNames[kBuckets] = {"liquid", "two-phase", "vapour", "near-critical"};

struct Errors {
  long n = 0;
  double rho = 0, T = 0, h = 0, x = 0;
  double at_p = 0, at_h = 0;  // where the worst density error is
};

// EOS enthalpy of the table's (T, rho): single phase directly; two phase via the lever rule on
// the EOS saturation state at T.
double h_round_trip(const r32::PhState<double>& r) {
  if (r.region != r32::Region::kTwoPhase) return r32::properties_trho(r.T, r.rho).h;
  const r32::Saturation s = r32::saturation_t(r.T);
  const double x = (1 / r.rho - 1 / s.liquid.rho) / (1 / s.vapour.rho - 1 / s.liquid.rho);
  return s.liquid.h + x * (s.vapour.h - s.liquid.h);
}

void accumulate(const r32::PhTable& t, double p, double h, Errors* e, long& mismatches,
                long& failures) {
  const r32::PhState<double> r = t.ph(p, h);
  const r32::FlashResult f = r32::flash_ph(p, h);
  if (r.status != r32::Status::kOk || f.status != r32::Status::kOk) {
    ++failures;
    return;
  }
  Bucket b = f.phase == r32::Phase::kLiquid   ? kLiquid
             : f.phase == r32::Phase::kVapour ? kVapour
                                              : kTwoPhase;
  if (p > 5.0e6 || std::abs(f.T - r32::kTc) < 3.0) b = kNearCritical;
  const bool two_phase_eos = f.phase == r32::Phase::kTwoPhase;
  if (two_phase_eos != (r.region == r32::Region::kTwoPhase)) ++mismatches;
  Errors& E = e[b];
  ++E.n;
  const double er = std::abs(r.rho / f.rho - 1);
  if (er > E.rho) {
    E.rho = er;
    E.at_p = p;
    E.at_h = h;
  }
  E.T = std::max(E.T, std::abs(r.T / f.T - 1));
  E.h = std::max(E.h, std::abs(h_round_trip(r) - h) / std::abs(h));
  if (two_phase_eos) E.x = std::max(E.x, std::abs(r.quality - f.quality));
}

template <class F>
double calls_per_second(long n, F&& f) {
  const auto t0 = Clock::now();
  f();
  return static_cast<double>(n) / seconds_since(t0);
}

}  // namespace

int main(int argc, char** argv) {
  const bool short_run = argc > 1 && std::strcmp(argv[1], "--short") == 0;
  std::printf("refrigerant_bench (%s)\n", short_run ? "--short" : "long");

  // --- Build cost and footprint --------------------------------------------------------------
  const auto t0 = Clock::now();
  const r32::PhTable& t = r32::ph_table();
  const double build_s = seconds_since(t0);
  std::printf("table build (first call of ph_table): %.3f s, status %d, %zu bytes (%.0f KiB)\n",
              build_s, r32::callback_code(t.build_status()), r32::PhTable::memory_bytes(),
              static_cast<double>(r32::PhTable::memory_bytes()) / 1024.0);
  if (t.build_status() != r32::Status::kOk) return 1;

  // --- Accuracy against the EOS flash --------------------------------------------------------
  const int NP = short_run ? 60 : 300;
  const int NH = short_run ? 120 : 600;
  const int NB = short_run ? 8 : 24;  // points per side in the band at the saturation curve
  Errors e[kBuckets];
  long mismatches = 0;
  long failures = 0;
  const double lp0 = std::log(r32::PhTable::kPmin);
  const double lp1 = std::log(r32::PhTable::kPmax);
  const auto ta = Clock::now();
  for (int a = 0; a < NP; ++a) {
    // Irrational offsets keep the grid off the table nodes.
    const double p = std::exp(lp0 + (lp1 - lp0) * (a + 0.3819660) / NP);
    const double lo = t.h_min(p);
    const double hi = t.h_max(p);
    for (int b = 0; b < NH; ++b) {
      accumulate(t, p, lo + (hi - lo) * (b + 0.6180340) / NH, e, mismatches, failures);
    }
    const r32::SatState<double> s = t.sat_p(p);
    for (int k = 1; k <= NB; ++k) {
      const double dh = 1e-7 * std::pow(10.0, 4.0 * k / NB) * (s.h_v - s.h_l);  // 1e-7 ... 1e-3
      for (double hb : {s.h_l, s.h_v}) {
        accumulate(t, p, hb - dh, e, mismatches, failures);
        accumulate(t, p, hb + dh, e, mismatches, failures);
      }
    }
  }
  const double accuracy_s = seconds_since(ta);
  std::printf(
      "\nvalidation: %d pressures x (%d enthalpies + %d near saturation), off-node; "
      "near-critical = p > 5.0 MPa or |T - Tc| < 3 K\n",
      NP, NH, 4 * NB);
  std::printf("%-14s %8s %11s %11s %11s %11s   worst rho at (p [MPa], h [kJ/kg])\n", "region",
              "points", "rho rel", "T rel", "h rt rel", "quality");
  for (int b = 0; b < kBuckets; ++b) {
    std::printf("%-14s %8ld %11.2e %11.2e %11.2e %11.2e   (%.4f, %.2f)\n", kBucketNames[b], e[b].n,
                e[b].rho, e[b].T, e[b].h, e[b].x, e[b].at_p / 1e6, e[b].at_h / 1e3);
  }
  std::printf(
      "phase disagreements (table vs EOS two-phase flag): %ld; failed calls: %ld; "
      "(%.1f s)\n",
      mismatches, failures, accuracy_s);

  // --- Speed ---------------------------------------------------------------------------------
  const long n_table = short_run ? 200000 : 4000000;
  const long n_eos = short_run ? 2000 : 40000;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<double> P(static_cast<std::size_t>(n_table));
  std::vector<double> H(P.size());
  for (std::size_t k = 0; k < P.size(); ++k) {
    P[k] = std::exp(lp0 + (lp1 - lp0) * u01(rng));
    H[k] = t.h_min(P[k]) + (t.h_max(P[k]) - t.h_min(P[k])) * u01(rng);
  }
  double sink = 0.0;
  const double cps_table = calls_per_second(n_table, [&] {
    for (std::size_t k = 0; k < P.size(); ++k) {
      const r32::PhState<double> r = t.ph(P[k], H[k]);
      sink += r.rho + r.T + r.drho_dh_p;
    }
  });
  const double cps_dual = calls_per_second(n_table, [&] {
    for (std::size_t k = 0; k < P.size(); ++k) {
      Dual<8> p(P[k]);
      Dual<8> h(H[k]);
      p.d[0] = 1.0;
      h.d[1] = 1.0;
      const r32::PhState<Dual<8>> r = t.ph(p, h);
      sink += r.rho.d[1] + r.drho_dh_p.d[0];
    }
  });
  const double cps_sat = calls_per_second(n_table, [&] {
    for (std::size_t k = 0; k < P.size(); ++k)
      sink += t.sat_p(P[k]).T;
  });
  const double cps_eos = calls_per_second(n_eos, [&] {
    for (std::size_t k = 0; k < static_cast<std::size_t>(n_eos); ++k)
      sink += r32::flash_ph(P[k], H[k]).rho;
  });
  std::printf("\nspeed (random (p, h) over the table range, one core):\n");
  std::printf("  table ph<double>   %12.3g calls/s  (%.0f ns/call)\n", cps_table, 1e9 / cps_table);
  std::printf("  table ph<Dual<8>>  %12.3g calls/s  (%.0f ns/call)\n", cps_dual, 1e9 / cps_dual);
  std::printf("  table sat_p<double>%12.3g calls/s  (%.0f ns/call)\n", cps_sat, 1e9 / cps_sat);
  std::printf("  EOS flash_ph       %12.3g calls/s  (%.0f ns/call)\n", cps_eos, 1e9 / cps_eos);
  std::printf("  table / EOS speed-up: %.0fx\n", cps_table / cps_eos);
  std::printf("(checksum %.6g)\n", sink);

  bool ok = failures == 0;
  for (int b = 0; b < kNearCritical; ++b)
    ok = ok && e[b].rho < 1e-3;
  std::printf("%s\n", ok ? "PASS: density within 0.1 % outside the near-critical region"
                         : "FAIL: density target missed or calls failed");
  return ok ? 0 : 1;
}
