// Forward-mode automatic differentiation with a fixed number of tangent directions.
//
// Dual<K> carries a value and K directional derivatives in stack storage, so arithmetic never
// allocates. Jacobians of an n-dimensional model function are assembled in ceil(n/K) "chunks"
// (see jacobian.hpp), which keeps the scalar small for any n. Models are written once as
// templates over the scalar type and instantiated with double (simulation) and Dual<K>
// (derivatives): one model source, exact derivatives.
//
// Every function here propagates derivatives by its exact analytic rule; there is no
// approximation. Functions that are not differentiable everywhere (abs, min, max) take the
// derivative of the branch selected by the value, as a subgradient; models avoid them where the
// kink matters and use the smooth helpers in smooth.hpp instead.
//
// Thread-safety: plain value type. Allocation: none.
#pragma once

#include <array>
#include <cmath>
#include <type_traits>

namespace hvac_twin::plant {

template <int K>
struct Dual {
  static_assert(K >= 1, "a dual number needs at least one tangent direction");
  static constexpr int kDirections = K;

  double v = 0.0;
  std::array<double, K> d{};

  constexpr Dual() = default;
  constexpr Dual(double value) : v(value) {}  // NOLINT(google-explicit-constructor): constants
  constexpr Dual(double value, const std::array<double, K>& deriv) : v(value), d(deriv) {}

