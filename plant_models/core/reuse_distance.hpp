// The distance test behind every reuse of a linearisation (a model Jacobian, its matrix
// exponential, the filter's output Jacobian): whether a is within `distance` of b, per entry in
// units of its own scale (a state's initial_std, an input's reuse_scale). A NaN anywhere, or a
// length mismatch, is not near. Pure; no allocation.
#pragma once

#include <cmath>
#include <cstddef>
#include <span>

namespace hvac_twin::plant {

inline bool within_scaled(std::span<const double> a, std::span<const double> b,
                          std::span<const double> scale, double distance) {
  if (a.size() != b.size() || a.size() != scale.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(std::abs(a[i] - b[i]) <= distance * scale[i])) return false;  // NaN: not near
  return true;
}

}  // namespace hvac_twin::plant
