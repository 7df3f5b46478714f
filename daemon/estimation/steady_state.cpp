#include "daemon/estimation/steady_state.hpp"

#include <algorithm>
#include <cmath>

namespace hvac_twin::est {

SteadyState::SteadyState(const plant::ContinuousModel& model, std::vector<std::size_t> parameters,
                         std::vector<std::size_t> known, SteadyStateOptions options)
    : model_(model), parameters_(std::move(parameters)), options_(options) {
  const auto& states = model.layout().states;
  const std::size_t n = states.size();
  std::vector<bool> fixed(n, false);
  for (const std::size_t i : parameters_)
    fixed[i] = true;
  for (const std::size_t i : known)
    fixed[i] = true;
  for (std::size_t i = 0; i < n; ++i)
    if (!fixed[i] && !states[i].augmented && !states[i].held_while_settling) free_.push_back(i);
  scale_.resize(static_cast<Eigen::Index>(free_.size()));
  for (std::size_t k = 0; k < free_.size(); ++k)
    scale_[static_cast<Eigen::Index>(k)] = std::max(states[free_[k]].abs_tol, 1e-12);
  f_.resize(static_cast<Eigen::Index>(n));
  jac_.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
}

bool SteadyState::evaluate(std::span<const double> u, std::span<const double> x) {
  const int status = model_.rhs_jacobian(x, u, {f_.data(), static_cast<std::size_t>(f_.size())},
                                         {jac_.data(), static_cast<std::size_t>(jac_.size())});
  return status == plant::kModelOk && f_.allFinite() && jac_.allFinite();
}

double SteadyState::scaled_norm() const {
  double sum = 0.0;
  for (std::size_t k = 0; k < free_.size(); ++k) {
    const double r = f_[static_cast<Eigen::Index>(free_[k])] / scale_[static_cast<Eigen::Index>(k)];
    sum += r * r;
  }
  return std::sqrt(sum);
}

bool SteadyState::solve(std::span<const double> u, std::span<double> x) {
  const auto nf = static_cast<Eigen::Index>(free_.size());
  const auto& states = model_.layout().states;
  std::vector<double> trial(x.begin(), x.end()), best(x.begin(), x.end());
  Eigen::MatrixXd a(nf, nf);
  Eigen::VectorXd rhs(nf);
  iterations_ = 0;
  if (!evaluate(u, best)) {
    error_ = "the model cannot be evaluated at the first guess";
    return false;
  }
  for (int it = 0; it < options_.max_newton_iterations; ++it) {
    iterations_ = it + 1;
    for (Eigen::Index r = 0; r < nf; ++r) {
      rhs[r] = -f_[static_cast<Eigen::Index>(free_[static_cast<std::size_t>(r)])];
      for (Eigen::Index c = 0; c < nf; ++c)
        a(r, c) = jac_(static_cast<Eigen::Index>(free_[static_cast<std::size_t>(r)]),
                       static_cast<Eigen::Index>(free_[static_cast<std::size_t>(c)]));
    }
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(a);
    const Eigen::VectorXd step = lu.solve(rhs);
    if (!step.allFinite()) {
      error_ = "the steady-state Jacobian is singular";
      return false;
    }
    const double step_size = (step.array().abs() / scale_.array()).maxCoeff();
    const double norm = scaled_norm();
    bool accepted = false;
    for (double lambda = 1.0; lambda > 1e-4 && !accepted; lambda *= 0.5) {
      trial = best;
      for (std::size_t k = 0; k < free_.size(); ++k) {
        const auto& s = states[free_[k]];
        trial[free_[k]] =
            std::clamp(best[free_[k]] + lambda * step[static_cast<Eigen::Index>(k)], s.min, s.max);
      }
      accepted = evaluate(u, trial) && scaled_norm() < norm * (1.0 - 1e-4 * lambda);
    }
    if (!accepted) {
      // Near the solution the residual stalls at round-off: a step already below tolerance is
      // convergence, anything else is not.
      if (step_size < options_.step_tolerance) break;
      error_ = "no Newton step reduces the steady-state residual";
      return false;
    }
    best = trial;
    if (step_size < options_.step_tolerance) {
      std::copy(best.begin(), best.end(), x.begin());
      return true;
    }
  }
  if (!evaluate(u, best) || iterations_ >= options_.max_newton_iterations) {
    error_ = "Newton's method did not converge in " +
             std::to_string(options_.max_newton_iterations) + " iterations";
    return false;
  }
  std::copy(best.begin(), best.end(), x.begin());
  return true;
}

bool SteadyState::sensitivities(std::span<const double> u, std::span<const double> x,
                                Eigen::VectorXd& y, Eigen::MatrixXd& dy_dp) {
  const auto n = static_cast<Eigen::Index>(model_.num_states());
  const auto m = static_cast<Eigen::Index>(model_.num_outputs());
  const auto nf = static_cast<Eigen::Index>(free_.size());
  const auto np = static_cast<Eigen::Index>(parameters_.size());
  if (!evaluate(u, x)) {
    error_ = "the model cannot be evaluated at the steady state";
    return false;
  }
  y.resize(m);
  Eigen::MatrixXd h(m, n);
  if (model_.output_jacobian(x, u, {y.data(), static_cast<std::size_t>(m)},
                             {h.data(), static_cast<std::size_t>(h.size())}) != plant::kModelOk ||
      !y.allFinite() || !h.allFinite()) {
    error_ = "the model's outputs cannot be evaluated at the steady state";
    return false;
  }
  Eigen::MatrixXd a(nf, nf), b(nf, np), h_free(m, nf);
  for (Eigen::Index r = 0; r < nf; ++r) {
    const auto row = static_cast<Eigen::Index>(free_[static_cast<std::size_t>(r)]);
    for (Eigen::Index c = 0; c < nf; ++c)
      a(r, c) = jac_(row, static_cast<Eigen::Index>(free_[static_cast<std::size_t>(c)]));
    for (Eigen::Index c = 0; c < np; ++c)
      b(r, c) = jac_(row, static_cast<Eigen::Index>(parameters_[static_cast<std::size_t>(c)]));
  }
  for (Eigen::Index c = 0; c < nf; ++c)
    h_free.col(c) = h.col(static_cast<Eigen::Index>(free_[static_cast<std::size_t>(c)]));
  const Eigen::MatrixXd dx_dp = -Eigen::PartialPivLU<Eigen::MatrixXd>(a).solve(b);
  dy_dp = h_free * dx_dp;
  for (Eigen::Index c = 0; c < np; ++c)
    dy_dp.col(c) += h.col(static_cast<Eigen::Index>(parameters_[static_cast<std::size_t>(c)]));
  if (!dy_dp.allFinite()) {
    error_ = "the steady-state Jacobian is singular";
    return false;
  }
  return true;
}

}  // namespace hvac_twin::est
