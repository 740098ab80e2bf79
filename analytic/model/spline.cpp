#include "analytic/model/spline.h"

#include <algorithm>
#include <utility>

namespace crosslink {

NaturalSpline::NaturalSpline(std::vector<double> x, std::vector<double> y)
    : x_(std::move(x)), y_(std::move(y)), m_(x_.size(), 0.0) {
  // The second derivatives M_i by the tridiagonal system of a natural spline (M_0 = M_n-1 = 0),
  // solved by the Thomas algorithm.
  const size_t n = x_.size();
  std::vector<double> c(n, 0.0), d(n, 0.0);
  for (size_t i = 1; i + 1 < n; ++i) {
    const double h0 = x_[i] - x_[i - 1], h1 = x_[i + 1] - x_[i];
    const double a = h0, b = 2.0 * (h0 + h1), cc = h1;
    const double r = 6.0 * ((y_[i + 1] - y_[i]) / h1 - (y_[i] - y_[i - 1]) / h0);
    const double denom = b - a * c[i - 1];
    c[i] = cc / denom;
    d[i] = (r - a * d[i - 1]) / denom;
  }
  for (size_t i = n - 2; i >= 1; --i) m_[i] = d[i] - c[i] * m_[i + 1];
}

SplinePoint NaturalSpline::at(double x) const {
  const size_t n = x_.size();
  const size_t k = std::clamp<size_t>(
      static_cast<size_t>(std::upper_bound(x_.begin(), x_.end(), x) - x_.begin()), 1, n - 1);
  const double h = x_[k] - x_[k - 1], a = (x_[k] - x) / h, b = (x - x_[k - 1]) / h;
  SplinePoint p;
  p.y = a * y_[k - 1] + b * y_[k] +
        ((a * a * a - a) * m_[k - 1] + (b * b * b - b) * m_[k]) * h * h / 6.0;
  p.dy = (y_[k] - y_[k - 1]) / h - (3.0 * a * a - 1.0) / 6.0 * h * m_[k - 1] +
         (3.0 * b * b - 1.0) / 6.0 * h * m_[k];
  p.ddy = a * m_[k - 1] + b * m_[k];
  p.dddy = (m_[k] - m_[k - 1]) / h;
  return p;
}

}  // namespace crosslink
