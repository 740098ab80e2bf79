#include "compare/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace crosslink::compare {

namespace {
constexpr double kNoScale = std::numeric_limits<double>::quiet_NaN();
}  // namespace

double percent_difference(double value, double against) {
  if (against == 0.0) return value == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  return 100.0 * std::abs(value - against) / std::abs(against);
}

double wrap_angle(double radians) {
  constexpr double two_pi = 2.0 * std::numbers::pi;
  double wrapped = std::remainder(radians, two_pi);  // [-pi, pi]
  if (wrapped <= -std::numbers::pi) wrapped += two_pi;
  return wrapped;
}

double wrap_positive_angle(double radians) {
  constexpr double two_pi = 2.0 * std::numbers::pi;
  double wrapped = std::fmod(radians, two_pi);
  if (wrapped < 0.0) wrapped += two_pi;
  return wrapped >= two_pi ? 0.0 : wrapped;
}

std::string channel_kind(std::string_view channel) {
  return std::string(to_string(Trajectory::quantity_of(channel))) +
         (Trajectory::angular(channel) ? "/angular" : "/linear");
}

double channel_peak(std::string_view channel, const Eigen::VectorXd& reference,
                    const std::vector<bool>& usable, double size) {
  const Quantity q = Trajectory::quantity_of(channel);
  if (q == Quantity::angle) return std::numbers::pi;
  if (q == Quantity::position) return size;
  if (q == Quantity::energy) return 0.0;  // the energy scale, as the floor (comparison.cpp)
  double peak = 0.0;
  for (Eigen::Index k = 0; k < reference.size(); ++k)
    if (usable[static_cast<size_t>(k)]) peak = std::max(peak, std::abs(reference(k)));
  return peak;
}

double peak_floor(std::string_view channel, double kind_peak, double magnitude_peak,
                  const Scales& scales) {
  const Quantity q = Trajectory::quantity_of(channel);
  // Forces and torques: against the component's vector, or 1 % of the largest of their kind
  // (a reaction that is small by design, such as a light link's), or 1 % of the other kind's
  // peak at the size (a torque that is zero by design, such as a free pendulum's driver's).
  if (q == Quantity::force)
    return std::max({magnitude_peak, 0.01 * kind_peak,
                     scales.size > 0.0 ? 0.01 * scales.torque / scales.size : 0.0});
  if (q == Quantity::torque)
    return std::max({magnitude_peak, 0.01 * kind_peak, 0.01 * scales.force * scales.size});
  if (q != Quantity::velocity && q != Quantity::acceleration && q != Quantity::jerk) return 0.0;
  const bool angular = channel_kind(channel).ends_with("/angular");
  double rate = scales.driver_rate;  // to the power of the derivative's order
  if (q != Quantity::velocity) rate *= scales.driver_rate;
  if (q == Quantity::jerk) rate *= scales.driver_rate;
  const double characteristic = angular ? rate : rate * scales.size;
  return std::max({magnitude_peak, 0.01 * kind_peak, characteristic});
}

std::vector<std::pair<std::string, int>> ChannelMetrics::excluded() const {
  std::vector<std::pair<std::string, int>> counts;
  for (const std::string& r : reason) {
    if (r.empty()) continue;
    auto it =
        std::find_if(counts.begin(), counts.end(), [&](const auto& c) { return c.first == r; });
    if (it == counts.end())
      counts.push_back({r, 1});
    else
      ++it->second;
  }
  return counts;
}

ChannelMetrics compare_channel(std::string_view channel, const Eigen::VectorXd& reference,
                               const Eigen::VectorXd& method, const std::vector<bool>& usable,
                               double size, double peak_floor) {
  ChannelMetrics m;
  m.channel = std::string(channel);
  m.quantity = Trajectory::quantity_of(channel);
  const bool angle = m.quantity == Quantity::angle;
  const Eigen::Index n = reference.size();
  m.in_verdict = usable;

  // P and P_eff: the scale of every % of peak below.
  m.peak = channel_peak(channel, reference, usable, size);
  m.peak_used = std::max(m.peak, peak_floor);
  // A scale of zero or below the smallest normal number (a reference at rest: 1e-300 is no
  // scale) gives no % of peak: NaN, "n/a", never 1e308 or inf.
  const double scale = m.peak_used >= std::numeric_limits<double>::min() ? m.peak_used : kNoScale;

  // Per sample: d_k, signed % of peak, local % (masked near zero).
  m.difference.resize(n);
  m.pct_of_peak.resize(n);
  m.local_pct.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double d = angle ? wrap_angle(method(k) - reference(k)) : method(k) - reference(k);
    const double r = angle ? wrap_positive_angle(reference(k)) : reference(k);
    m.difference(k) = d;
    m.pct_of_peak(k) = 100.0 * d / scale;
    m.local_pct(k) = !(std::abs(r) >= 0.01 * scale) ? std::numeric_limits<double>::quiet_NaN()
                                                    : 100.0 * std::abs(d) / std::abs(r);
  }

  // Max and RMS over K; the worst sample is the verdict's witness.
  double sum_sq = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!usable[static_cast<size_t>(k)]) continue;
    const double a = std::abs(m.difference(k));
    ++m.usable;
    sum_sq += a * a;
    if (m.worst_sample < 0 || a > m.max_abs) {
      m.max_abs = a;
      m.worst_sample = static_cast<int>(k);
    }
    if (!std::isnan(m.local_pct(k))) m.max_local_pct = std::max(m.max_local_pct, m.local_pct(k));
  }
  if (m.usable > 0) m.rms_abs = std::sqrt(sum_sq / m.usable);
  m.max_pct_of_peak = 100.0 * m.max_abs / scale;
  m.rms_pct_of_peak = 100.0 * m.rms_abs / scale;
  return m;
}

std::vector<std::pair<std::string, std::string>> metric_legend() {
  return {
      {"difference",
       "d = method - reference (analytic Newton), SI; angles wrapped into "
       "(-180, 180] deg (compared modulo 360 deg)"},
      {"peak",
       "P = largest |reference| over the usable samples of the cycle; angles: 180 deg; "
       "positions: the mechanism's size (coordinates depend on the origin)"},
      {"scale",
       "P floored by: a component's vector magnitude peak (vx against |v|); 1 % of the "
       "largest peak of the same kind; the mechanism's characteristic value (driver rate W: "
       "W, W^2, W size, W^2 size; forces: 1 % of the peak torque / size; torques: 1 % of the "
       "peak force x size), so a channel that is zero by design is not scaled by "
       "its round-off; energy channels (dynamics): the energy scale E, the largest of the "
       "reference's peak kinetic energy, range of potential energy and peak |work|"},
      {"% of peak", "100 |d| / P per sample; its maximum over the cycle is the verdict metric"},
      {"max % of peak", "the largest % of peak over the usable samples, at the worst sample"},
      {"RMS % of peak", "100 sqrt(mean d^2) / P over the usable samples"},
      {"local % difference",
       "100 |d| / |reference| (the course's \"% difference\"); not shown "
       "where |reference| < 1 % of P"},
      {"usable sample",
       "PoseStatus ok in both trajectories and not next to a singular sample of the "
       "reference; singular, loop-gap and other flagged samples are shown but kept out "
       "of every max, RMS and verdict"},
      {"verdict",
       "pass when max % of peak <= the tolerance of the channel's quantity class "
       "for that method"},
  };
}

}  // namespace crosslink::compare
