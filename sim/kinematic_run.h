// The run loop every engine's kinematic run shares (docs/design.md, "sim/"): the plan (usable
// span, step grid, pre-roll, exact start), the steps (drive, loads, step, read, watch), the
// samples written as soon as their stencils are complete (positions, rates and forces from a ring
// of the last poses: memory does not grow with the steps), the statuses, the notes and the cost.
// An engine supplies only a KinematicScene: its scene built at the plan's start, stepped.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "analytic/mechanism.h"
#include "analytic/newton.h"
#include "analytic/trajectory.h"
#include "sim/engine.h"
#include "sim/forces.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"

namespace crosslink::sim {

// An engine's scene in a kinematic run: what the loop asks of it, in the mechanism's terms.
class KinematicScene {
 public:
  virtual ~KinematicScene() = default;
  // The driver's value by the definition's law (Driver::at_time) to reach at the end of the next
  // step.
  virtual void drive(double driver_value) = 0;
  // The definition's loads and springs on the moving links (Mechanism order) for the next step.
  virtual void apply(const std::vector<BodyLoad>& loads) = 0;
  // One step of `h` seconds; with `forces`, the constraint forces of the pose it leaves, in the
  // mechanism's terms. "" or the engine's own reason the step cannot be trusted.
  virtual std::string step(double h, ForceReading* forces) = 0;
  // The pose the last step reached: absolute coordinates of the moving links, each angle on the
  // turn of the pose before.
  virtual void read_pose(Eigen::VectorXd& q) = 0;
  virtual long evaluations() const = 0;  // model evaluations so far
  // What the run's message should add about the engine's own work ("" for nothing).
  virtual std::string note() const { return ""; }
};

// The thresholds a run watches its steps and judges its samples by, in force (auto resolved).
struct KinematicWatch {
  double gap = 0.0;              // a larger joint gap [m] in a sample's interval: loop_gap
  double divergence_gap = 0.0;   // a larger joint gap [m] at a step: the run diverged there
  double driver = 0.0;           // the driver further from its law [rad, or m]: the run lost it
  double singular_rcond = 0.0;   // the fraction of the chain's own conditioning: singular below
  double branch_distance = 0.0;  // a closed configuration further from the reference's [size or
                                 // rad]: branch_jump
};

// When a run starts, how it steps, and the exact state it starts from. The steps split each
// sample interval of the usable span into equal ones no longer than the engine's wanted step
// (sample_grid()), so samples fall on steps. A sweep over whole cycles, usable throughout, is
// periodic: the run starts `preroll` steps before its first sample and ends as many after its
// last, so every stencil is central and clear of the start's transient, unless the chain does
// not close well conditioned there (then it starts on the first sample).
struct KinematicPlan {
  Span span;
  TimeGrid grid;
  long preroll = 0;            // steps before the first sample (and after the last)
  Eigen::VectorXd q, qdot;     // the scene mechanism's exact state at grid.time[0]
  double driver_offset = 0.0;  // the reference's driver value less the definition's law
  std::string note;            // "" or how the start was made (a perturbed chain started open)
};
// `wanted`: the longest step [s]; `inner`: where steps fall inside an interval; `singular_rcond`:
// the pre-roll's start conditioned worse than this fraction of the chain's own is refused. Throws
// std::runtime_error when there is nothing to run over, the steps are too many (check_steps) or
// the scene's chain does not close at the start (a perturbed chain then starts open, noted).
KinematicPlan plan_kinematic(const Mechanism& scene_mechanism, const Trajectory& reference,
                             double wanted, InnerTimes inner, long preroll, long max_steps,
                             double singular_rcond, bool perturbed);

// The fastest link's angular speed over the reference's usable samples in `span` [rad/s]: what
// an engine's step length follows (errors grow as (omega dt)^2).
double fastest_rate(const Trajectory& reference, const Span& span);

// The joints' gap of a pose (the largest residual of the joint rows, angle rows times the size)
// and the driver row's error, from the one constraint layout.
class JointGap {
 public:
  JointGap(const Mechanism& m, const NewtonSolver& solver)
      : solver_(solver), size_(m.size()), phi_(m.coordinate_count()) {}
  // With the driver at `driver_value` (as the reference counts it): the gap (infinite when it
  // or the driver's row is not finite) and the driver row's error.
  double at(const Eigen::VectorXd& q, double driver_value, double& driver_error);
  // A dynamics run: the driver's row is measured at the engine's own coordinate, so it is zero.
  double at(const Eigen::VectorXd& q);

 private:
  double joints(const Eigen::VectorXd& q, double driver_value);
  const NewtonSolver& solver_;
  double size_;
  Eigen::VectorXd phi_;
};

// Runs `scene` over `plan` and fills `run`: its trajectory (shaped for `definition` with forces
// when `with_forces`) sampled at the reference's samples with each sample's status, its notes
// and its cost (wall time from `begin`). `scene_mechanism` is the chain the scene realises (the
// definition, or its perturbed copy); samples are read as the definition's.
void run_kinematic(const Mechanism& definition, const Mechanism& scene_mechanism,
                   const Trajectory& reference, const KinematicPlan& plan,
                   const KinematicWatch& watch, bool with_forces, KinematicScene& scene,
                   Clock::time_point begin, EngineRun& run);

}  // namespace crosslink::sim
