// The run loop every engine's forward-dynamics run shares (a [dynamics] case; docs/engines.md,
// "Forward dynamics"): the plan (usable span, steps on the samples and one past the last, the
// exact start), the steps (loads, step, read, watch), the work of the loads by the trapezoid
// rule, the samples written as soon as their stencils are complete (from a ring of the last
// poses: memory does not grow with the steps) with their forces and energy balance, the
// statuses, the notes and the cost. An engine supplies only a DynamicsScene.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "sim/engine.h"
#include "sim/forces.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"

namespace crosslink::sim {

// An engine's scene in a dynamics run, built at the plan's start, moving: what the loop asks of
// it, in the mechanism's terms.
class DynamicsScene {
 public:
  virtual ~DynamicsScene() = default;
  // Whether the engine evaluates the definition's loads itself at each evaluation of its
  // equations (MuJoCo's control callback, every RK4 stage); else the loop applies them at the
  // pose a step leaves, at its backward-difference velocity (start_velocity() at the start).
  virtual bool evaluates_loads() const { return false; }
  virtual void apply(const std::vector<BodyLoad>& /*loads*/) {}
  virtual Eigen::VectorXd start_velocity() const { return {}; }
  // One step from time t0 of `h` seconds; with `forces`, the constraint forces of the pose it
  // leaves. "" or the engine's own reason the step cannot be trusted.
  virtual std::string step(double t0, double h, ForceReading* forces) = 0;
  // The pose the last step reached (the start before any): absolute coordinates of the moving
  // links, each angle on the turn of the pose before.
  virtual void read_pose(Eigen::VectorXd& q) = 0;
  // The pose one step of `h` before the start, when the engine integrates back to it: then the
  // start is as clean as any later pose (central differences and forces read there). Else the
  // first sample takes one-sided differences over poses 1 to 4 and forces from pose 2 on.
  virtual bool pose_before_start(double /*h*/, Eigen::VectorXd& /*q*/) { return false; }
  // The state readout: the samples take the engine's own rates and forces at a sample's step
  // (read_state) instead of differences of poses (MuJoCo RK4, whose velocity is not staggered).
  virtual bool reads_state() const { return false; }
  // Whether the start (step 0) is read so, whatever reads_state(): the engine's rates and forces
  // from its own equations at the state it was given, where the differences would read its first
  // step (MuJoCo, whose first step lacks part of the velocity terms: docs/dynamics.md, "The first
  // instant").
  virtual bool reads_start_state() const { return false; }
  virtual void read_state(long /*step*/, double /*t*/, Eigen::VectorXd& /*qdot*/,
                          Eigen::VectorXd& /*qddot*/, ForceReading& /*forces*/) {}
  virtual long evaluations() const = 0;  // model evaluations so far
  // The work the engine's joint friction did over the last step [J] (docs/engines.md, "Joint
  // friction"): the energy balance's dissipated part.
  virtual double friction_work() const { return 0.0; }
  // What the run's message should add about the engine's own work ("" for nothing).
  virtual std::string note() const { return ""; }
};

// The thresholds a dynamics run watches and judges by, in force.
struct DynamicsWatch {
  double gap = 0.0;                // a larger joint gap [m] in a sample's interval: loop_gap
  double divergence_gap = 0.0;     // a larger joint gap [m] at a step: the run diverged there
  double singular_rcond = 0.0;     // the fraction of the chain's own conditioning: singular below
  double energy_scale = 0.0;       // the energy the exact motion moves [J]
  double energy_threshold = 0.0;   // an energy error beyond this fraction of it: drift (a note)
  double divergence_energy = 0.0;  // beyond this fraction: the run diverged there
};

// The steps (each sample interval of the usable span split into equal steps no longer than the
// engine's `wanted`, and one more past the last sample so that it has a central difference) and
// the exact start: the reference's first usable sample (its positions, velocities and
// accelerations); with `perturbed` the scene's chain closed by Newton at the reference's
// coordinate and rate. std::runtime_error when there is nothing to run over, the steps are too
// many (check_steps) or the perturbed chain does not close.
struct DynamicsPlan {
  Span span;
  TimeGrid grid;
  ReferenceState start;  // the scene mechanism's exact state at grid.time[0]
};
DynamicsPlan plan_dynamics(const Mechanism& definition, const Mechanism& scene_mechanism,
                           const Trajectory& reference, double wanted, InnerTimes inner,
                           long max_steps, bool perturbed);

// Runs `scene` over `plan` and fills `run`: its trajectory (shaped for `definition`, with forces
// when `with_forces`, and the energy balance) at the reference's samples with each sample's
// status, its notes and its cost (wall time from `begin`). `scene_mechanism` is the chain the
// scene realises (its joint gap); samples are read as the definition's.
void run_dynamics(const Mechanism& definition, const Mechanism& scene_mechanism,
                  const Trajectory& reference, const DynamicsPlan& plan, const DynamicsWatch& watch,
                  bool with_forces, DynamicsScene& scene, Clock::time_point begin, EngineRun& run);

}  // namespace crosslink::sim
