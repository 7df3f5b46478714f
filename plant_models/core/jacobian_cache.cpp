#include "plant_models/core/jacobian_cache.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "plant_models/core/reuse_distance.hpp"

namespace hvac_twin::plant {

JacobianCache::JacobianCache(const ContinuousModel& model, std::size_t n)
    : model_(model),
      n_(n),
      x_(new double[n]()),
      scale_(new double[n]()),
      jac_(new double[n * n]()),
      u_(new double[model.layout().inputs.size()]()),
      u_scale_(new double[model.layout().inputs.size()]()),
      m_(model.layout().inputs.size()) {
  const auto& states = model.layout().states;
  for (std::size_t i = 0; i < n; ++i)
    scale_[i] = i >= states.size()            ? 0.0
                : states[i].reuse_scale > 0.0 ? states[i].reuse_scale
                                              : std::abs(states[i].initial_std);
  const auto& inputs = model.layout().inputs;
  for (std::size_t i = 0; i < m_; ++i)
    u_scale_[i] = std::abs(inputs[i].reuse_scale);
}

void JacobianCache::begin(std::span<const double> u, double distance) {
  if (!valid_) return;
  valid_ = distance > 0.0 && within_scaled(u, {u_.get(), m_}, {u_scale_.get(), m_}, distance);
}

bool JacobianCache::holds(std::span<const double> x) const {
  // Bitwise: the same state, not merely an equal one (0.0 and -0.0 count as different, which
  // only costs an evaluation).
  return valid_ && x.size() == n_ && std::memcmp(x.data(), x_.get(), n_ * sizeof(double)) == 0;
}

bool JacobianCache::near(std::span<const double> x, double distance) const {
  return valid_ && within(x, {x_.get(), n_}, distance);
}

bool JacobianCache::within(std::span<const double> a, std::span<const double> b,
                           double distance) const {
  return a.size() == n_ && within_scaled(a, b, {scale_.get(), n_}, distance);
}

int JacobianCache::get_near(std::span<const double> x, std::span<const double> u, double distance,
                            const double** J) {
  if (distance > 0.0 && near(x, distance)) {
    ++hits_;
    *J = jac_.get();
    return kModelOk;
  }
  return get(x, u, J);
}

int JacobianCache::get(std::span<const double> x, std::span<const double> u, const double** J) {
  if (holds(x)) {
    ++hits_;
    *J = jac_.get();
    return kModelOk;
  }
  valid_ = false;
  *J = nullptr;
  ++evaluations_;
  const int status = model_.rhs_jacobian(x, u, {}, {jac_.get(), n_ * n_});
  if (status != kModelOk) return status;
  std::memcpy(x_.get(), x.data(), n_ * sizeof(double));
  // std::copy, not memcpy: a model without inputs passes an empty span, whose data() may be null.
  if (u.size() == m_) std::copy(u.begin(), u.end(), u_.get());
  valid_ = true;
  *J = jac_.get();
  return kModelOk;
}

}  // namespace hvac_twin::plant
