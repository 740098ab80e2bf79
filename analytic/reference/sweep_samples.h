// What the reference's sweeps share (internal to analytic/reference/): writing a solved sample
// with its rates and reactions, a sample without a pose, and the band beside a singular position
// where a sample's rates are dropped. The sweep along a driver's value is sweep.cpp, the sweep in
// time timed_sweep.cpp.
#pragma once

#include <fmt/format.h>

#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/trajectory.h"
#include "analytic/physics/kinetostatics.h"

namespace crosslink::sweeping {

// Writes samples: velocity and acceleration solved for the real driver state, then the forces
// (kinetostatics, method 1) at every usable sample.
class Recorder {
 public:
  explicit Recorder(const NewtonSolver& solver)
      : solver_(solver), kinetostatics_(solver), forces_(kinetostatics_.make_sample()) {}

  // The state's drivers are the sample's.
  void operator()(KinematicState& state, const SolveReport& report, Trajectory& out, int row) {
    if (report.status == PoseStatus::ok) {
      solver_.solve_velocity(state);
      solver_.solve_acceleration(state);
    } else {
      state.qdot.setZero();
      state.qddot.setZero();
    }
    solver_.write_sample(state, report, out, row);
    if (report.status != PoseStatus::ok || !out.has_forces) return;
    kinetostatics_.solve(state, forces_);
    if (forces_.status != PoseStatus::ok) {
      // Joint friction the motion does not determine (the pose stands, its forces do not), or a
      // follower that leaves its cam (the pose is not its motion).
      out.status[static_cast<size_t>(row)] = forces_.status;
      out.events.push_back({out.along(row), forces_.status, forces_.why(solver_.mechanism())});
      return;
    }
    if (!forces_.finite() || !state.qdot.allFinite() || !state.qddot.allFinite()) {
      // J is singular in floating point although Newton converged (two loops at a change point
      // at once): no rates, no reactions.
      out.status[static_cast<size_t>(row)] = PoseStatus::singular;
      out.events.push_back({out.along(row), PoseStatus::singular,
                            "Jacobian singular: rates and joint reactions are not determined"});
      return;
    }
    kinetostatics_.write_sample(forces_, out, row);
  }

 private:
  const NewtonSolver& solver_;
  Kinetostatics kinetostatics_;
  ForceSample forces_;
};

// A copy of `state` for a sample without a pose: no coordinates, rates or accelerations (the
// state itself stays where the branch stopped); the caller sets its driver.
inline KinematicState without_pose(const KinematicState& state) {
  KinematicState none = state;
  none.q.setZero();
  none.qdot.setZero();
  none.qddot.setZero();
  return none;
}

inline double sign_of(double v) {
  return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
}

// Where a sample solved by Newton is too near a singular position for its rates to be exact to
// round-off. Off the curve by the residual r, a pose a driver distance delta from a change point
// gets its rates wrong by r / delta^2 and its accelerations by r / delta^3 (relative), as the
// Jacobian's smallest singular value shrinks with delta: measured on a parallelogram and a kite
// after polishing to round-off, accelerations wrong by 2e-10 of their scale at delta = 1e-2 rad,
// 1.1e-9 at 5e-3, 3e-7 at 1e-3 and 4e5 at 1e-7 (tests/analytic/test_singular_samples.cpp). Near
// a toggle the smallest singular value shrinks as sqrt(delta). So a sample is flagged where the
// Jacobian's condition estimate is below kSingularBand of the best along the sweep (the chain's
// own, so the rule does not depend on its size or units): on those two, delta below 1.3e-2 rad,
// short of a 1-degree neighbour.
inline constexpr double kSingularBand = 1.5e-2;

class SingularBand {
 public:
  // `best`: the largest reciprocal condition estimate along the sweep.
  explicit SingularBand(double best) : threshold_(kSingularBand * best) {}
  // Empty when a pose's rates are exact to round-off; else why not.
  std::string why(double rcond) const {
    if (rcond >= threshold_) return "";
    return fmt::format(
        "beside a singular position: the Jacobian's condition estimate (rcond {:.1e}) is {:.1e} "
        "of its best along the sweep, so the rates are not determined to round-off here",
        rcond, rcond / threshold_ * kSingularBand);
  }

 private:
  double threshold_;
};

// Flags a sample singular after it was written: its positions stay, its rates and forces go.
inline void drop_rates(Trajectory& t, int row) {
  t.status[static_cast<size_t>(row)] = PoseStatus::singular;
  for (Eigen::MatrixXd* m : {&t.omega, &t.alpha, &t.vx, &t.vy, &t.ax, &t.ay, &t.sdot, &t.sddot,
                             &t.jerk, &t.fx, &t.fy, &t.fn, &t.moment, &t.shaking, &t.friction})
    if (m->rows() > row && m->cols() > 0) m->row(row).setZero();  // no columns: no data to offset
  if (t.effort.rows() > row && t.effort.cols() > 0) t.effort.row(row).setZero();
}

// Flags the samples whose condition is far below the best of the sweep's samples (a sweep
// without a traced curve): their positions stay, their rates and forces go.
inline void drop_rates_beside_singular(Trajectory& out) {
  double best = 0.0;
  for (int k = 0; k < out.samples(); ++k)
    if (has_position(out.status[static_cast<size_t>(k)])) best = std::max(best, out.rcond(k));
  const SingularBand band(best);
  for (int k = 0; k < out.samples(); ++k)
    if (out.status[static_cast<size_t>(k)] == PoseStatus::ok && !band.why(out.rcond(k)).empty())
      drop_rates(out, k);
}

// The sweep in time (several drivers): the samples at `times` (increasing from 0), followed from
// the assembled state at t = 0 (timed_sweep.cpp).
Trajectory timed_sweep(const NewtonSolver& solver, KinematicState& state,
                       const SolveReport& assembled, const std::vector<double>& times);

}  // namespace crosslink::sweeping
