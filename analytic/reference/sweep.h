// Driver sweeps: follow one assembly branch continuously over the driver's cycle or its
// assembling range, sampling position, velocity and acceleration on a regular grid.
#pragma once

#include <algorithm>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/kinematics/continuation.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

struct SweepOptions {
  // Grid step of the driver [rad or m]; 0 = 1 degree for angles, 1/360 of the range for sliders.
  double step = 0.0;
  // Sweep this driver interval instead of the cycle or the assembling range [rad or m].
  std::optional<std::pair<double, double>> range;
  NewtonOptions newton;
  // What a constant-speed sweep does at a limit of the assembling range (a toggle): stop there
  // (the sweep covers the range on the drawn branch), or reverse the driver as a real rocker
  // would and follow the chain back on the other assembly mode until it closes its loop.
  enum class AtLimit { stop, reverse };
  AtLimit at_limit = AtLimit::stop;
  // The tracer's budget of arclength steps for each leg of the configuration curve (a cycle of
  // a drawn linkage takes a few thousand): a leg that spends it ends flagged and the assembling
  // range is unknown, never its last pose taken for a limit.
  int tracer_steps = 400000;
};

// A position along the sweep where the Jacobian is singular, or where the branch was lost.
enum class SingularKind {
  toggle,        // dead point: the driver reaches an extreme (a fold of the configuration curve,
                 // transmission angle 0 or 180 deg in a four-bar) and bounds the assembling range
  change_point,  // two branches cross (the constraint Jacobian loses rank); the driver passes and
                 // the sweep continues on the smooth branch (continuous velocity)
  branch_jump,   // the tracer could not continue on its branch
};
std::string_view to_string(SingularKind kind);

struct SingularPosition {
  SingularKind kind = SingularKind::toggle;
  double driver = 0.0;     // located to ~1e-12 [rad or m]
  double direction = 0.0;  // +1 / -1: the driver's direction of travel arriving there
  std::string message;
};

// Where the chain can be assembled, found by continuation from the drawn position.
struct AssemblingRange {
  bool full_cycle = false;  // the driver turns (or runs) through its whole cycle
  double lower = 0.0;       // limits when not full_cycle [rad or m]
  double upper = 0.0;
  std::string unknown;  // why the range could not be traced (a leg lost the chain); else empty
  std::string explain(const Mechanism& mechanism) const;  // in the file's units
};

// Continuation over the driver from the drawn position to find its assembling range. Limits are
// located by bisection to `tolerance` in the driver coordinate.
AssemblingRange assembling_range(const Mechanism& mechanism, const SweepOptions& options = {},
                                 double tolerance = 1e-9);

// The exact sweep: samples at start + k*step (in the direction of the driver's speed) over one
// cycle when the driver can complete it, else over the assembling range; over an explicit range
// (options.range, else the driver's), its grid and its own ends (range_grid()). For a polynomial or
// table law, samples are equally spaced in time over the law's duration. Each sample's status says
// whether it is usable; events list limits and jumps.
//
// Singular positions met on the way are events (kind `singular`, message "toggle: ...",
// "change_point: ...") located to ~1e-12 in the driver; a constant-speed sweep also has a sample
// exactly at each toggle (flagged singular), inside an explicit range too, where the range is
// swept on the traced curve (a chain that does not turn fully: an end within 1e-9 of a toggle is
// that toggle, a value beyond a limit a sample without a pose). The overload also returns them as
// data.
Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options = {});
Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options,
                 std::vector<SingularPosition>& singular);

// The driver values of a sweep over an explicit range [lower, upper] from `start` at `step`: the
// grid start + k*step strictly inside, and the range's own two ends (a range between two grid
// values still has them; a grid value within 1e-9 of a step of an end is that end). The grid's
// indices are doubles: the work bound counts them before any is made (analytic/reference/budget.h).
struct RangeGrid {
  double start = 0.0, step = 0.0, lower = 0.0, upper = 0.0;
  double first = 0.0, last = -1.0;  // the grid's indices k inside
  double size() const { return 2.0 + std::max(0.0, last - first + 1.0); }
  std::vector<double> values() const;  // ascending
};
RangeGrid range_grid(double start, double step, double lower, double upper);

// The exact state at one driver value, reached by continuation from the drawn position so it
// lies on the drawn branch. The driver's rate and acceleration are those of the motion law at
// the first time it passes the value (constant speed: the speed, zero).
// A driver that turns fully (angular, constant speed, the chain back at its drawn pose one turn
// on) is solved a whole number of turns nearer its start, its links' angles moved on by their
// own whole turns: the continuation covers at most about two turns however far the value.
Trajectory solve_at(const Mechanism& mechanism, double driver_value,
                    const SweepOptions& options = {});

// The whole turns solve_at skips on the way to `driver_value` (0 when it follows the driver all
// the way: a driver that does not turn fully, or a value within two turns of the start), and
// each link's angle over one turn the way the driver goes (a whole number of turns).
struct SkippedTurns {
  long turns = 0;
  Eigen::VectorXd link_turn;  // [rad] per moving link
  double driver_shift() const { return static_cast<double>(turns) * 2.0 * std::numbers::pi; }
  // The one-sample `pose` solved driver_shift() nearer the start made the pose at driver_value.
  void move_on(const Mechanism& mechanism, double driver_value, Trajectory& pose) const;
};
SkippedTurns skipped_turns(const Mechanism& mechanism, double driver_value,
                           const SweepOptions& options = {});

}  // namespace crosslink
