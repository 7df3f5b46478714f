// The constraint rows A x <= b of a model: one per finite state bound, one per state
// constraint, then one per output constraint, re-linearised on demand. Shared by the
// constrained EKF and EnKF.
//
// Construction allocates; linearise_outputs() and output_violation() never do.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::est {

class ConstraintSet {
 public:
  explicit ConstraintSet(const plant::ModelLayout& layout);

  [[nodiscard]] std::size_t rows() const { return static_rows_ + outputs_.size(); }
  [[nodiscard]] std::size_t static_rows() const { return static_rows_; }
  [[nodiscard]] bool has_output_rows() const { return !outputs_.empty(); }
  [[nodiscard]] const Eigen::MatrixXd& A() const { return A_; }
  [[nodiscard]] const Eigen::VectorXd& b() const { return b_; }
  [[nodiscard]] const Eigen::VectorXd& scale() const { return scale_; }  // |b| + 1 per row
  [[nodiscard]] const std::string& name(int row) const {
    return names_[static_cast<std::size_t>(row)];
  }

  // The inputs over the coming period: an output row whose condition of operation
  // (LinearConstraint::while_input) they do not meet is off, 0 <= 0, until they do. Empty: every
  // row on. No allocation.
  void set_inputs(std::span<const double> u);

  // The output rows linearised at x_ref, where the outputs are y with Jacobian H (m x n):
  // g(x) ~ g(x_ref) + G (x - x_ref) <= bound.
  void linearise_outputs(const Eigen::VectorXd& x_ref, const Eigen::VectorXd& y,
                         const Eigen::MatrixXd& H);

  // The largest scaled violation of the output constraints on by outputs y (<= 0: satisfied),
  // and the row of that constraint (-1 if the model has no output constraint on).
  [[nodiscard]] double output_violation(std::span<const double> y, int* row = nullptr) const;

 private:
  struct OutputRow {
    std::vector<std::pair<std::size_t, double>> terms;
    double bound = 0.0;
    int while_input = -1;
    double while_above = 0.0;
    bool on = true;
  };
  std::size_t static_rows_ = 0;
  std::vector<OutputRow> outputs_;
  std::vector<std::string> names_;
  Eigen::MatrixXd A_;
  Eigen::VectorXd b_, scale_;
};

}  // namespace hvac_twin::est
