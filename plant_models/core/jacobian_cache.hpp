// JacobianCache: the model Jacobian J = df/dx at the last state it was asked for, so that the
// integrator's callbacks (CVODES's Newton matrix, the sensitivity right-hand side, the direct
// sensitivity solve) never evaluate it twice at the same point. Private to the integrator.
//
// The key is the state's bit pattern: a request at exactly the state of the last evaluation
// returns the stored matrix. get_near() also returns it for a state within a given distance of
// the key, measured per state in units of its scale (the layout's reuse_scale, else its
// initial_std): the integrator's
// optional Jacobian reuse (IntegratorOptions::jacobian_reuse_sigma). The inputs u are checked
// only by begin(), which the owner calls whenever u may have changed, i.e. at the start of every
// Integrator::step(): it forgets the matrix unless reuse is on and every input is within the
// distance of the one the matrix was evaluated at (the layout's reuse_scale as its unit), so
// that a unit in steady operation keeps one Jacobian over many periods.
//
// Ownership: holds a reference to the model (which must outlive it) and owns its n x n storage,
// allocated at construction; begin() and the requests never allocate or throw.
// Thread-safety: none; one instance per integrator.
#pragma once

#include <cstddef>
#include <memory>
#include <span>

#include "plant_models/core/model.hpp"

namespace hvac_twin::plant {

class JacobianCache {
 public:
  JacobianCache(const ContinuousModel& model, std::size_t n);

  // Before requests at inputs u: keeps the stored matrix only if distance > 0 and every input is
  // within distance * reuse_scale of the inputs it was evaluated at (see above).
  void begin(std::span<const double> u, double distance);

  // J at (x, u), column-major n x n (J[c * n + r] = df_r/dx_c), in *J. Returns the model status
  // (kModelOk, > 0 recoverable, < 0 fatal); on failure *J is null and nothing is stored.
  int get(std::span<const double> x, std::span<const double> u, const double** J);
  // The same, but a stored matrix evaluated within `distance` of x (|x_i - key_i| <= distance *
  // scale_i for every i) is returned as it is. distance 0 is get().
  int get_near(std::span<const double> x, std::span<const double> u, double distance,
               const double** J);

  // Whether the stored matrix, if any, was evaluated at exactly x.
  [[nodiscard]] bool holds(std::span<const double> x) const;
  // Whether the stored matrix, if any, was evaluated within `distance` of x (see get_near()).
  [[nodiscard]] bool near(std::span<const double> x, double distance) const;
  // Whether a is within `distance` of b, in the same units.
  [[nodiscard]] bool within(std::span<const double> a, std::span<const double> b,
                            double distance) const;

  // The stored matrix, wherever it was evaluated, or null if none (counted as a hit).
  const double* latest() {
    if (!valid_) return nullptr;
    ++hits_;
    return jac_.get();
  }

  // Model Jacobian evaluations and requests served from the store since construction. The
  // stored matrix is evaluation number evaluations() (a request that evaluated changes it).
  [[nodiscard]] long evaluations() const { return evaluations_; }
  [[nodiscard]] long hits() const { return hits_; }

 private:
  const ContinuousModel& model_;
  std::size_t n_;
  std::unique_ptr<double[]> x_;      // the key: the state of the stored matrix
  std::unique_ptr<double[]> scale_;  // per state: the unit of get_near()'s distance
  std::unique_ptr<double[]> jac_;    // n x n
  std::unique_ptr<double[]> u_;      // the inputs of the stored matrix
  std::unique_ptr<double[]> u_scale_;
  std::size_t m_;
  bool valid_ = false;
  long evaluations_ = 0;
  long hits_ = 0;
};

}  // namespace hvac_twin::plant
