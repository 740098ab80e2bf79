// Golden-section search, for the events the derived quantities locate on exact poses.
#pragma once

#include <cmath>
#include <optional>

namespace crosslink {

// Where f (a std::optional<double> of the place) is largest over [a, b], for f unimodal there:
// the midpoint of the bracket once it is 1e-13 of its place wide, after 200 steps, or where f
// has no value at a point the search reaches.
template <class F>
double golden_section_max(F f, double a, double b) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - g * (b - a), d = a + g * (b - a);
  std::optional<double> fc = f(c), fd = f(d);
  for (int i = 0; i < 200 && fc && fd && b - a > 1e-13 * (1.0 + std::abs(a)); ++i) {
    if (*fc > *fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
  }
  return 0.5 * (a + b);
}

}  // namespace crosslink
