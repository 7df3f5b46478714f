// Batch calibration of a model's uncertain parameters to steady operating windows of a
// commissioning period with the charge known (issue 15, item 4): a maximum a posteriori fit,
//
//   minimise  sum_w sum_j ((y_wj - h_j(x_w(p), u_w) - b_j) / sigma_j)^2
//             + sum_i ((p_i - p0_i) / s_i)^2 + sum_j (b_j / t_j)^2
//   over p in [min, max] and the sensor offsets b_j fitted (prior sigma t_j),
//   with f_free(x_w(p), u_w) = 0 in every window w,
//
// by Levenberg–Marquardt. The residuals' derivatives are exact: the model's AD Jacobians and the
// implicit-function theorem at each window's steady state (steady_state.hpp), one model source.
// The prior (each parameter's nominal value and the sigma a filter starts it with) keeps a
// parameter the windows cannot separate from the others where it was, with its prior sigma: the
// fit says which parameters the data determined and which it did not.
//
// Why steady windows rather than the whole trajectory: a commissioning engineer runs the unit at
// a few operating points and waits for each to settle; at a steady state the parameters meet the
// measurements without the transient's own errors (sensor lags, the model's dynamics), the
// residual derivatives cost one Jacobian per window instead of a sensitivity integration over
// hours, and a fit of 8 parameters on 6 hours takes seconds. The filter itself estimates the
// same parameters online (commissioning.hpp); this is the batch answer to compare with.
//
// Each window's mean is weighted by the sensor's noise sigma, not sigma / sqrt(samples): a
// sensor's bias and the model's structural error do not average away over a window. When the
// fit's chi-square per residual is above 1, the covariance is scaled by it (Birge ratio): the
// parameters' sigma is then what the scatter of the windows says, not only the sensors.
//
// Offline only: allocates; never throws.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "plant_models/core/model.hpp"

namespace hvac_twin::est {

struct CalibrationParameter {
  std::size_t state = 0;  // an augmented state of the model
  double prior = 1.0;     // its nominal value
  double prior_std = 1.0;
  double min = -1e300, max = 1e300;
};

struct CalibrationWindow {
  std::vector<double> u;  // the model's inputs, the window's mean
  std::vector<double> y;  // the model's outputs as measured (window mean); NaN: not measured
  std::vector<double> x;  // the first guess of the state (known states at their known values)
  double start_s = 0.0, end_s = 0.0;  // for the report
};

struct CalibrationProblem {
  std::vector<CalibrationParameter> parameters;
  std::vector<std::size_t> known;     // states held at their value in each window's x
  std::vector<std::size_t> measured;  // output indices with a sensor
  std::vector<double> measured_std;   // their sensors' sigma, one per measured output
  // Per measured output: the prior sigma of its sensor's offset (reading = output + offset),
  // fitted after the parameters in the result's vectors; 0 or empty: no offset fitted.
  std::vector<double> offset_std;
  std::vector<CalibrationWindow> windows;
};

struct CalibrationOptions {
  double settle_s = 900.0;  // each window's first guess is integrated this long at its inputs
  int max_iterations = 30;
};

struct WindowFit {
  bool used = false;
  std::string error;  // why a window was left out
  // The measured outputs' model values, offsets included, at the prior and at the fit.
  Eigen::VectorXd nominal, fitted;
};

struct CalibrationResult {
  bool ok = false;
  std::string error;
  Eigen::VectorXd value, std;       // the parameters, then the fitted offsets; their sigma
  Eigen::MatrixXd covariance;       // after the Birge scaling
  double chi_square = 0.0;          // of the data residuals at the fit
  double chi_square_nominal = 0.0;  // at the prior
  std::size_t residuals = 0;        // data residuals in the fit
  double birge = 1.0;               // max(1, chi_square / residuals): the covariance's factor
  int iterations = 0;
  std::vector<WindowFit> windows;  // one per problem window
};

CalibrationResult calibrate(const plant::ContinuousModel& model, CalibrationProblem problem,
                            const CalibrationOptions& options = {});

}  // namespace hvac_twin::est
