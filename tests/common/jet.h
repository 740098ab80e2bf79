// A value and its first three derivatives in one variable, carried through arithmetic and the
// elementary functions by the chain rule: closed forms differentiated exactly (to round-off),
// the independent check of a solver's rates, accelerations and jerks.
#pragma once

#include <cmath>

namespace crosslink::test {

struct Jet {
  double v = 0, d = 0, dd = 0, ddd = 0;
  Jet() = default;
  Jet(double value, double d1 = 0, double d2 = 0, double d3 = 0)  // NOLINT: a constant is a jet
      : v(value), d(d1), dd(d2), ddd(d3) {}
};
inline Jet operator+(Jet a, Jet b) {
  return {a.v + b.v, a.d + b.d, a.dd + b.dd, a.ddd + b.ddd};
}
inline Jet operator-(Jet a, Jet b) {
  return {a.v - b.v, a.d - b.d, a.dd - b.dd, a.ddd - b.ddd};
}
inline Jet operator-(Jet a) {
  return {-a.v, -a.d, -a.dd, -a.ddd};
}
inline Jet operator*(Jet a, Jet b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d, a.dd * b.v + 2 * a.d * b.d + a.v * b.dd,
          a.ddd * b.v + 3 * a.dd * b.d + 3 * a.d * b.dd + a.v * b.ddd};
}
// f(a) from f and its first three derivatives at a.v (Faa di Bruno to third order).
inline Jet apply(Jet a, double f, double f1, double f2, double f3) {
  return {f, f1 * a.d, f2 * a.d * a.d + f1 * a.dd,
          f3 * a.d * a.d * a.d + 3 * f2 * a.d * a.dd + f1 * a.ddd};
}
inline Jet operator/(Jet a, Jet b) {
  const double x = b.v;
  return a * apply(b, 1 / x, -1 / (x * x), 2 / (x * x * x), -6 / (x * x * x * x));
}
inline Jet sqrt(Jet a) {
  const double s = std::sqrt(a.v);
  return apply(a, s, 0.5 / s, -0.25 / (s * a.v), 0.375 / (s * a.v * a.v));
}
inline Jet cos(Jet a) {
  const double c = std::cos(a.v), s = std::sin(a.v);
  return apply(a, c, -s, -c, s);
}
inline Jet sin(Jet a) {
  const double c = std::cos(a.v), s = std::sin(a.v);
  return apply(a, s, c, -s, -c);
}
inline Jet acos(Jet a) {
  const double w = 1 - a.v * a.v, root = std::sqrt(w);
  return apply(a, std::acos(a.v), -1 / root, -a.v / (w * root),
               -(1 + 2 * a.v * a.v) / (w * w * root));
}
// atan2(y, x): its rate (x y' - y x') / r^2 is a jet of one order less.
inline Jet atan2(Jet y, Jet x) {
  const Jet r2 = x * x + y * y;
  const Jet rate = (x * Jet(y.d, y.dd, y.ddd) - y * Jet(x.d, x.dd, x.ddd)) / r2;
  return {std::atan2(y.v, x.v), rate.v, rate.d, rate.dd};
}

}  // namespace crosslink::test
