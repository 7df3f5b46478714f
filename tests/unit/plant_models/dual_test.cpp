#include "plant_models/core/dual.hpp"

#include <catch2/catch.hpp>
#include <cmath>

using hvac_twin::plant::Dual;
using D = Dual<2>;

namespace {

// f'(x) by central differences of the double version.
template <class F>
double fd(F f, double x) {
  const double h = 1e-6 * std::max(1.0, std::abs(x));
  return (f(x + h) - f(x - h)) / (2.0 * h);
}

D seed(double v) {
  return D(v, {1.0, 0.0});
}

}  // namespace

TEST_CASE("dual arithmetic follows the product and quotient rules", "[dual]") {
  const D a(3.0, {1.0, 0.0});
  const D b(-2.0, {0.0, 1.0});
  const D p = a * b;
  CHECK(p.v == -6.0);
  CHECK(p.d[0] == -2.0);  // d(ab)/da = b
  CHECK(p.d[1] == 3.0);   // d(ab)/db = a
  const D q = a / b;
  CHECK(q.v == Approx(-1.5));
  CHECK(q.d[0] == Approx(-0.5));        // 1/b
  CHECK(q.d[1] == Approx(-3.0 / 4.0));  // -a/b^2
  const D r = 2.0 - a * 4.0 + 1.0 / b;
  CHECK(r.v == Approx(2.0 - 12.0 - 0.5));
  CHECK(r.d[0] == Approx(-4.0));
  CHECK(r.d[1] == Approx(-1.0 / 4.0));
  CHECK(value_of(r) == r.v);
}

TEST_CASE("dual elementary functions match finite differences", "[dual]") {
  using std::atan, std::cbrt, std::cos, std::exp, std::expm1, std::log, std::log1p, std::pow,
      std::sin, std::sqrt, std::tanh;
  for (double x : {0.3, 1.7, 4.2}) {
    CHECK(exp(seed(x)).d[0] == Approx(fd([](double t) { return std::exp(t); }, x)).epsilon(1e-8));
    CHECK(log(seed(x)).d[0] == Approx(fd([](double t) { return std::log(t); }, x)).epsilon(1e-8));
    CHECK(log1p(seed(x)).d[0] ==
          Approx(fd([](double t) { return std::log1p(t); }, x)).epsilon(1e-8));
    CHECK(expm1(seed(x)).d[0] ==
          Approx(fd([](double t) { return std::expm1(t); }, x)).epsilon(1e-8));
    CHECK(sqrt(seed(x)).d[0] == Approx(fd([](double t) { return std::sqrt(t); }, x)).epsilon(1e-8));
    CHECK(cbrt(seed(x)).d[0] == Approx(fd([](double t) { return std::cbrt(t); }, x)).epsilon(1e-8));
    CHECK(pow(seed(x), 2.5).d[0] ==
          Approx(fd([](double t) { return std::pow(t, 2.5); }, x)).epsilon(1e-8));
    CHECK(pow(seed(x), seed(x)).d[0] ==
          Approx(fd([](double t) { return std::pow(t, t); }, x)).epsilon(1e-8));
    CHECK(pow(2.0, seed(x)).d[0] ==
          Approx(fd([](double t) { return std::pow(2.0, t); }, x)).epsilon(1e-8));
    CHECK(sin(seed(x)).d[0] == Approx(fd([](double t) { return std::sin(t); }, x)).epsilon(1e-8));
    CHECK(cos(seed(x)).d[0] ==
          Approx(fd([](double t) { return std::cos(t); }, x)).epsilon(1e-8).margin(1e-9));
    CHECK(tanh(seed(x)).d[0] == Approx(fd([](double t) { return std::tanh(t); }, x)).epsilon(1e-6));
    CHECK(atan(seed(x)).d[0] == Approx(fd([](double t) { return std::atan(t); }, x)).epsilon(1e-8));
  }
}

TEST_CASE("pow with an integer exponent is differentiable at zero", "[dual]") {
  const D z = pow(seed(0.0), 2.0);
  CHECK(z.v == 0.0);
  CHECK(z.d[0] == 0.0);
  CHECK(std::isfinite(z.d[0]));
  CHECK(pow(seed(0.0), 1.0).d[0] == 1.0);
}

TEST_CASE("dual comparisons use the value only and isfinite checks derivatives", "[dual]") {
  const D a(1.0, {5.0, 0.0});
  const D b(2.0, {-5.0, 0.0});
  CHECK(a < b);
  CHECK(b > 1.5);
  CHECK(0.5 < a);
  CHECK(isfinite(a));
  D bad = a;
  bad.d[1] = std::nan("");
  CHECK_FALSE(isfinite(bad));
}