  Dual& operator+=(const Dual& o) {
    v += o.v;
    for (int i = 0; i < K; ++i)
      d[i] += o.d[i];
    return *this;
  }
  Dual& operator-=(const Dual& o) {
    v -= o.v;
    for (int i = 0; i < K; ++i)
      d[i] -= o.d[i];
    return *this;
  }
  Dual& operator*=(const Dual& o) {
    for (int i = 0; i < K; ++i)
      d[i] = d[i] * o.v + v * o.d[i];
    v *= o.v;
    return *this;
  }
  Dual& operator/=(const Dual& o) {
    const double inv = 1.0 / o.v;
    const double q = v * inv;
    for (int i = 0; i < K; ++i)
      d[i] = (d[i] - q * o.d[i]) * inv;
    v = q;
    return *this;
  }
  Dual& operator+=(double c) {
    v += c;
    return *this;
  }
  Dual& operator-=(double c) {
    v -= c;
    return *this;
  }
  Dual& operator*=(double c) {
    v *= c;
    for (int i = 0; i < K; ++i)
      d[i] *= c;
    return *this;
  }
  Dual& operator/=(double c) { return *this *= (1.0 / c); }
};

template <class T>
struct IsDual : std::false_type {};
template <int K>
struct IsDual<Dual<K>> : std::true_type {};
template <class T>
inline constexpr bool kIsDual = IsDual<T>::value;

// value_of: the plain double of any scalar. Used for branch decisions (which must not depend on
// derivatives) and for diagnostics.
inline constexpr double value_of(double x) {
  return x;
}
template <int K>
constexpr double value_of(const Dual<K>& x) {
  return x.v;
}

// Chain rule helper: f(x) with f'(x) = df.
template <int K>
Dual<K> chain(const Dual<K>& x, double f, double df) {
  Dual<K> r(f);
  for (int i = 0; i < K; ++i)
    r.d[i] = df * x.d[i];
  return r;
}

template <int K>
Dual<K> operator+(Dual<K> a, const Dual<K>& b) {
  return a += b;
}
template <int K>
Dual<K> operator-(Dual<K> a, const Dual<K>& b) {
  return a -= b;
}
template <int K>
Dual<K> operator*(Dual<K> a, const Dual<K>& b) {
  return a *= b;
}
template <int K>
Dual<K> operator/(Dual<K> a, const Dual<K>& b) {
  return a /= b;
}
template <int K>
Dual<K> operator+(Dual<K> a, double c) {
  return a += c;
}
template <int K>
Dual<K> operator+(double c, Dual<K> a) {
  return a += c;
}
template <int K>
Dual<K> operator-(Dual<K> a, double c) {
  return a -= c;
}
template <int K>
Dual<K> operator-(double c, const Dual<K>& a) {
  Dual<K> r(c - a.v);
  for (int i = 0; i < K; ++i)
    r.d[i] = -a.d[i];
  return r;
}
template <int K>
Dual<K> operator*(Dual<K> a, double c) {
  return a *= c;
}
template <int K>
Dual<K> operator*(double c, Dual<K> a) {
  return a *= c;
}
template <int K>
Dual<K> operator/(Dual<K> a, double c) {
  return a /= c;
}
template <int K>
Dual<K> operator/(double c, const Dual<K>& a) {
  const double inv = 1.0 / a.v;
  return chain(a, c * inv, -c * inv * inv);
}
template <int K>
Dual<K> operator-(const Dual<K>& a) {
  return a * -1.0;
}
template <int K>
const Dual<K>& operator+(const Dual<K>& a) {
  return a;
}

// Comparisons look at values only.
template <int K>
bool operator<(const Dual<K>& a, const Dual<K>& b) {
  return a.v < b.v;
}
template <int K>
bool operator>(const Dual<K>& a, const Dual<K>& b) {
  return a.v > b.v;
}
template <int K>
bool operator<=(const Dual<K>& a, const Dual<K>& b) {
  return a.v <= b.v;
}
template <int K>
bool operator>=(const Dual<K>& a, const Dual<K>& b) {
  return a.v >= b.v;
}
template <int K>
bool operator<(const Dual<K>& a, double b) {
  return a.v < b;
}
template <int K>
bool operator>(const Dual<K>& a, double b) {
  return a.v > b;
}
template <int K>
bool operator<=(const Dual<K>& a, double b) {
  return a.v <= b;
}
template <int K>
bool operator>=(const Dual<K>& a, double b) {
  return a.v >= b;
}
template <int K>
bool operator<(double a, const Dual<K>& b) {
  return a < b.v;
}
template <int K>
bool operator>(double a, const Dual<K>& b) {
  return a > b.v;
}

// Elementary functions (found by argument-dependent lookup; models write `using std::exp;`
// and then call `exp(x)` so the same line works for double and Dual).
template <int K>
Dual<K> exp(const Dual<K>& x) {
  const double e = std::exp(x.v);
  return chain(x, e, e);
}
template <int K>
Dual<K> log(const Dual<K>& x) {
  return chain(x, std::log(x.v), 1.0 / x.v);
}
template <int K>
Dual<K> log1p(const Dual<K>& x) {
  return chain(x, std::log1p(x.v), 1.0 / (1.0 + x.v));
}
template <int K>
Dual<K> expm1(const Dual<K>& x) {
  return chain(x, std::expm1(x.v), std::exp(x.v));
}
template <int K>
Dual<K> sqrt(const Dual<K>& x) {
  const double s = std::sqrt(x.v);
  return chain(x, s, 0.5 / s);
}
template <int K>
Dual<K> cbrt(const Dual<K>& x) {
  const double c = std::cbrt(x.v);
  return chain(x, c, 1.0 / (3.0 * c * c));
}
template <int K>
Dual<K> pow(const Dual<K>& x, double n) {
  const double p = std::pow(x.v, n);
  // d/dx x^n = n x^(n-1); written without dividing by x so x = 0 works for n >= 1.
  return chain(x, p, n == 0.0 ? 0.0 : n * std::pow(x.v, n - 1.0));
}
template <int K>
Dual<K> pow(const Dual<K>& x, const Dual<K>& y) {
  return exp(y * log(x));
}
template <int K>
Dual<K> pow(double b, const Dual<K>& y) {
  const double p = std::pow(b, y.v);
  return chain(y, p, p * std::log(b));
}
template <int K>
Dual<K> sin(const Dual<K>& x) {
  return chain(x, std::sin(x.v), std::cos(x.v));
}
template <int K>
Dual<K> cos(const Dual<K>& x) {
  return chain(x, std::cos(x.v), -std::sin(x.v));
}
template <int K>
Dual<K> tanh(const Dual<K>& x) {
  const double t = std::tanh(x.v);
  return chain(x, t, 1.0 - t * t);
}
template <int K>
Dual<K> atan(const Dual<K>& x) {
  return chain(x, std::atan(x.v), 1.0 / (1.0 + x.v * x.v));
}
template <int K>
Dual<K> abs(const Dual<K>& x) {
  return x.v < 0.0 ? -x : x;
}
template <int K>
Dual<K> fabs(const Dual<K>& x) {
  return abs(x);
}
template <int K>
bool isfinite(const Dual<K>& x) {
  if (!std::isfinite(x.v)) return false;
  for (double di : x.d)
    if (!std::isfinite(di)) return false;
  return true;
}

}  // namespace hvac_twin::plant
