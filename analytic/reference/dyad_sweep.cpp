#include "analytic/reference/dyad_sweep.h"

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include "analytic/kinematics/continuation.h"
#include "analytic/physics/kinetostatics.h"

namespace crosslink {

namespace {

constexpr double kPi = std::numbers::pi;
// A drawing whose groups' loci meet at a sine above this is clear of singular positions: its
// modes are told apart by continuity from there (a 1e-4 deg neighbour of a kite's change point
// is at 1e-6).
constexpr double kClearOfSingular = 1e-3;

// Moves a solved DyadState along its branch to a driver value in substeps, as the Newton sweep's
// Follower does for Newton. The closed form picks, per group, the root nearest a linear
// prediction from the last two solves; over a long step that prediction can land nearer the
// other assembly (a 90 degree grid step on the sewing machine did), so steps are capped and a
// substep whose choice is not clear-cut is refused and halved. At a singular position, where the
// two roots meet, the halving stops at the smallest step the driver tells apart.
class DyadMarch {
 public:
  DyadMarch(const DyadSolver& solver, DyadState& state, double max_step, double min_step)
      : solver_(solver), state_(state), saved_(state), max_step_(max_step), min_step_(min_step) {}

  // On failure (a group cannot assemble) the state is solved at the last value reached. Mode
  // changes on the way are in changes().
  SolveReport advance_to(double target) {
    changes_.clear();
    SolveReport last;
    double allowed = max_step_;
    bool first = true;
    while (first || state_.kinematics.parameter() != target) {
      first = false;
      // Equal substeps to the target: a short remainder would make the next prediction
      // extrapolate from two solves too close to tell their difference from round-off.
      const double d0 = state_.kinematics.parameter(), remaining = target - d0;
      const double h = remaining / std::max(1.0, std::ceil(std::abs(remaining) / allowed - 1e-9));
      saved_ = state_;
      state_.kinematics.set_parameter(solver_.mechanism(),
                                      std::abs(h) < std::abs(remaining) ? d0 + h : target);
      const SolveReport report = solver_.solve_position(state_);
      const bool shortest = std::abs(h) <= min_step_;
      // Refused: a group cannot assemble (perhaps a step past a limit the target stops short
      // of), or its choice of root is not clear-cut.
      if (report.status == PoseStatus::cannot_assemble ||
          (state_.ambiguity > kAmbiguous && !shortest)) {
        state_ = saved_;
        if (shortest) return report;
        allowed = 0.5 * std::abs(h);
        continue;
      }
      changes_.insert(changes_.end(), state_.mode_changes.begin(), state_.mode_changes.end());
      last = report;
      allowed = std::min(2.0 * allowed, max_step_);
    }
    return last;
  }

  const std::vector<DyadState::ModeChange>& changes() const { return changes_; }

 private:
  // The chosen root must be at least four times nearer the prediction than the other.
  static constexpr double kAmbiguous = 0.25;
  const DyadSolver& solver_;
  DyadState& state_;
  DyadState saved_;  // the state before the substep being tried
  double max_step_, min_step_;
  std::vector<DyadState::ModeChange> changes_;
};

// The coordinates q of a sample of a trajectory with positions: each moving link's angle, and its
// origin from the world position of one of its points (a point it shares by name with the
// trajectory's named points, as a joint's two links do). False when a link has no such point.
bool coordinates_of(const Mechanism& m, const Trajectory& t, int row, Eigen::VectorXd& q) {
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const double theta = t.angle(row, k);
    bool placed = false;
    for (const Point& p : m.links[l].points) {
      const auto it = std::find(t.point_names.begin(), t.point_names.end(), p.name);
      if (it == t.point_names.end()) continue;
      const auto c = static_cast<Eigen::Index>(it - t.point_names.begin());
      const Eigen::Vector2d origin = Eigen::Vector2d(t.x(row, c), t.y(row, c)) -
                                     Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local;
      q.segment<3>(3 * k) << origin.x(), origin.y(), theta;
      placed = true;
      break;
    }
    if (!placed) return false;
  }
  return true;
}

}  // namespace

