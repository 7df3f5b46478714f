// JacobianCache: the model Jacobian J = df/dx at the last state it was asked for, so that the
// integrator's callbacks (CVODES's Newton matrix, the sensitivity right-hand side, the direct
// sensitivity solve) never evaluate it twice at the same point. Private to the integrator.
//
// The key is the state's bit pattern: a request at exactly the state of the last evaluation
// returns the stored matrix. The inputs u are not part of the key: the owner calls invalidate()
// whenever u (or anything else the model reads) may have changed, i.e. at the start of every
// Integrator::step().
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

  // Whether the stored matrix, if any, was evaluated at exactly x.
  [[nodiscard]] bool holds(std::span<const double> x) const;

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
  std::unique_ptr<double[]> x_;    // the key: the state of the stored matrix
  std::unique_ptr<double[]> jac_;  // n x n
  bool valid_ = false;
  long evaluations_ = 0;
  long hits_ = 0;
};

}  // namespace hvac_twin::plant
