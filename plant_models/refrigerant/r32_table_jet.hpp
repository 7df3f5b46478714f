// Second-order derivatives of the (p, h) table interpolant in plain double, for the fused Dual<K>
// evaluation of r32_table_fused.hpp (included by r32_table.hpp; not for direct use).
//
// A Jet is a value with its gradient and Hessian with respect to the table's two inputs (p, h).
// The table is evaluated once in Jets: the Hermite patches and curves in their local
// coordinates with first and second partial derivatives (polynomials, in closed form), composed
// with the coordinate maps by the chain rule. A Dual<K> output is then its value with tangent
// grad . (dp, dh), and a partial-derivative output (drho/dh at constant p, ...) is the gradient
// component with tangent (its Hessian row) . (dp, dh): the same numbers the operation-by-operation
// evaluation in Dual<K> produces, to rounding, at a fraction of the cost (K directions ride on
// two inputs instead of on every operation).
//
// Plain value types; never allocate; thread-safe.
#pragma once

#include <array>
#include <cmath>

namespace hvac_twin::plant::r32::table_detail {

struct Jet {
  double v = 0.0;                       // value
  double p = 0.0, h = 0.0;              // d/dp, d/dh
  double pp = 0.0, ph = 0.0, hh = 0.0;  // second derivatives
};

// The input variables themselves.
inline Jet jet_p(double p) {
  return {p, 1.0, 0.0, 0.0, 0.0, 0.0};
}
inline Jet jet_h(double h) {
  return {h, 0.0, 1.0, 0.0, 0.0, 0.0};
}

// g(x) for a scalar function g with g(x.v) = g0, g' = g1, g'' = g2.
inline Jet compose(const Jet& x, double g0, double g1, double g2) {
  return {g0,
          g1 * x.p,
          g1 * x.h,
          g2 * x.p * x.p + g1 * x.pp,
          g2 * x.p * x.h + g1 * x.ph,
          g2 * x.h * x.h + g1 * x.hh};
}

inline Jet operator+(const Jet& a, const Jet& b) {
  return {a.v + b.v, a.p + b.p, a.h + b.h, a.pp + b.pp, a.ph + b.ph, a.hh + b.hh};
}
inline Jet operator-(const Jet& a, const Jet& b) {
  return {a.v - b.v, a.p - b.p, a.h - b.h, a.pp - b.pp, a.ph - b.ph, a.hh - b.hh};
}
inline Jet operator-(const Jet& a) {
  return {-a.v, -a.p, -a.h, -a.pp, -a.ph, -a.hh};
}
inline Jet operator-(const Jet& a, double c) {
  return {a.v - c, a.p, a.h, a.pp, a.ph, a.hh};
}
inline Jet operator*(const Jet& a, double c) {
  return {a.v * c, a.p * c, a.h * c, a.pp * c, a.ph * c, a.hh * c};
}
inline Jet operator*(const Jet& a, const Jet& b) {
  return {a.v * b.v,
          a.p * b.v + a.v * b.p,
          a.h * b.v + a.v * b.h,
          a.pp * b.v + 2.0 * a.p * b.p + a.v * b.pp,
          a.ph * b.v + a.p * b.h + a.h * b.p + a.v * b.ph,
          a.hh * b.v + 2.0 * a.h * b.h + a.v * b.hh};
}
inline Jet reciprocal(const Jet& a) {
  const double r = 1.0 / a.v;
  return compose(a, r, -r * r, 2.0 * r * r * r);
}
inline Jet operator/(const Jet& a, const Jet& b) {
  return a * reciprocal(b);
}
inline Jet exp(const Jet& a) {
  const double e = std::exp(a.v);
  return compose(a, e, e, e);
}
inline Jet log(const Jet& a) {
  const double r = 1.0 / a.v;
  return compose(a, std::log(a.v), r, -r * r);
}

// Hermite basis on [0, 1] at the local coordinate a: values, first and second derivatives
// (h00 = 1 - h01, so its derivatives are the negatives of h01's).
struct Basis2 {
  double h01, h10, h11;
  double d01, d10, d11;
  double s01, s10, s11;
  explicit Basis2(double a) {
    const double a2 = a * a;
    const double a3 = a2 * a;
    h01 = 3.0 * a2 - 2.0 * a3;
    h10 = a3 - 2.0 * a2 + a;
    h11 = a3 - a2;
    d01 = 6.0 * a - 6.0 * a2;
    d10 = 3.0 * a2 - 4.0 * a + 1.0;
    d11 = 3.0 * a2 - 2.0 * a;
    s01 = 6.0 - 12.0 * a;
    s10 = 6.0 * a - 4.0;
    s11 = 6.0 * a - 2.0;
  }
};

// A cubic Hermite curve on one interval (node values f0, f1, slopes g0, g1 per unit of the
// coordinate, interval length de) as a function of the local coordinate a (a Jet), with the
// basis A at a.v.
inline Jet hermite_jet(double f0, double f1, double g0, double g1, double de, const Basis2& A,
                       const Jet& a) {
  const double df = f1 - f0, e0 = de * g0, e1 = de * g1;
  return compose(a, f0 + df * A.h01 + e0 * A.h10 + e1 * A.h11, df * A.d01 + e0 * A.d10 + e1 * A.d11,
                 df * A.s01 + e0 * A.s10 + e1 * A.s11);
}

// A bicubic Hermite patch from its corner nodes n[eta corner][xi corner] (value, d/deta, d/dxi,
// d2/(deta dxi)) as a function of the local coordinates a (eta) and b (xi), with bases A and B
// at a.v and b.v; de, dx the cell's sides.
inline Jet patch_jet(const std::array<double, 4>& n00, const std::array<double, 4>& n01,
                     const std::array<double, 4>& n10, const std::array<double, 4>& n11, double de,
                     double dx, const Basis2& A, const Basis2& B, const Jet& a, const Jet& b) {
  // Along xi on each eta edge k: g (value) and q (d/deta), each with its first and second
  // derivative in b.
  const std::array<double, 4>* lo[2] = {&n00, &n10};
  const std::array<double, 4>* hi[2] = {&n01, &n11};
  double g[2], g1[2], g2[2], q[2], q1[2], q2[2];
  for (int k = 0; k < 2; ++k) {
    const std::array<double, 4>& l = *lo[k];
    const std::array<double, 4>& u = *hi[k];
    const double dg = u[0] - l[0], eg0 = dx * l[2], eg1 = dx * u[2];
    const double dq = u[1] - l[1], eq0 = dx * l[3], eq1 = dx * u[3];
    g[k] = l[0] + dg * B.h01 + eg0 * B.h10 + eg1 * B.h11;
    g1[k] = dg * B.d01 + eg0 * B.d10 + eg1 * B.d11;
    g2[k] = dg * B.s01 + eg0 * B.s10 + eg1 * B.s11;
    q[k] = l[1] + dq * B.h01 + eq0 * B.h10 + eq1 * B.h11;
    q1[k] = dq * B.d01 + eq0 * B.d10 + eq1 * B.d11;
    q2[k] = dq * B.s01 + eq0 * B.s10 + eq1 * B.s11;
  }
  // Across eta: F(a, b) and its partials in the local coordinates.
  const double F = g[0] + (g[1] - g[0]) * A.h01 + de * (q[0] * A.h10 + q[1] * A.h11);
  const double Fa = (g[1] - g[0]) * A.d01 + de * (q[0] * A.d10 + q[1] * A.d11);
  const double Faa = (g[1] - g[0]) * A.s01 + de * (q[0] * A.s10 + q[1] * A.s11);
  const double Fb = g1[0] + (g1[1] - g1[0]) * A.h01 + de * (q1[0] * A.h10 + q1[1] * A.h11);
  const double Fbb = g2[0] + (g2[1] - g2[0]) * A.h01 + de * (q2[0] * A.h10 + q2[1] * A.h11);
  const double Fab = (g1[1] - g1[0]) * A.d01 + de * (q1[0] * A.d10 + q1[1] * A.d11);
  // F(a(p, h), b(p, h)) by the chain rule.
  return {F,
          Fa * a.p + Fb * b.p,
          Fa * a.h + Fb * b.h,
          Faa * a.p * a.p + 2.0 * Fab * a.p * b.p + Fbb * b.p * b.p + Fa * a.pp + Fb * b.pp,
          Faa * a.p * a.h + Fab * (a.p * b.h + a.h * b.p) + Fbb * b.p * b.h + Fa * a.ph + Fb * b.ph,
          Faa * a.h * a.h + 2.0 * Fab * a.h * b.h + Fbb * b.h * b.h + Fa * a.hh + Fb * b.hh};
}

}  // namespace hvac_twin::plant::r32::table_detail