Trajectory dyad_sweep(const Mechanism& mechanism, const Trajectory& grid, bool forces) {
  const bool timed = mechanism.axis().timed();
  const double start_value = timed ? 0.0 : mechanism.swept().start;
  // A sample's own time and drivers' states.
  const auto drive = [&](KinematicState& k, int row) {
    if (timed) {
      k.drive_at(mechanism, grid.time(row));
      return;
    }
    const Driver& d = mechanism.swept();
    k.swept() = d.at_time(grid.time(row));
    k.swept().value = grid.swept(row);
    // Reversed at a toggle (--at-limit reverse), the driver runs against its law's speed: the
    // direction toward the next sample (at the end, from the last), as the Newton sweep's.
    if (d.law.kind != MotionLaw::Kind::constant_speed) return;
    double way = 0.0;
    if (row + 1 < grid.samples() && grid.swept(row + 1) != grid.swept(row))
      way = grid.swept(row + 1) - grid.swept(row);
    else if (row > 0)
      way = grid.swept(row) - grid.swept(row - 1);
    if (way * d.law.speed < 0.0) k.swept().rate = -k.swept().rate;
  };
  Trajectory out;
  out.method = "dyads";
  out.resize_as(mechanism, grid, forces);
  Decomposition decomposition = decompose(mechanism);
  const NewtonSolver newton(mechanism);
  KinematicState assembled(mechanism);
  const SolveReport start = newton.assemble(assembled);
  PoseStatus failure = PoseStatus::ok;
  std::string why;
  if (!decomposition.complete) {
    failure = PoseStatus::no_convergence;
    why = "does not decompose into dyads: " + decomposition.reason;
  } else if (start.status != PoseStatus::ok && start.status != PoseStatus::singular) {
    failure = start.status;
    why = start.message;
  }
  if (failure != PoseStatus::ok) {
    out.status.assign(static_cast<size_t>(out.samples()), failure);
    out.events.push_back({start_value, failure, why});
    return out;
  }
  const DyadSolver solver(mechanism, std::move(decomposition));
  DyadState state(mechanism);
  solver.set_modes(assembled, state);
  // The driver tells apart values 1e-10 rad (or 1e-10 of the size) apart, as the Newton sweep.
  // Several drivers: steps in time in which no driver moves more than its continuation step
  // (1 degree, or the size's arc over 1 degree), down to 1e-12 of the sweep's time.
  double unit = 1.0, max_step = 0.0, min_step = 0.0;
  if (!timed) {
    unit = mechanism.swept().angular() ? 1.0 : mechanism.size();
    max_step = continuation_step(mechanism);
    min_step = unit * 1e-10;
  } else {
    // From the assembly at t = 0 through each sample's time.
    const double end = grid.time(grid.samples() - 1);
    max_step = end > 0.0 ? end : 1.0;
    double previous = 0.0;
    for (int row = 0; row < grid.samples(); ++row) {
      const double t = grid.time(row);
      if (t == previous) continue;
      max_step = std::min(max_step, (t - previous) / timed_substeps(mechanism, previous, t));
      previous = t;
    }
    min_step = 1e-12 * (end > 0.0 ? end : 1.0);
    unit = max_step * 180.0 / kPi;  // a step that moves a driver about 1 rad
  }
  DyadMarch march(solver, state, max_step, min_step);
  // Forces: the multipliers (kinetostatics method 1) at each closed-form pose, with the
  // constraint Jacobian factorised there.
  const Kinetostatics kinetostatics(newton);
  ForceSample reactions = kinetostatics.make_sample();
  KinematicState at_pose(mechanism);

  // The reference's singular positions (toggles and change points, located to ~1e-12 on its
  // traced curve) are the dyads' events too: a mode change the march meets within a substep is
  // the change point located inside it, and is told at its located value, not the substep's end.
  for (const Trajectory::Event& e : grid.events)
    if (e.kind == PoseStatus::singular || e.kind == PoseStatus::branch_jump)
      out.events.push_back(e);
  const size_t located = out.events.size();
  auto note_mode_change = [&](const DyadState::ModeChange& c, double from) {
    const std::string what = fmt::format(
        "assembly mode of {} changes from {} to {}: its two assemblies meet here and "
        "the motion is followed continuously",
        solver.decomposition().groups[static_cast<size_t>(c.group)].name,
        solver.describe_mode(c.group, c.from), solver.describe_mode(c.group, c.to));
    for (size_t e = 0; e < located; ++e) {
      Trajectory::Event& at = out.events[e];
      if (at.message.rfind("change_point", 0) != 0 ||
          (at.driver - from) * (at.driver - c.driver) > 0.0)
        continue;
      at.message += "; " + what;
      return;
    }
    out.events.push_back({c.driver, PoseStatus::singular, what});
  };
  KinematicState reference(mechanism);
  auto solve_row = [&](int row) {
    if (grid.status[static_cast<size_t>(row)] == PoseStatus::singular &&
        coordinates_of(mechanism, grid, row, reference.q)) {
      // The reference flags this sample: too near a singular position for its rates to be exact
      // to round-off, where continuity cannot tell the two assemblies apart either. Its pose is
      // the root nearest the reference's, and the march goes on from the last pose it solved.
      DyadState side = state;
      reference.set_parameter(mechanism, grid.along(row));
      solver.set_modes(reference, side);
      side.kinematics.set_parameter(mechanism, grid.along(row));
      SolveReport r = solver.solve_position(side);
      if (r.status == PoseStatus::ok || r.status == PoseStatus::singular) {
        r.status = PoseStatus::singular;
        r.message = "as the reference: beside a singular position";
      } else {
        r.status = PoseStatus::singular;  // the loci touch within round-off: the reference's pose
        side.kinematics.q = reference.q;
      }
      drive(side.kinematics, row);
      side.kinematics.qdot.setZero();
      side.kinematics.qddot.setZero();
      newton.write_sample(side.kinematics, r, out, row);
      return;
    }
    const double from = state.kinematics.parameter();
    SolveReport r = march.advance_to(grid.along(row));
    for (const DyadState::ModeChange& c : march.changes()) note_mode_change(c, from);
    if (r.status == PoseStatus::cannot_assemble) {
      if (out.events.empty() || out.events.back().kind != PoseStatus::cannot_assemble)
        out.events.push_back({state.kinematics.parameter(), r.status, r.message});
      // The sample has no pose; the march resumes from the last one it solved.
      KinematicState none = state.kinematics;
      none.q.setZero();
      none.qdot.setZero();
      none.qddot.setZero();
      // The sample's own time and driver state, not the last pose's.
      drive(none, row);
      newton.write_sample(none, r, out, row);
      return;
    }
    drive(state.kinematics, row);
    if (r.status == PoseStatus::ok) {
      solver.solve_velocity(state);
      solver.solve_acceleration(state);
    } else {
      state.kinematics.qdot.setZero();
      state.kinematics.qddot.setZero();
    }
    newton.write_sample(state.kinematics, r, out, row);
    if (r.status != PoseStatus::ok || !out.has_forces) return;
    at_pose.q = state.kinematics.q;
    at_pose.qdot = state.kinematics.qdot;
    at_pose.qddot = state.kinematics.qddot;
    at_pose.drivers = state.kinematics.drivers;
    if (newton.solve_position(at_pose).status != PoseStatus::ok) {
      // The constraint Jacobian is singular here: the reactions are not determined.
      out.status[static_cast<size_t>(row)] = PoseStatus::singular;
      return;
    }
    at_pose.qdot = state.kinematics.qdot;  // the closed form's, not re-solved
    at_pose.qddot = state.kinematics.qddot;
    kinetostatics.solve(at_pose, reactions);
    if (reactions.status != PoseStatus::ok) {
      out.status[static_cast<size_t>(row)] = reactions.status;
      return;
    }
    if (!reactions.finite()) {
      out.status[static_cast<size_t>(row)] = PoseStatus::singular;
      return;
    }
    kinetostatics.write_sample(reactions, out, row);
  };
  if (grid.samples() == 0) return out;

  // From the sample nearest the start value forward, then from it backward. Near a singular
  // position continuity cannot tell the two assemblies apart, so the march starts from the
  // nearest sample the reference solved well, with the modes of the reference's pose there.
  int first = -1;
  for (int i = 0; i < grid.samples(); ++i)
    if (grid.status[static_cast<size_t>(i)] == PoseStatus::ok &&
        (first < 0 ||
         std::abs(grid.along(i) - start_value) < std::abs(grid.along(first) - start_value)))
      first = i;
  // The modes are the drawing's, and the march goes from the drawn pose to that sample, so the
  // dyads check Newton independently of its start (a Newton start on a fold put 66 samples on
  // the other assembly, and dyads seeded from them agreed). Only a drawing beside a singular
  // position, where continuity cannot tell the two assemblies apart, takes the reference's modes
  // at that sample instead.
  const bool drawn_clear = [&] {
    DyadState at_start = state;
    return solver.solve_position(at_start).status == PoseStatus::ok &&
           at_start.smallest_sine >= kClearOfSingular;
  }();
  if (first >= 0 && drawn_clear) {
    // (the march to it starts from the drawing)
  } else if (first >= 0 && coordinates_of(mechanism, grid, first, reference.q)) {
    reference.set_parameter(mechanism, grid.along(first));
    solver.set_modes(reference, state);
  } else {
    first = 0;
    for (int i = 1; i < grid.samples(); ++i)
      if (std::abs(grid.along(i) - start_value) < std::abs(grid.along(first) - start_value))
        first = i;
  }
  solve_row(first);
  const DyadState at_first = state;
  // Continuity predicts linearly from the last two poses: the first march step gets a second
  // pose a little behind the first sample (1e-4 of the driver's unit: well inside the band
  // the reference keeps clear of singular positions), so that a step crossing a change point
  // right after it is predicted, not guessed.
  auto seed = [&](int toward) {
    if (toward < 0 || toward >= grid.samples() || grid.along(toward) == grid.along(first)) return;
    const double behind =
        grid.along(first) - 1e-4 * unit * (grid.along(toward) > grid.along(first) ? 1.0 : -1.0);
    if (march.advance_to(behind).status == PoseStatus::cannot_assemble) return;
    march.advance_to(grid.along(first));
  };
  // Where the grid turns back at a toggle (--at-limit reverse), the chain goes on through the
  // fold onto the folding group's other assembly: the march is taken to the fold, and the group
  // whose two roots meet there (its own closed form says which) changes mode. Continuity alone
  // would retrace the way it came on the first assembly.
  const auto turns_back = [&](int k) {
    if (k <= 0 || k + 1 >= grid.samples()) return false;
    const double before = grid.along(k) - grid.along(k - 1);
    const double after = grid.along(k + 1) - grid.along(k);
    return before * after < 0.0;
  };
  const auto through_fold = [&](int k) {
    march.advance_to(grid.along(k));  // short of it by round-off where it cannot assemble
    solver.solve_position(state);
    const int g = state.folding_group;
    if (g < 0) return;
    state.assembly_mode[static_cast<size_t>(g)] = -state.assembly_mode[static_cast<size_t>(g)];
    state.history = 0;  // no prediction from the way in
    solver.solve_position(state);
  };
  seed(first + 1);
  for (int i = first + 1; i < grid.samples(); ++i) {
    if (turns_back(i - 1)) through_fold(i - 1);
    solve_row(i);
  }
  state = at_first;
  seed(first - 1);
  for (int i = first - 1; i >= 0; --i) {
    if (turns_back(i + 1)) through_fold(i + 1);
    solve_row(i);
  }
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const auto& a, const auto& b) { return a.driver < b.driver; });
  return out;
}

Trajectory dyad_sweep(const Mechanism& mechanism, const SweepOptions& options) {
  return dyad_sweep(mechanism, sweep(mechanism, options));
}

}  // namespace crosslink
