// What the engines' forward-dynamics tests share: IFToMM A02 with N = 2 (five bars under gravity
// for 10 s through seven singular positions), its exact simulation, and the worst differences of
// a run from it.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "sim/engine.h"

namespace crosslink::sim::dynamics_testing {

inline const Mechanism& a02() {
  static const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                            "/mechanisms/iftomm_a02_double_fourbar.toml");
  return m;
}

// The exact reference over `duration` seconds (0: the case's 10 s), sampled every `interval`.
inline const Trajectory& exact(double duration = 0.0, double interval = 0.0) {
  static std::map<std::pair<double, double>, Simulation> cache;
  auto it = cache.find({duration, interval});
  if (it == cache.end())
    it = cache
             .emplace(std::pair{duration, interval},
                      simulate(a02(), {.duration = duration, .interval = interval}))
             .first;
  EXPECT_TRUE(it->second.ok) << it->second.message;
  return it->second.trajectory;
}

// Worst differences over the samples both call usable: positions of the named points [m], point
// velocities and accelerations over their peak magnitude, |energy.error| [J].
struct Errors {
  double position = 0.0, velocity = 0.0, acceleration = 0.0, energy = 0.0;
  int usable = 0, flagged = 0;
};

inline Errors errors(const Trajectory& ref, const Trajectory& run) {
  Errors e;
  double v_peak = 0.0, a_peak = 0.0;
  for (int i = 0; i < ref.samples(); ++i) {
    const auto row = static_cast<size_t>(i);
    if (!usable(run.status[row])) ++e.flagged;
    if (!usable(ref.status[row]) || !usable(run.status[row])) continue;
    ++e.usable;
    for (Eigen::Index p = 0; p < ref.x.cols(); ++p) {
      e.position =
          std::max(e.position, std::hypot(run.x(i, p) - ref.x(i, p), run.y(i, p) - ref.y(i, p)));
      e.velocity = std::max(e.velocity,
                            std::hypot(run.vx(i, p) - ref.vx(i, p), run.vy(i, p) - ref.vy(i, p)));
      e.acceleration = std::max(
          e.acceleration, std::hypot(run.ax(i, p) - ref.ax(i, p), run.ay(i, p) - ref.ay(i, p)));
      v_peak = std::max(v_peak, std::hypot(ref.vx(i, p), ref.vy(i, p)));
      a_peak = std::max(a_peak, std::hypot(ref.ax(i, p), ref.ay(i, p)));
    }
    e.energy = std::max(e.energy, std::abs(run.energy(i, 3)));
  }
  e.velocity /= v_peak;
  e.acceleration /= a_peak;
  return e;
}

// Every sample the run flagged is `singular`, for its conditioning (rcond below 1e-3), next to a
// passage through A02's singular position (the cranks within 0.05 rad of the horizontal).
inline void expect_flags_only_at_passages(const Trajectory& ref, const Trajectory& run,
                                          const std::string& what) {
  for (int i = 0; i < ref.samples(); ++i) {
    const PoseStatus s = run.status[static_cast<size_t>(i)];
    if (s == PoseStatus::ok) continue;
    EXPECT_EQ(s, PoseStatus::singular) << what << " sample " << i;
    EXPECT_LT(run.rcond(i), 1e-3) << what << " sample " << i;
    EXPECT_LT(std::abs(std::remainder(ref.along(i), std::numbers::pi)), 0.05)
        << what << " sample " << i;
  }
}

inline bool all_finite(const Trajectory& t) {
  for (const Eigen::MatrixXd* m : {&t.angle, &t.omega, &t.alpha, &t.x, &t.y, &t.vx, &t.vy, &t.ax,
                                   &t.ay, &t.fx, &t.fy, &t.energy})
    if (!m->allFinite()) return false;
  return t.effort.allFinite() && t.driver_values.allFinite();
}

}  // namespace crosslink::sim::dynamics_testing
