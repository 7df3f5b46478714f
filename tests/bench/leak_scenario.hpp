// The leak acceptance scenarios (issue 5, item 4), in process and time-accelerated: the truth of
// heat_pump_scenario.hpp operated day after day, the constrained EKF on the 10-cell model with
// the leak rate augmented, and the LeakDetector on the filter's charge and leak-rate estimates.
// Shared by leak_bench (the long form, a table) and leak_acceptance_test (the short form,
// assertions).
//
// Operation, on top of the simulator's scenario (outdoor temperature cycle 24-36 degC, internal
// gains re-drawn every 3 h, zone setpoint 24 degC by day and 26 degC at night with a PI loop on
// the compressor speed in 20-90 Hz, superheat PI on the valve): the unit is switched off for a
// night set-back (compressor and outdoor fan off, the zone floats) and cycles on and off for an
// hour in the evening, as a thermostat at minimum speed does at low load. Both are what the
// detector must hold through (compressor off, start-up, cycling). While off, the expansion
// valve is closed, as inverter splits close theirs at a stop: with the scenario's valve left
// open the pressures equalise, and neither model survives that today (the 20-cell truth failed
// in CVODES within minutes of a stop; the filter's predictions failed from the first stop on
// and never recovered: 2018 failed steps in 4.8 h).
//
// Header-only; benchmarks and tests only (allocates freely).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include "daemon/estimation/commissioning.hpp"
#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/leak_detector.hpp"
#include "daemon/estimation/track_monitor.hpp"
#include "daemon/runtime/leak_options.hpp"
#include "plant_models/catalog.hpp"
#include "tests/bench/heat_pump_scenario.hpp"

namespace hvac_twin::bench {

// On/off operation in clock hours (the scenario's day starts at 08:00, t = 0).
struct Operation {
  bool enabled = true;
  double off_from_h = 1.0, off_to_h = 5.0;         // switched off: night set-back
  double cycle_from_h = 22.0, cycle_to_h = 23.0;   // cycling at low load
  double cycle_on_s = 360.0, cycle_off_s = 360.0;  // 4-5 starts per hour: "cycling"
  double off_valve = 0.0;  // valve opening while off (negative: the scenario's controller)

  // For short runs: 45 min of cycling from `clock_h` (5 min on, 5 min off: the fourth start
  // within the hour comes after 40 min), then 30 min off.
  static Operation early(double clock_h) {
    Operation o;
    o.cycle_on_s = o.cycle_off_s = 300.0;
    o.cycle_from_h = clock_h;
    o.cycle_to_h = clock_h + 0.75;
    o.off_from_h = clock_h + 0.75;
    o.off_to_h = clock_h + 1.25;
    return o;
  }

