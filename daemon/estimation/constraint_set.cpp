#include "daemon/estimation/constraint_set.hpp"

#include <cmath>

namespace hvac_twin::est {

ConstraintSet::ConstraintSet(const plant::ModelLayout& layout) {
  const auto n = static_cast<Eigen::Index>(layout.states.size());
  std::vector<std::pair<Eigen::VectorXd, double>> fixed;
  const auto add = [&](std::string name, Eigen::VectorXd a, double bound) {
    fixed.emplace_back(std::move(a), bound);
    names_.push_back(std::move(name));
  };
  for (std::size_t i = 0; i < layout.states.size(); ++i) {
    const auto& s = layout.states[i];
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
    e(static_cast<Eigen::Index>(i)) = 1.0;
    if (std::isfinite(s.min)) add(s.name + " >= " + std::to_string(s.min), -e, -s.min);
    if (std::isfinite(s.max)) add(s.name + " <= " + std::to_string(s.max), e, s.max);
  }
  for (const auto& c : layout.constraints) {
    if (c.over != plant::LinearConstraint::Over::kStates) continue;
    Eigen::VectorXd a = Eigen::VectorXd::Zero(n);
    for (const auto& [i, coeff] : c.terms)
      a(static_cast<Eigen::Index>(i)) += coeff;
    add(c.name, a, c.bound);
  }
  static_rows_ = fixed.size();
  for (const auto& c : layout.constraints) {
    if (c.over != plant::LinearConstraint::Over::kOutputs) continue;
    outputs_.push_back({c.terms, c.bound, c.while_input, c.while_above, true});
    names_.push_back(c.name);
  }
  const auto total = static_cast<Eigen::Index>(rows());
  A_ = Eigen::MatrixXd::Zero(total, n);
  b_ = scale_ = Eigen::VectorXd::Ones(total);
  for (std::size_t r = 0; r < static_rows_; ++r) {
    A_.row(static_cast<Eigen::Index>(r)) = fixed[r].first.transpose();
    b_(static_cast<Eigen::Index>(r)) = fixed[r].second;
  }
  for (std::size_t k = 0; k < outputs_.size(); ++k)
    b_(static_cast<Eigen::Index>(static_rows_ + k)) = outputs_[k].bound;
  for (Eigen::Index r = 0; r < total; ++r)
    scale_(r) = 1.0 + std::abs(b_(r));
}

void ConstraintSet::set_inputs(std::span<const double> u) {
  for (auto& row : outputs_) {
    const auto i = static_cast<std::size_t>(row.while_input);
    row.on = row.while_input < 0 || i >= u.size() || u[i] >= row.while_above;
  }
}

void ConstraintSet::linearise_outputs(const Eigen::VectorXd& x_ref, const Eigen::VectorXd& y,
                                      const Eigen::MatrixXd& H) {
  for (std::size_t k = 0; k < outputs_.size(); ++k) {
    const auto r = static_cast<Eigen::Index>(static_rows_ + k);
    A_.row(r).setZero();
    if (!outputs_[k].on) {
      b_(r) = 0.0;  // off: 0 <= 0
      continue;
    }
    double g = 0.0;
    for (const auto& [o, coeff] : outputs_[k].terms) {
      A_.row(r) += coeff * H.row(static_cast<Eigen::Index>(o));
      g += coeff * y(static_cast<Eigen::Index>(o));
    }
    b_(r) = outputs_[k].bound - g + A_.row(r).dot(x_ref);
  }
}

double ConstraintSet::output_violation(std::span<const double> y, int* row) const {
  double worst = -1.0;
  if (row != nullptr) *row = -1;
  for (std::size_t k = 0; k < outputs_.size(); ++k) {
    if (!outputs_[k].on) continue;
    double g = 0.0;
    for (const auto& [o, coeff] : outputs_[k].terms)
      g += coeff * y[o];
    const double v = (g - outputs_[k].bound) / (1.0 + std::abs(outputs_[k].bound));
    if (v > worst) {
      worst = v;
      if (row != nullptr) *row = static_cast<int>(static_rows_ + k);
    }
  }
  return worst;
}

}  // namespace hvac_twin::est
