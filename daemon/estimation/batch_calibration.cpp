#include "daemon/estimation/batch_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "daemon/estimation/steady_state.hpp"
#include "plant_models/core/settling.hpp"

namespace hvac_twin::est {
namespace {

using Eigen::Index;

// The data residuals and their Jacobian at p: every used window's steady state solved from its
// current x (updated when `keep` is set).
struct Evaluation {
  Eigen::VectorXd r;  // (y - h) / sigma, window by window
  Eigen::MatrixXd j;  // dr/dp
  double cost = 0.0;
};

class Fit {
 public:
  Fit(const plant::ContinuousModel& model, CalibrationProblem& problem,
      std::vector<WindowFit>& windows)
      : problem_(problem),
        windows_(windows),
        steady_(model, states_of(problem), problem.known),
        offset_(offsets_of(problem)) {}

  // False if a used window has no steady state at p.
  bool evaluate(const Eigen::VectorXd& p, Evaluation& e, bool keep, bool nominal) {
    const auto np = static_cast<Index>(p.size());
    const std::size_t factors = problem_.parameters.size();
    std::vector<double> rows;
    std::vector<Eigen::RowVectorXd> jrows;
    for (std::size_t w = 0; w < problem_.windows.size(); ++w) {
      if (!windows_[w].used) continue;
      auto& win = problem_.windows[w];
      std::vector<double> x = win.x;
      for (std::size_t k = 0; k < problem_.parameters.size(); ++k)
        x[problem_.parameters[k].state] = p[static_cast<Index>(k)];
      Eigen::VectorXd y;
      Eigen::MatrixXd dy;
      if (!steady_.solve(win.u, x) || !steady_.sensitivities(win.u, x, y, dy)) return false;
      if (keep) win.x = x;
      Eigen::VectorXd fitted(static_cast<Index>(problem_.measured.size()));
      for (std::size_t k = 0; k < problem_.measured.size(); ++k) {
        const auto o = static_cast<Index>(problem_.measured[k]);
        const Index b = offset_[k];
        const double offset = b >= 0 ? p[b] : 0.0;
        fitted[static_cast<Index>(k)] = y[o] + offset;
        const double meas = win.y[problem_.measured[k]];
        // Not measured here, or an output of held states only (the zone air): no information.
        if (!std::isfinite(meas) || dy.row(o).isZero(0.0)) continue;
        const double s = problem_.measured_std[k];
        rows.push_back((meas - y[o] - offset) / s);
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(np);
        row.head(static_cast<Index>(factors)) = -dy.row(o) / s;
        if (b >= 0) row[b] = -1.0 / s;
        jrows.push_back(row);
      }
      if (keep) (nominal ? windows_[w].nominal : windows_[w].fitted) = fitted;
    }
    e.r.resize(static_cast<Index>(rows.size()));
    e.j.resize(static_cast<Index>(rows.size()), np);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      e.r[static_cast<Index>(i)] = rows[i];
      e.j.row(static_cast<Index>(i)) = jrows[i];
    }
    e.cost = e.r.squaredNorm();
    return true;
  }

  // At the prior: the windows whose steady state exists (the others left out, saying why).
  std::size_t select(const Eigen::VectorXd& p0) {
    std::size_t used = 0;
    for (std::size_t w = 0; w < problem_.windows.size(); ++w) {
      auto& win = problem_.windows[w];
      for (std::size_t k = 0; k < problem_.parameters.size(); ++k)
        win.x[problem_.parameters[k].state] = p0[static_cast<Index>(k)];
      Eigen::VectorXd y;
      Eigen::MatrixXd dy;
      windows_[w].used = steady_.solve(win.u, win.x) && steady_.sensitivities(win.u, win.x, y, dy);
      // A window whose settling failed but whose steady state Newton found is used.
      auto& error = windows_[w].error;
      error = windows_[w].used ? "" : (error.empty() ? "" : error + "; ") + steady_.error();
      used += windows_[w].used ? 1 : 0;
    }
    return used;
  }

 private:
  // Per measured output, its offset's index in p (after the parameters), or -1.
  static std::vector<Index> offsets_of(const CalibrationProblem& problem) {
    std::vector<Index> out(problem.measured.size(), -1);
    auto next = static_cast<Index>(problem.parameters.size());
    for (std::size_t k = 0; k < problem.offset_std.size() && k < out.size(); ++k)
      if (problem.offset_std[k] > 0.0) out[k] = next++;
    return out;
  }
  static std::vector<std::size_t> states_of(const CalibrationProblem& problem) {
    std::vector<std::size_t> s;
    for (const auto& p : problem.parameters)
      s.push_back(p.state);
    return s;
  }

  CalibrationProblem& problem_;
  std::vector<WindowFit>& windows_;
  SteadyState steady_;
  std::vector<Index> offset_;
};

}  // namespace

