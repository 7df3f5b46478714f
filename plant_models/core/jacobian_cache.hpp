// JacobianCache: the model Jacobian J = df/dx at the last state it was asked for, so that the
// integrator's callbacks (CVODES's Newton matrix, the sensitivity right-hand side, the direct
// sensitivity solve) never evaluate it twice at the same point. Private to the integrator.
//
// The key is the state's bit pattern: a request at exactly the state of the last evaluation
// returns the stored matrix. get_near() also returns it for a state within a given distance of
// the key, measured per state in units of its scale (the layout's initial_std): the integrator's
// optional Jacobian reuse (IntegratorOptions::jacobian_reuse_sigma). The inputs u are not part of
// the key: the owner calls invalidate() whenever u (or anything else the model reads) may have
// changed, i.e. at the start of every Integrator::step().
//
// Ownership: holds a reference to the model (which must outlive it) and owns its n x n storage,
// allocated at construction; get() and invalidate() never allocate or throw.
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

  // Forgets the stored matrix (the next get() evaluates).
  void invalidate() { valid_ = false; }

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

  // Model Jacobian evaluations and requests served from the store since construction.
  [[nodiscard]] long evaluations() const { return evaluations_; }
  [[nodiscard]] long hits() const { return hits_; }

 private:
  const ContinuousModel& model_;
  std::size_t n_;
  std::unique_ptr<double[]> x_;      // the key: the state of the stored matrix
  std::unique_ptr<double[]> scale_;  // per state: the unit of get_near()'s distance
  std::unique_ptr<double[]> jac_;    // n x n
  bool valid_ = false;
  long evaluations_ = 0;
  long hits_ = 0;
};

}  // namespace hvac_twin::plant
