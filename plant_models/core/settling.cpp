#include "plant_models/core/settling.hpp"

#include <algorithm>
#include <memory>
#include <vector>

namespace hvac_twin::plant {
namespace {

// The model with the derivatives (and their Jacobian rows) of the held states zeroed.
class HeldStates final : public ContinuousModel {
 public:
  explicit HeldStates(const ContinuousModel& model) : model_(model) {
    const auto& states = model.layout().states;
    for (std::size_t i = 0; i < states.size(); ++i)
      if (states[i].held_while_settling) held_.push_back(i);
  }
  const ModelLayout& layout() const override { return model_.layout(); }
  int rhs(std::span<const double> x, std::span<const double> u,
          std::span<double> xdot) const override {
    const int status = model_.rhs(x, u, xdot);
    for (const std::size_t i : held_)
      xdot[i] = 0.0;
    return status;
  }
  int rhs_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> xdot,
                   std::span<double> jac) const override {
    const int status = model_.rhs_jacobian(x, u, xdot, jac);
    const std::size_t n = x.size();
    for (const std::size_t i : held_) {
      if (!xdot.empty()) xdot[i] = 0.0;
      for (std::size_t c = 0; c < n; ++c)
        jac[c * n + i] = 0.0;
    }
    return status;
  }
  int outputs(std::span<const double> x, std::span<const double> u,
              std::span<double> y) const override {
    return model_.outputs(x, u, y);
  }
  int output_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> y,
                      std::span<double> jac) const override {
    return model_.output_jacobian(x, u, y, jac);
  }
  std::unique_ptr<ContinuousModel> clone() const override {
    return std::make_unique<HeldStates>(model_);
  }

 private:
  const ContinuousModel& model_;
  std::vector<std::size_t> held_;
};

}  // namespace

bool settle(const ContinuousModel& model, std::span<const double> u, double seconds,
            std::span<double> x, std::string* error, const IntegratorOptions& options) {
  try {
    const HeldStates held(model);
    IntegratorOptions o = options;
    o.sensitivities = false;
    Integrator integrator(held, o);
    std::vector<double> xs(x.begin(), x.end());
    if (!integrator.step(xs, u, seconds, {}).ok()) {
      if (error != nullptr) *error = integrator.last_error();
      return false;
    }
    std::copy(xs.begin(), xs.end(), x.begin());
    return true;
  } catch (const std::exception& e) {
    if (error != nullptr) *error = e.what();
    return false;
  }
}

}  // namespace hvac_twin::plant