CalibrationResult calibrate(const plant::ContinuousModel& model, CalibrationProblem problem,
                            const CalibrationOptions& options) {
  CalibrationResult out;
  const auto nf = static_cast<Index>(problem.parameters.size());
  out.windows.resize(problem.windows.size());
  if (nf == 0 || problem.measured.size() != problem.measured_std.size() ||
      problem.offset_std.size() > problem.measured.size()) {
    out.error = "no parameters to fit, or a sigma missing or extra for a measured output";
    return out;
  }
  const auto offsets = static_cast<Index>(std::count_if(
      problem.offset_std.begin(), problem.offset_std.end(), [](double s) { return s > 0.0; }));
  const Index np = nf + offsets;
  Eigen::VectorXd p0(np), s0(np), lo(np), hi(np);
  for (Index k = 0; k < nf; ++k) {
    const auto& c = problem.parameters[static_cast<std::size_t>(k)];
    p0[k] = c.prior;
    s0[k] = c.prior_std;
    lo[k] = c.min;
    hi[k] = c.max;
  }
  for (std::size_t j = 0, k = static_cast<std::size_t>(nf); j < problem.offset_std.size(); ++j)
    if (problem.offset_std[j] > 0.0) {
      const auto i = static_cast<Index>(k++);
      p0[i] = 0.0;
      s0[i] = problem.offset_std[j];
      lo[i] = -std::numeric_limits<double>::infinity();
      hi[i] = std::numeric_limits<double>::infinity();
    }
  // Each window's first guess settled at its inputs, the parameters at their prior.
  for (std::size_t w = 0; w < problem.windows.size(); ++w) {
    auto& win = problem.windows[w];
    for (std::size_t k = 0; k < problem.parameters.size(); ++k)
      win.x[problem.parameters[k].state] = p0[static_cast<Index>(k)];
    std::string error;
    if (options.settle_s > 0.0 && !plant::settle(model, win.u, options.settle_s, win.x, &error))
      out.windows[w].error = "settling failed: " + error;
  }
  Fit fit(model, problem, out.windows);
  if (fit.select(p0) == 0) {
    out.error = "no window has a steady state at the nominal parameters";
    return out;
  }
  Evaluation e, trial;
  if (!fit.evaluate(p0, e, true, true)) {
    out.error = "the nominal parameters have no steady state";
    return out;
  }
  out.chi_square_nominal = e.cost;
  const Eigen::VectorXd w_prior = s0.cwiseInverse().cwiseAbs2();
  auto total = [&](const Evaluation& ev, const Eigen::VectorXd& p) {
    return ev.cost + ((p - p0).array().square() * w_prior.array()).sum();
  };
  Eigen::VectorXd p = p0;
  double cost = total(e, p), lambda = 1e-3;
  Eigen::MatrixXd normal;
  for (out.iterations = 0; out.iterations < options.max_iterations; ++out.iterations) {
    normal = e.j.transpose() * e.j;
    normal.diagonal() += w_prior;
    const Eigen::VectorXd gradient =
        e.j.transpose() * e.r + (w_prior.array() * (p - p0).array()).matrix();
    bool accepted = false, small = false;
    while (!accepted && lambda < 1e10) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += lambda * normal.diagonal();
      const Eigen::VectorXd step = -damped.ldlt().solve(gradient);
      const Eigen::VectorXd next = (p + step).cwiseMax(lo).cwiseMin(hi);
      const Eigen::VectorXd sigma = normal.inverse().diagonal().cwiseSqrt();
      small = ((next - p).array().abs() / sigma.array()).maxCoeff() < 1e-3;
      if (fit.evaluate(next, trial, false, false) && total(trial, next) < cost) {
        p = next;
        fit.evaluate(p, e, true, false);
        const double improvement = cost - total(e, p);
        cost = total(e, p);
        accepted = true;
        lambda = std::max(lambda / 3.0, 1e-9);
        small = small || improvement < 1e-9 * std::max(cost, 1.0);
      } else {
        lambda *= 4.0;
        if (small) break;
      }
    }
    if (!accepted || small) break;
  }
  fit.evaluate(p, e, true, false);
  normal = e.j.transpose() * e.j;
  normal.diagonal() += w_prior;
  out.value = p;
  out.chi_square = e.cost;
  out.residuals = static_cast<std::size_t>(e.r.size());
  out.birge = std::max(1.0, out.residuals > 0 ? e.cost / static_cast<double>(out.residuals) : 1.0);
  out.covariance = normal.inverse() * out.birge;
  out.std = out.covariance.diagonal().cwiseSqrt();
  out.ok = out.covariance.allFinite();
  if (!out.ok) out.error = "the fit's covariance is not finite";
  return out;
}

}  // namespace hvac_twin::est