  // Whether the compressor runs over [t, t + period).
  [[nodiscard]] bool running(double t) const {
    if (!enabled) return true;
    const double h = std::fmod(8.0 + t / 3600.0, 24.0);
    if (h >= off_from_h && h < off_to_h) return false;
    if (h >= cycle_from_h && h < cycle_to_h) {
      const double into = (h - cycle_from_h) * 3600.0;
      return std::fmod(into, cycle_on_s + cycle_off_s) < cycle_on_s;
    }
    return true;
  }
};

struct LeakRunOptions {
  double days = 1.0;
  double period_s = 5.0;
  double leak_g_per_h = 0.0;  // truth leak from leak_start_s on
  double leak_start_s = 0.0;
  double leak_duration_s = 0.0;  // > 0: the leak stops after this long (a sudden loss)
  bool stop_at_leak = false;     // end the run when LEAK is raised after the leak started
  std::uint64_t seed = 1;        // the scenario's (internal gains); sensor noise has its own
  std::uint64_t noise_seed = 7;
  Operation operation;
  est::LeakDetectorOptions detector;
  double score_after_s = 7200.0;  // charge and heat-flow errors count from here (convergence)
  std::FILE* trace = nullptr;     // a CSV line per trace_every_s when set
  double trace_every_s = 300.0;
  // When set, the first failed prediction of each run of failures: the time, CVODES's message
  // and the filter's state and inputs before it (one line each), to replay it alone.
  std::FILE* failure_dump = nullptr;
};

// One decision of the detector: its interval means, what it judged, and the truth then.
struct LeakDecision {
  double t_s = 0.0;
  double z = 0.0;  // the leak-rate statistic, beyond the detector's rate allowance [sigma]
  double charge = 0.0, charge_sigma = 0.0, speed_hz = 0.0;  // interval means [kg], [Hz]
  double reference = -1.0;  // C_ref of the band [kg]; -1: not judged on the charge
  double zc = 0.0;          // the charge-deficit statistic when judged [sigma]
  double truth_charge = 0.0;
  bool leaking = false;  // the truth leaked during the interval's end
  // The interval's means of the leak-rate estimate [g/h], of 1 / max(sigma, floor) and of
  // leak / max(sigma, floor): z = z_raw - allowance * inv_sigma, for replays with another one.
  double rate_gph = 0.0, inv_sigma = 0.0, z_raw = 0.0;
};

struct LeakRunResult {
  double simulated_s = 0.0, wall_s = 0.0;
  double step_ms_median = 0.0;
  long steps = 0, filter_failures = 0;
  long restarts = 0;              // filter restarts from the measured conditions, as the daemon's
  long lost_updates = 0;          // updates in which the filter had lost track (TrackMonitor)
  long covariance_resets = 0;     // the EKF's own (lost track, re-admission)
  bool leak_raised = false;       // LEAK after the leak started (or at all, without a leak)
  double leak_delay_s = -1.0;     // from the leak's start to LEAK
  double suspect_delay_s = -1.0;  // from the leak's start to SUSPECT or LEAK
  int false_suspect = 0, false_leak = 0;  // alarms raised while the truth did not leak
  // Charge estimate against truth after score_after_s [kg]: mean |e| and largest |e|,
  // and the charge the filter lost against the truth's loss since the leak started.
  double charge_mae = 0.0, charge_max = 0.0;
  // The same for the charge referred to commissioning: the charge weighed in at commissioning
  // plus the estimate's change against the detector's reference of the current speed band,
  // charge_commissioned + (estimate - C_ref(band)); scored once the references are learnt,
  // while running and not in start-up (the bands are judged there).
  double referred_mae = 0.0, referred_max = 0.0;
  double truth_loss_kg = 0.0, est_loss_kg = 0.0;
  // Largest departure of the charge estimate within a stop from its value at the stop carried
  // on by the leak-rate estimate then: how far the updates move the charge at rest, where no
  // sensor sees it (the high side two-phase at its temperature's saturation pressure) [kg].
  double stopped_drift_max = 0.0;
  double leak_est_mean = 0.0;  // mean leak-rate estimate while judgeable after the leak start
  double leak_sigma_mean = 0.0;
  // Heat flows, scored while the compressor ran (after score_after_s, not in start-up).
  double qc_mae = 0.0, qc_mape = 0.0, qe_mae = 0.0, qe_mape = 0.0;
  std::array<double, 6> held_s{};  // per est::HoldReason
  std::uint64_t decisions = 0;
  std::uint64_t charge_decisions = 0;  // decisions that judged the charge deficit
  est::LeakReport last;
  std::vector<LeakDecision> decision_log;
};

// What the daemon runs: the model layout's noise and bounds (set for leak detection in
// plant_models/heat_pump/heat_pump.cpp, from runs of this benchmark), and the detector as the
// daemon builds it from its configuration's defaults (config/config.hpp, LeakDetectionConfig;
// runtime::leak_detector_options): the charge-deficit CUSUM with an allowance of 2 % of the
// nameplate charge (10 g), counted in units of its in-control noise (0.6 %, 3 g), over
// speed-band references averaged over 18 h of judgeable operation, and a 0.1 g/h sigma floor.
// Before the layout was set so (charge random walk 1e-6 kg/sqrt(s), leak rate >= 0 at 0.01
// g/h/sqrt(s), charge <= nameplate) a 46 g loss moved the charge estimate by 3 g and 22 h of a 2.08
// g/h leak raised no alarm.
//
// The nameplate charge of heat_pump_r32 at its default parameters, truth and filter alike [kg].
inline constexpr double kNameplateChargeKg = 0.5;

inline LeakRunOptions daemon_settings() {
  LeakRunOptions o;
  o.detector = runtime::leak_detector_options(config::LeakDetectionConfig{}, kNameplateChargeKg);
  return o;
}

// The short form (CI) of a setting: the same filter, the detector compressed into hours. Warm-up
// 30 min (the filter's charge and heat flows settle within minutes; what still moves after is
// the operating point, which the speed bands take), references over the next 30 min, a decision
// per 15 min of judgeable operation (the threshold follows the designed false-alarm rate:
// 5.9 sigma), 45 min of cycling from 2 h and 30 min off from 2.75 h.
inline LeakRunOptions short_form(LeakRunOptions o) {
  o.detector.warm_up_s = 1800.0;
  o.detector.reference_s = 1800.0;
  o.detector.interval_s = 900.0;
  o.operation = Operation::early(10.0);
  return o;
}

inline LeakRunResult run_leak_scenario(const LeakRunOptions& o) {
  using namespace plant::hp;
  using Clock = std::chrono::steady_clock;
  sim::ScenarioOptions so;
  so.seed = o.seed;
  so.leak_g_per_h = o.leak_g_per_h;
  so.leak_start_s = o.leak_g_per_h > 0.0 ? o.leak_start_s : 1e30;
  if (o.leak_duration_s > 0.0) so.leak_end_s = so.leak_start_s + o.leak_duration_s;
  HeatPumpTruth truth(so, o.noise_seed);
  truth.failure_dump = o.failure_dump;
  std::unique_ptr<plant::ContinuousModel> model =
      plant::create_model("heat_pump_r32", filter_parameters());
  const auto& layout = model->layout();
  std::vector<double> q = layout_process_noise(*model);
  est::EkfOptions eo;
  eo.constrained = true;
  est::Ekf ekf(*model, q, kMeasured.size(), eo);
  // The parameters held after the start and released, as the daemon holds and releases them
  // (estimator.parameter_hold_s, parameter_release_s).
  const config::EstimatorConfig defaults;
  const est::StatePhases phases(layout, {}, defaults.parameter_hold_s, 0.0,
                                defaults.parameter_release_s);
  constexpr int kRestartAfterFailedPredictions = 6;
  int failed_predictions = 0;
  bool restart_lost = false;  // the filter lost track kRestartAfterLostUpdates updates in a row
  est::TrackMonitor track(est::kLostAfterUpdates, est::kRestartAfterLostUpdates);
  double phases_from = 0.0;  // model time of the last (re)start
  Eigen::VectorXd x_before;  // the state before the predict (failure_dump)
  est::LeakDetector detector(o.detector);
  const plant::ModelLayout& truth_layout = truth.model().layout();
  const std::size_t truth_charge = *truth_layout.state("charge");
  const std::size_t truth_leak = *truth_layout.state("leak_rate");
  const std::size_t truth_m_cond = *truth_layout.state("M_cond");
  const auto i_m_cond = static_cast<Eigen::Index>(*layout.state("M_cond"));
  const auto i_charge = static_cast<Eigen::Index>(*layout.state("charge"));
  const auto i_leak = static_cast<Eigen::Index>(*layout.state("leak_rate"));
  double charge_at_stop = -1.0, leak_at_stop = 0.0, stopped_at = 0.0;

  std::vector<double> y(model->num_outputs()), sigma(model->num_outputs()),
      own_sigma(model->num_outputs());
  std::vector<est::MeasurementReport> reports(kMeasured.size());
  AdaptedMeasurements offered(o.period_s);  // the daemon's adaptive noise, when on
  std::vector<double> step_ms;
  LeakRunResult r;
  const auto wall0 = Clock::now();
  const long steps = std::lround(o.days * 86400.0 / o.period_s);
  double last_start = -1e30;
  bool prev_running = false;
  double rate_sum = 0.0, inv_sigma_sum = 0.0, z_raw_sum = 0.0, judged_s = 0.0;  // decision log
  est::LeakState prev_state = est::LeakState::kNormal;
  double truth_charge_at_leak = -1.0, est_charge_at_leak = -1.0;
  long charge_n = 0, q_n = 0, leak_n = 0, referred_n = 0;
  const double commissioned = truth.x()[truth_charge];
  if (o.trace != nullptr)
    std::fprintf(o.trace,
                 "t_h,speed_hz,charge_truth_kg,charge_est_kg,charge_sigma_kg,leak_truth_gph,"
                 "leak_est_gph,leak_sigma_gph,cusum,state,hold,qc_truth_W,qc_est_W,qe_truth_W,"
                 "qe_est_W,sc_truth,sc_est,sh_truth,sh_est,fouling,qint_truth,qint_est,mcond_truth,"
                 "mcond_est,running,filter_failures");
  // Every augmented state the filter estimates (the parameters and the leak rate), by name.
  std::vector<Eigen::Index> augmented;
  for (std::size_t i = 0; i < layout.states.size(); ++i)
    if (layout.states[i].augmented) augmented.push_back(static_cast<Eigen::Index>(i));
  if (o.trace != nullptr) {
    for (const Eigen::Index i : augmented)
      std::fprintf(o.trace, ",%s", layout.states[static_cast<std::size_t>(i)].name.c_str());
    std::fprintf(o.trace, "\n");
  }
  for (long k = 0; k < steps; ++k) {
    const double t = static_cast<double>(k) * o.period_s;
    std::vector<double>& u = truth.drive(t, o.period_s);
    const bool running = o.operation.running(t);
    if (!running) {
      u[kCompressorSpeed] = 0.0;
      u[kOutdoorFan] = 0.0;
      if (o.operation.off_valve >= 0.0) u[kValveOpening] = o.operation.off_valve;
    }
    if (running && !prev_running) last_start = t;
    if (!running && prev_running) {
      charge_at_stop = ekf.state()(i_charge);
      leak_at_stop = ekf.state()(i_leak) / 3.6e6;  // g/h -> kg/s
      stopped_at = t;
    }
    if (!running && charge_at_stop >= 0.0) {
      const double held = charge_at_stop - leak_at_stop * (t - stopped_at);
      r.stopped_drift_max = std::max(r.stopped_drift_max, std::abs(ekf.state()(i_charge) - held));
    }
    prev_running = running;
    truth.advance(o.period_s);
    const double t_end = t + o.period_s;
    const auto& z = offered.offer(truth.measurements());

    bool ok = true;
    const auto t0 = Clock::now();
    if (k == 0 || failed_predictions >= kRestartAfterFailedPredictions || restart_lost) {
      // A start, or a restart from the measured conditions after predictions kept failing, as
      // the daemon does (UnitPipeline::kRestartAfterFailedPredictions), parameters held anew.
      if (k > 0) ++r.restarts;
      restart_lost = false;
      start_filter(*model, ekf, u, truth.y_measured());
      phases_from = t;
      failed_predictions = 0;
      phases.apply(ekf, 0.0, u);
    } else {
      phases.apply(ekf, t - phases_from, u);
      if (o.failure_dump != nullptr) x_before = ekf.state();
      ok = ekf.predict(u, o.period_s) == est::StepStatus::kOk;
      if (!ok && failed_predictions == 0 && o.failure_dump != nullptr)
        dump_failure(o.failure_dump, t, "filter", ekf.integrator().last_error(), x_before, u);
      failed_predictions = ok ? 0 : failed_predictions + 1;
    }
    const auto resets_before = ekf.counters().covariance_resets;
    ok = ekf.update(z, u, reports) == est::StepStatus::kOk && ok;
    // Lost track, as the daemon judges it; its restart here at the next step.
    const bool covariance_reset = ekf.counters().covariance_resets != resets_before;
    const est::TrackStep track_step = track.observe(reports, covariance_reset);
    offered.observe(reports, track_step.lost || covariance_reset || track_step.restart_due);
    r.lost_updates += track_step.lost ? 1 : 0;
    restart_lost = track_step.restart_due;
    ok = ekf.output_estimates(u, y, sigma, own_sigma) == plant::kModelOk && ok;
    step_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (!ok) ++r.filter_failures;
    bool fused = false;
    for (const auto& rep : reports)
      fused = fused || rep.fused;

    // The sigmas as the daemon passes them (unit_pipeline_leak.cpp): the leak rate's published,
    // the charge's the filter's own.
    const est::LeakReport& rep =
        detector.step(t_end, y[kLeakRate], sigma[kLeakRate], y[kCharge], own_sigma[kCharge],
                      u[kCompressorSpeed], !ok || !fused);
    r.held_s[static_cast<std::size_t>(rep.hold)] += o.period_s;
    const bool leaking = o.leak_g_per_h > 0.0 && t_end > o.leak_start_s;
    // The interval's rate means, accumulated as the detector does (a held cycle discards them).
    if (rep.hold != est::HoldReason::kNone) {
      rate_sum = inv_sigma_sum = z_raw_sum = judged_s = 0.0;
    } else {
      const double s = std::max(sigma[kLeakRate], o.detector.sigma_floor);
      rate_sum += o.period_s * y[kLeakRate];
      inv_sigma_sum += o.period_s / s;
      z_raw_sum += o.period_s * y[kLeakRate] / s;
      judged_s += o.period_s;
    }
    if (rep.decisions > r.decisions) {
      r.decisions = rep.decisions;
      if (rep.charge_reference > 0.0) ++r.charge_decisions;
      LeakDecision d{t_end,
                     rep.statistic,
                     rep.interval_charge,
                     rep.interval_charge_sigma,
                     rep.interval_speed_hz,
                     rep.charge_reference,
                     rep.charge_statistic,
                     truth.x()[truth_charge],
                     leaking};
      d.rate_gph = rate_sum / judged_s;
      d.inv_sigma = inv_sigma_sum / judged_s;
      d.z_raw = z_raw_sum / judged_s;
      r.decision_log.push_back(d);
      rate_sum = inv_sigma_sum = z_raw_sum = judged_s = 0.0;
    }
    if (rep.state != prev_state && rep.state != est::LeakState::kNormal) {
      if (!leaking) {
        if (rep.state == est::LeakState::kSuspect) ++r.false_suspect;
        if (rep.state == est::LeakState::kLeak) ++r.false_leak;
      } else {
        if (r.suspect_delay_s < 0.0) r.suspect_delay_s = t_end - o.leak_start_s;
        if (rep.state == est::LeakState::kLeak && r.leak_delay_s < 0.0) {
          r.leak_delay_s = t_end - o.leak_start_s;
          r.leak_raised = true;
        }
      }
    }
    if (o.leak_g_per_h <= 0.0 && rep.state == est::LeakState::kLeak) r.leak_raised = true;
    prev_state = rep.state;

    const double ct = truth.x()[truth_charge], ce = y[kCharge];
    if (leaking && truth_charge_at_leak < 0.0) {
      truth_charge_at_leak = ct;
      est_charge_at_leak = ce;
    }
    if (truth_charge_at_leak >= 0.0) {
      r.truth_loss_kg = truth_charge_at_leak - ct;
      r.est_loss_kg = est_charge_at_leak - ce;
    }
    if (leaking && rep.hold == est::HoldReason::kNone) {
      r.leak_est_mean += y[kLeakRate];
      r.leak_sigma_mean += sigma[kLeakRate];
      ++leak_n;
    }
    if (t_end >= o.score_after_s) {
      const double e = ce - ct;
      r.charge_mae += std::abs(e);
      r.charge_max = std::max(r.charge_max, std::abs(e));
      ++charge_n;
      const auto& yt = truth.y();
      const double ref = detector.reference_charge(u[kCompressorSpeed]);
      if (running && t - last_start >= o.detector.startup_s && ref > 0.0) {
        const double er = commissioned + (ce - ref) - ct;
        r.referred_mae += std::abs(er);
        r.referred_max = std::max(r.referred_max, std::abs(er));
        ++referred_n;
      }
      if (running && t - last_start >= o.detector.startup_s) {
        r.qc_mae += std::abs(y[kCondenserHeatFlow] - yt[kCondenserHeatFlow]);
        r.qe_mae += std::abs(y[kEvaporatorHeatFlow] - yt[kEvaporatorHeatFlow]);
        r.qc_mape += std::abs(y[kCondenserHeatFlow] / yt[kCondenserHeatFlow] - 1.0);
        r.qe_mape += std::abs(y[kEvaporatorHeatFlow] / yt[kEvaporatorHeatFlow] - 1.0);
        ++q_n;
      }
    }
    if (o.trace != nullptr && std::fmod(t_end, o.trace_every_s) < 0.5 * o.period_s) {
      const auto& yt = truth.y();
      std::fprintf(o.trace,
                   "%.4f,%.1f,%.5f,%.5f,%.5f,%.3f,%.3f,%.3f,%.3f,%d,%d,%.0f,%.0f,%.0f,%.0f",
                   t_end / 3600.0, u[kCompressorSpeed], ct, ce, sigma[kCharge],
                   truth.x()[truth_leak], y[kLeakRate], sigma[kLeakRate], rep.cusum,
                   static_cast<int>(rep.state), static_cast<int>(rep.hold), yt[kCondenserHeatFlow],
                   y[kCondenserHeatFlow], yt[kEvaporatorHeatFlow], y[kEvaporatorHeatFlow]);
      std::fprintf(o.trace, ",%.2f,%.2f,%.2f,%.2f,%.4f,%.0f,%.0f,%.5f,%.5f,%d,%ld", yt[kSubcooling],
                   y[kSubcooling], yt[kSuperheat], y[kSuperheat], y[kOutdoorCoilFouling],
                   yt[kInternalGains], y[kInternalGains], truth.x()[truth_m_cond],
                   ekf.state()(i_m_cond), running ? 1 : 0, r.filter_failures);
      for (const Eigen::Index i : augmented)
        std::fprintf(o.trace, ",%.5g", ekf.state()(i));
      std::fprintf(o.trace, "\n");
      std::fflush(o.trace);
    }
    r.simulated_s = t_end;
    ++r.steps;
    if (o.stop_at_leak && r.leak_delay_s >= 0.0) break;
  }
  r.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  std::sort(step_ms.begin(), step_ms.end());
  r.step_ms_median = step_ms.empty() ? 0.0 : step_ms[step_ms.size() / 2];
  const auto mean = [](double& v, long n) { v = n > 0 ? v / static_cast<double>(n) : 0.0; };
  mean(r.charge_mae, charge_n);
  mean(r.referred_mae, referred_n);
  mean(r.qc_mae, q_n);
  mean(r.qe_mae, q_n);
  mean(r.qc_mape, q_n);
  mean(r.qe_mape, q_n);
  mean(r.leak_est_mean, leak_n);
  mean(r.leak_sigma_mean, leak_n);
  r.last = detector.report();
  r.covariance_resets = static_cast<long>(ekf.counters().covariance_resets);
  return r;
}

}  // namespace hvac_twin::bench
