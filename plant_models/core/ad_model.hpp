// AdModel<M>: turns a model written once as a template over the scalar type into a
// ContinuousModel with exact Jacobians, by forward-mode automatic differentiation in chunks of K
// directions (Dual<K>). Cost of one Jacobian: ceil(n / K) evaluations of f with Dual<K> scalars.
//
// A templated model M provides:
//   ModelLayout layout() const;
//   template <class S> int rhs(std::span<const S> x, std::span<const double> u,
//                              std::span<S> xdot) const;
//   template <class S> int outputs(std::span<const S> x, std::span<const double> u,
//                                  std::span<S> y) const;
// with the status convention of model.hpp, and is copyable. It may also provide
//   bool initial_guess(std::span<const double> u, std::span<const double> y,
//                      std::span<double> x) const;   (see ContinuousModel)
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "plant_models/core/dual.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::plant {

template <class M, int K = 8>
class AdModel final : public ContinuousModel {
 public:
  using Scalar = Dual<K>;

  explicit AdModel(M model)
      : model_(std::move(model)),
        layout_(model_.layout()),
        x_(layout_.states.size()),
        f_(layout_.states.size()),
        y_(layout_.outputs.size()) {}

  [[nodiscard]] const ModelLayout& layout() const override { return layout_; }
  [[nodiscard]] const M& model() const { return model_; }

  int rhs(std::span<const double> x, std::span<const double> u,
          std::span<double> xdot) const override {
    return model_.template rhs<double>(x, u, xdot);
  }

  int rhs_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> xdot,
                   std::span<double> jac) const override {
    return jacobian(x, u, xdot, jac, f_, [this](auto xs, auto us, auto out) {
      return model_.template rhs<Scalar>(xs, us, out);
    });
  }

  int outputs(std::span<const double> x, std::span<const double> u,
              std::span<double> y) const override {
    return model_.template outputs<double>(x, u, y);
  }

  int output_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> y,
                      std::span<double> jac) const override {
    return jacobian(x, u, y, jac, y_, [this](auto xs, auto us, auto out) {
      return model_.template outputs<Scalar>(xs, us, out);
    });
  }

  bool initial_guess(std::span<const double> u, std::span<const double> y,
                     std::span<double> x) const override {
    if constexpr (requires { model_.initial_guess(u, y, x); }) {
      return model_.initial_guess(u, y, x);
    } else {
      return ContinuousModel::initial_guess(u, y, x);
    }
  }

  // A clone starts as the model was built: without the warm starts its source has gathered
  // (a model's forget_warm_starts()), so that what it computes does not depend on when it was
  // cloned.
  [[nodiscard]] std::unique_ptr<ContinuousModel> clone() const override {
    auto copy = std::make_unique<AdModel>(model_);
    if constexpr (requires { copy->model_.forget_warm_starts(); })
      copy->model_.forget_warm_starts();
    return copy;
  }

 private:
  // Evaluates fn with x seeded in chunks of K unit directions; writes values (first chunk) and
  // the columns of the Jacobian of fn's outputs (size out.size() x n, column-major).
  template <class Fn>
  int jacobian(std::span<const double> x, std::span<const double> u, std::span<double> value,
               std::span<double> jac, std::vector<Scalar>& out, Fn&& fn) const {
    const std::size_t n = x_.size();
    const std::size_t m = out.size();
    for (std::size_t c0 = 0; c0 < n; c0 += K) {
      for (std::size_t i = 0; i < n; ++i) {
        x_[i] = Scalar(x[i]);
        if (i >= c0 && i < c0 + K) x_[i].d[i - c0] = 1.0;
      }
      const int status = fn(std::span<const Scalar>(x_), u, std::span<Scalar>(out));
      if (status != kModelOk) return status;
      const std::size_t cols = std::min<std::size_t>(K, n - c0);
      for (std::size_t k = 0; k < cols; ++k)
        for (std::size_t r = 0; r < m; ++r)
          jac[(c0 + k) * m + r] = out[r].d[k];
      if (c0 == 0 && !value.empty())
        for (std::size_t r = 0; r < m; ++r)
          value[r] = out[r].v;
    }
    return kModelOk;
  }

  M model_;
  ModelLayout layout_;
  mutable std::vector<Scalar> x_;  // scratch: seeded state
  mutable std::vector<Scalar> f_;  // scratch: dual rhs
  mutable std::vector<Scalar> y_;  // scratch: dual outputs
};

}  // namespace hvac_twin::plant
