// A model's steady state at constant inputs, and its sensitivity to some of its states held as
// parameters: what a batch calibration on steady operating windows fits (batch_calibration.hpp).
//
// The states split three ways:
//  - parameters: states the caller varies (a calibration's factors); constant here;
//  - fixed: states held at their values: the model's augmented states (parameters and slow
//    unknowns whose derivative is zero), the states an initial guess takes from the measured
//    conditions (StateInfo::held_while_settling: the heat pump's zone air and building mass),
//    and the states the caller knows (the weighed-in charge, whose own derivative is the leak);
//  - free: the rest, solved for f_free(x) = 0.
// The free block of the Jacobian, A = df_free/dx_free, is then nonsingular at a stable operating
// point, and by the implicit-function theorem
//     dx_free/dp = -A^-1 df_free/dp,   dy/dp = H_free dx_free/dp + H_p.
//
// Offline (calibration) only: allocates; never throws.
#pragma once

#include <Eigen/Dense>
#include <span>
#include <string>
#include <vector>

#include "plant_models/core/model.hpp"

namespace hvac_twin::est {

struct SteadyStateOptions {
  int max_newton_iterations = 40;
  // Converged when every free state's Newton step is below this many of its integrator
  // tolerance (StateInfo::abs_tol).
  double step_tolerance = 1.0;
};

class SteadyState {
 public:
  // parameters, known: state indices (disjoint; each < the model's state count).
  SteadyState(const plant::ContinuousModel& model, std::vector<std::size_t> parameters,
              std::vector<std::size_t> known, SteadyStateOptions options = {});

  // Newton's method on the free states of x (fixed and parameter states left as they are), from
  // x as the first guess, with a step halved until the model evaluates and the scaled residual
  // falls. Returns false (x unchanged, error() set) if it does not converge.
  bool solve(std::span<const double> u, std::span<double> x);

  // At a solved x: the outputs y and dy/dp (outputs x parameters). False if the model fails.
  bool sensitivities(std::span<const double> u, std::span<const double> x, Eigen::VectorXd& y,
                     Eigen::MatrixXd& dy_dp);

  [[nodiscard]] const std::vector<std::size_t>& free_states() const { return free_; }
  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] int last_iterations() const { return iterations_; }

 private:
  // f and J at x; false if the model fails there.
  bool evaluate(std::span<const double> u, std::span<const double> x);
  [[nodiscard]] double scaled_norm() const;  // of f_free in units of abs_tol per second

  const plant::ContinuousModel& model_;
  std::vector<std::size_t> parameters_, free_;
  SteadyStateOptions options_;
  Eigen::VectorXd f_;
  Eigen::MatrixXd jac_;
  Eigen::VectorXd scale_;  // abs_tol of each free state
  std::string error_;
  int iterations_ = 0;
};

}  // namespace hvac_twin::est
