// Difference metrics of one channel of a method against the reference trajectory. Every metric
// the comparator reports is defined here, once, and computed by the functions below; the
// reports' legends quote these definitions (metric_legend()).
//
// Notation, for one channel (e.g. "omega.coupler") over the samples k of one sweep:
//   r_k   the reference's value (analytic Newton), m_k the method's value, SI units
//   K     the trusted samples: PoseStatus ok in both trajectories, not next to a sample the
//         reference flags singular, and for forces and torques not ill-conditioned (every rule
//         in analytic/reference/trust.h). Samples outside K are kept in the per-sample arrays
//         (shown in charts and CSV, with their reason) but never enter a peak, max, RMS or verdict.
//
//   difference          d_k = m_k - r_k
//                       angle channels: d_k wrapped into (-pi, pi] (angles compare modulo 2 pi)
//   peak                P = max_{k in K} |r_k|
//                       angle channels: P = pi, the peak of an angle taken modulo 2 pi
//                       position channels (x, y, s): P = the mechanism's size L (the largest
//                       distance between its points): coordinates depend on where the origin
//                       is, so their own peak is no scale; 0.01 % of L is 1e-4 of the size
//                       energy channels (energy.kinetic, .potential, .work, .error; dynamics
//                       cases): P = 0 and the floor F is the energy scale E of the reference,
//                       the largest of its peak kinetic energy, the range of its potential
//                       energy and its peak |work| (Trajectory::energy_scale): potential energy
//                       depends on the origin and the balance's error is zero when exact
//   scale               P_eff = max(P, F), the floor F being the largest of
//                       - for a component (vx, vy, ax, ay) the peak of its point's magnitude
//                         (|v| or |a|): a component is judged against the vector it belongs to
//                       - 1 % of the largest P among the channels of the same kind (e.g. every
//                         linear velocity)
//                       - the mechanism's characteristic value of that kind, from the driver's
//                         peak rate W (rad/s; a slider's m/s over L) and L: W for angular
//                         velocity, W^2 for angular acceleration, W L and W^2 L for linear ones
//                         (the rates a link turning with the driver would have); for forces
//                         1 % of the largest torque peak over L, for torques 1 % of the largest
//                         force peak times L (the moment a peak force has at the mechanism's
//                         size): a free pendulum's driver torque, a shaking moment about a pivot
//                       so that a channel that is zero by design (a fixed point, a constant-speed
//                       crank's alpha, every alpha of a parallelogram) is not scaled by its own
//                       round-off
//   % of peak           e_k = 100 |d_k| / P_eff                       (the verdict metric)
//   max % of peak       E = max_{k in K} e_k, at the worst sample k* = argmax
//   RMS % of peak       100 sqrt(mean_{k in K} d_k^2) / P_eff
//   local % difference  l_k = percent_difference(m_k, r_k) = 100 |d_k| / |r_k|, the course's
//                       "% difference"; masked (NaN) where |r_k| < 1 % of P_eff
//                       (angle channels: r_k taken in [0, 2 pi))
//   max |d|, RMS |d|    over K, in SI units
//
// A channel passes when E <= tolerance (in % of peak; see tolerance.h). A channel with no
// usable sample has no verdict ("n/a"); a method with no usable sample at all fails.
#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/trajectory.h"

namespace crosslink::compare {

// The course's "% difference" of `value` against `against`: 100 |value - against| / |against|.
// E.g. Working Model 365 mm/s against the IC check 370 mm/s: 1.35 %. Infinite when against = 0.
double percent_difference(double value, double against);

// An angle difference wrapped into (-pi, pi] [rad].
double wrap_angle(double radians);
// An angle wrapped into [0, 2 pi) [rad].
double wrap_positive_angle(double radians);

// Channels of the same kind share the peak floor: quantity class and linear vs angular.
// Returns e.g. "velocity/linear", "acceleration/angular".
std::string channel_kind(std::string_view channel);

// The metrics of one channel of one method against the reference.
struct ChannelMetrics {
  std::string channel;
  Quantity quantity = Quantity::position;
  int usable = 0;                // |K|
  double peak = 0.0;             // P [SI]
  double peak_used = 0.0;        // P_eff [SI]
  double max_abs = 0.0;          // max |d| over K [SI]
  double rms_abs = 0.0;          // RMS |d| over K [SI]
  double max_pct_of_peak = 0.0;  // E [%]
  double rms_pct_of_peak = 0.0;  // [%]
  int worst_sample = -1;         // k*, or -1 when K is empty
  double max_local_pct = 0.0;    // max of l_k over K where not masked [%]
  // Per sample (all samples, usable or not):
  Eigen::VectorXd difference;    // d_k [SI]
  Eigen::VectorXd pct_of_peak;   // signed 100 d_k / P_eff [%]
  Eigen::VectorXd local_pct;     // l_k [%], NaN where masked
  std::vector<bool> in_verdict;  // k in K
  // Why each sample outside K is kept out ("" for k in K): the reference's reason
  // (analytic/reference/trust.h: "reference:<status>", "beside_singular", "ill_conditioned") or the
  // method's own status ("method:<status>"). Set by the comparison.
  std::vector<std::string> reason;
  // The samples kept out, counted per reason, in the order of first appearance.
  std::vector<std::pair<std::string, int>> excluded() const;
};

// Compares one channel. `reference` and `method` are the channel's columns over the same
// samples; `usable` marks K; `size` is L; `peak_floor` is the floor F (see above).
ChannelMetrics compare_channel(std::string_view channel, const Eigen::VectorXd& reference,
                               const Eigen::VectorXd& method, const std::vector<bool>& usable,
                               double size, double peak_floor);

// P for one reference column over its usable samples (pi for angles, `size` for positions, 0 for
// energy channels).
double channel_peak(std::string_view channel, const Eigen::VectorXd& reference,
                    const std::vector<bool>& usable, double size);

// The mechanism-wide scales of the floor: the size L [m], the driver's peak rate W, and the
// reference's largest force [N] and torque [N m] peaks (0 without forces).
struct Scales {
  double size = 0.0;
  double driver_rate = 0.0;
  double force = 0.0;
  double torque = 0.0;
};

// The floor F of one channel (see above). `kind_peak` is the largest P of the channel's kind,
// `magnitude_peak` the peak of its point's |v|, |a| or |f| (0 for a channel that is no
// component).
double peak_floor(std::string_view channel, double kind_peak, double magnitude_peak,
                  const Scales& scales);

// The definitions above as legend lines for reports: (term, definition).
std::vector<std::pair<std::string, std::string>> metric_legend();

}  // namespace crosslink::compare
