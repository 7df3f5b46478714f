#include "plant_models/core/jacobian_cache.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

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
    scale_[i] = i < states.size() ? std::abs(states[i].initial_std) : 0.0;
  const auto& inputs = model.layout().inputs;
  for (std::size_t i = 0; i < m_; ++i)
    u_scale_[i] = std::abs(inputs[i].reuse_scale);
}

void JacobianCache::begin(std::span<const double> u, double distance) {
  if (!valid_) return;
  bool keep = distance > 0.0 && u.size() == m_;
  for (std::size_t i = 0; keep && i < m_; ++i)
    keep = std::abs(u[i] - u_[i]) <= distance * u_scale_[i];  // NaN: not near
  valid_ = keep;
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
  if (a.size() != n_ || b.size() != n_) return false;
  for (std::size_t i = 0; i < n_; ++i)
    if (!(std::abs(a[i] - b[i]) <= distance * scale_[i])) return false;  // NaN: not near
  return true;
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
