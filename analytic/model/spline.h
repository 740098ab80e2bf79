// A natural cubic spline y(x) through points (x_i, y_i), x increasing: continuous to the second
// derivative, zero second derivative at both ends, its third derivative constant on each piece.
// A driver's table law runs through one in time; a curved slot's centreline is one over its
// chord (docs/mechanism-format.md, "Curved slots").
#pragma once

#include <vector>

namespace crosslink {

struct SplinePoint {
  double y = 0.0, dy = 0.0, ddy = 0.0, dddy = 0.0;  // the value and its three derivatives in x
};

class NaturalSpline {
 public:
  // At least two points, x strictly increasing (the caller's definition says so where not).
  NaturalSpline(std::vector<double> x, std::vector<double> y);
  // At any x: beyond an end, the end piece's cubic carried on.
  SplinePoint at(double x) const;
  double first() const { return x_.front(); }
  double last() const { return x_.back(); }

 private:
  std::vector<double> x_, y_, m_;  // the knots and the second derivatives there
};

}  // namespace crosslink
