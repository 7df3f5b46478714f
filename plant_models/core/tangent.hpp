// Tangent<N, S>: forward-mode derivatives in N local directions over any scalar S (double or
// Dual<K>), for the few places where a model needs partial derivatives of an expression *as
// values* (the heat pump's cell profiles: the mass balance needs d(mean density)/d(pressure,
// enthalpies), and the model's own Jacobian then needs their derivatives in turn). With S =
// Dual<K> the partials carry exact tangents of their own, i.e. second derivatives, so the
// derivative of a right-hand side that contains partials is still exact.
//
// Only what those expressions use is defined: + - * /, exp, expm1, log, log1p, sqrt, and value
// comparisons. A scalar operand (S or double) converts implicitly. Plain value type; never
// allocates; thread-safe.
#pragma once

#include <array>
#include <cmath>
#include <type_traits>

#include "plant_models/core/dual.hpp"

namespace hvac_twin::plant {

template <int N, class S>
struct Tangent {
  static_assert(N >= 1, "a tangent needs at least one direction");
  S v{};
  std::array<S, N> d{};

  Tangent() = default;
  Tangent(const S& value) : v(value) {}  // NOLINT(google-explicit-constructor): constants
  // Explicit so that a double never silently becomes a Tangent over double (S converts instead).
  template <class C>
  requires(!std::is_same_v<C, S> && std::is_convertible_v<C, S>) explicit Tangent(const C& value)
      : v(S(value)) {}

  // The value `value` with partial `slope` in direction i.
  static Tangent seed(const S& value, int i, const S& slope = S(1.0)) {
    Tangent t(value);
    t.d[static_cast<std::size_t>(i)] = slope;
    return t;
  }

  Tangent& operator+=(const Tangent& o) {
    v += o.v;
    for (int i = 0; i < N; ++i)
      d[i] += o.d[i];
    return *this;
  }
  Tangent& operator-=(const Tangent& o) {
    v -= o.v;
    for (int i = 0; i < N; ++i)
      d[i] -= o.d[i];
    return *this;
  }
  Tangent& operator*=(const Tangent& o) {
    for (int i = 0; i < N; ++i)
      d[i] = d[i] * o.v + v * o.d[i];
    v *= o.v;
    return *this;
  }
  Tangent& operator/=(const Tangent& o) {
    const S inv = 1.0 / o.v;
    const S q = v * inv;
    for (int i = 0; i < N; ++i)
      d[i] = (d[i] - q * o.d[i]) * inv;
    v = q;
    return *this;
  }
  Tangent& operator+=(const S& c) {
    v += c;
    return *this;
  }
  Tangent& operator-=(const S& c) {
    v -= c;
    return *this;
  }
  Tangent& operator*=(const S& c) {
    v *= c;
    for (int i = 0; i < N; ++i)
      d[i] *= c;
    return *this;
  }
  Tangent& operator/=(const S& c) { return *this *= S(1.0 / c); }
};

template <int N, class S>
constexpr double value_of(const Tangent<N, S>& x) {
  return value_of(x.v);
}

// f(x) with f'(x) = df.
template <int N, class S>
Tangent<N, S> chain(const Tangent<N, S>& x, const S& f, const S& df) {
  Tangent<N, S> r(f);
  for (int i = 0; i < N; ++i)
    r.d[i] = df * x.d[i];
  return r;
}

template <int N, class S>
using TangentScalar = std::type_identity_t<S>;

template <int N, class S>
Tangent<N, S> operator+(Tangent<N, S> a, const Tangent<N, S>& b) {
  return a += b;
}
template <int N, class S>
Tangent<N, S> operator-(Tangent<N, S> a, const Tangent<N, S>& b) {
  return a -= b;
}
template <int N, class S>
Tangent<N, S> operator*(Tangent<N, S> a, const Tangent<N, S>& b) {
  return a *= b;
}
template <int N, class S>
Tangent<N, S> operator/(Tangent<N, S> a, const Tangent<N, S>& b) {
  return a /= b;
}
template <int N, class S>
Tangent<N, S> operator+(Tangent<N, S> a, const TangentScalar<N, S>& c) {
  return a += c;
}
template <int N, class S>
Tangent<N, S> operator+(const TangentScalar<N, S>& c, Tangent<N, S> a) {
  return a += c;
}
template <int N, class S>
Tangent<N, S> operator-(Tangent<N, S> a, const TangentScalar<N, S>& c) {
  return a -= c;
}
template <int N, class S>
Tangent<N, S> operator-(const TangentScalar<N, S>& c, const Tangent<N, S>& a) {
  Tangent<N, S> r(c - a.v);
  for (int i = 0; i < N; ++i)
    r.d[i] = -a.d[i];
  return r;
}
template <int N, class S>
Tangent<N, S> operator*(Tangent<N, S> a, const TangentScalar<N, S>& c) {
  return a *= c;
}
template <int N, class S>
Tangent<N, S> operator*(const TangentScalar<N, S>& c, Tangent<N, S> a) {
  return a *= c;
}
template <int N, class S>
Tangent<N, S> operator/(Tangent<N, S> a, const TangentScalar<N, S>& c) {
  const S inv = 1.0 / c;
  return a *= inv;
}
template <int N, class S>
Tangent<N, S> operator/(const TangentScalar<N, S>& c, const Tangent<N, S>& a) {
  const S inv = 1.0 / a.v;
  return chain(a, S(c * inv), S(-c * inv * inv));
}
template <int N, class S>
Tangent<N, S> operator-(const Tangent<N, S>& a) {
  return 0.0 - a;
}

template <int N, class S>
bool operator<(const Tangent<N, S>& a, const Tangent<N, S>& b) {
  return value_of(a) < value_of(b);
}
template <int N, class S>
bool operator>(const Tangent<N, S>& a, const Tangent<N, S>& b) {
  return value_of(a) > value_of(b);
}

template <int N, class S>
Tangent<N, S> exp(const Tangent<N, S>& x) {
  using std::exp;
  const S e = exp(x.v);
  return chain(x, e, e);
}
template <int N, class S>
Tangent<N, S> expm1(const Tangent<N, S>& x) {
  using std::exp;
  using std::expm1;
  return chain(x, S(expm1(x.v)), S(exp(x.v)));
}
template <int N, class S>
Tangent<N, S> log(const Tangent<N, S>& x) {
  using std::log;
  return chain(x, S(log(x.v)), S(1.0 / x.v));
}
template <int N, class S>
Tangent<N, S> log1p(const Tangent<N, S>& x) {
  using std::log1p;
  return chain(x, S(log1p(x.v)), S(1.0 / (1.0 + x.v)));
}
template <int N, class S>
Tangent<N, S> sqrt(const Tangent<N, S>& x) {
  using std::sqrt;
  const S s = sqrt(x.v);
  return chain(x, s, S(0.5 / s));
}

}  // namespace hvac_twin::plant
