// Worst differences between an engine run and the analytic sweep, per quantity class.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink::test {

struct Agreement {
  double position = 0.0;      // worst |difference| / mechanism size
  double angle = 0.0;         // worst |difference| [rad]
  double velocity = 0.0;      // worst |difference| / the channel's peak
  double acceleration = 0.0;  // worst |difference| / the channel's peak
  std::string worst_velocity, worst_acceleration;
  int compared = 0;  // samples usable in both
};

// Samples flagged by either side are left out (as the comparator does).
inline Agreement agreement(const Mechanism& m, const Trajectory& ref, const Trajectory& run) {
  Agreement a;
  auto usable = [&](int i) {
    return ref.status[i] == PoseStatus::ok && run.status[i] == PoseStatus::ok;
  };
  for (int i = 0; i < ref.samples(); ++i) a.compared += usable(i);
  std::map<Quantity, double> class_peak;  // each quantity's largest value
  for (const std::string& ch : ref.channel_names()) {
    const auto r = *ref.channel(ch);
    for (int i = 0; i < r.size(); ++i)
      if (usable(i)) {
        double& p = class_peak[Trajectory::quantity_of(ch)];
        p = std::max(p, std::abs(r(i)));
      }
  }
  for (const std::string& ch : ref.channel_names()) {
    // Motion only: the forces are compared where the engine reads them.
    if (!run.channel(ch)) continue;
    const auto r = *ref.channel(ch);
    const auto e = *run.channel(ch);
    const Quantity q = Trajectory::quantity_of(ch);
    double peak = 0.0, err = 0.0;
    for (int i = 0; i < r.size(); ++i)
      if (usable(i)) {
        peak = std::max(peak, std::abs(r(i)));
        err = std::max(err, std::abs(r(i) - e(i)));
      }
    // A Cartesian component is judged against its point's whole velocity (acceleration): a
    // component that is zero by construction (vy of a slider on a horizontal guide) has no peak
    // of its own.
    const std::string prefix = ch.substr(0, ch.find('.'));
    if (prefix == "vx" || prefix == "vy" || prefix == "ax" || prefix == "ay") {
      const auto whole = *ref.channel(prefix.substr(0, 1) + ch.substr(ch.find('.')));
      for (int i = 0; i < whole.size(); ++i)
        if (usable(i)) peak = std::max(peak, std::abs(whole(i)));
    }
    // A channel that is (near) zero by construction, like the angular acceleration of a crank
    // at constant speed, is judged against 1e-3 of its class peak.
    peak = std::max(peak, 1e-3 * class_peak[q]);
    if (q == Quantity::position) a.position = std::max(a.position, err / m.size());
    if (q == Quantity::angle) a.angle = std::max(a.angle, err);
    if (q == Quantity::velocity && err / peak > a.velocity) {
      a.velocity = err / peak;
      a.worst_velocity = ch;
    }
    if (q == Quantity::acceleration && err / peak > a.acceleration) {
      a.acceleration = err / peak;
      a.worst_acceleration = ch;
    }
  }
  return a;
}

}  // namespace crosslink::test
