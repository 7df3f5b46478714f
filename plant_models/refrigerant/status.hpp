// Status codes of the refrigerant property calls. Values follow the SUNDIALS callback
// convention so a model callback can return them directly: 0 success, > 0 recoverable (the
// integrator retries with a smaller step). Property calls never throw and never return < 0.
#pragma once

namespace hvac_twin::plant::r32 {

enum class Status : int {
  kOk = 0,
  kOutOfRange = 1,    // input outside the range covered (the result is clamped and finite)
  kNotConverged = 2,  // an iterative EOS solve did not converge (EOS functions only)
};

constexpr int callback_code(Status s) {
  return static_cast<int>(s);
}
constexpr bool ok(Status s) {
  return s == Status::kOk;
}

}  // namespace hvac_twin::plant::r32
