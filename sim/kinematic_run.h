// The run loop every engine's kinematic run shares (docs/decisions.md, "Run loop"): the plan
// (usable span, step grid, pre-roll, exact start), the steps (drive, loads, step, read, watch), the
// samples written as soon as their stencils are complete (positions, rates and forces from a ring
// of the last poses: memory does not grow with the steps), the statuses, the notes and the cost.
// An engine supplies only a KinematicScene: its scene built at the plan's start, stepped.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "sim/engine.h"
#include "sim/forces.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"
#include "sim/statuses.h"

namespace crosslink::sim {

// An engine's scene in a kinematic run: what the loop asks of it, in the mechanism's terms.
class KinematicScene {
 public:
  virtual ~KinematicScene() = default;
  // Each driver's value by the definition's law (Driver::at_time), in Mechanism::drivers order,
  // to reach at the end of the next step.
  virtual void drive(const std::vector<double>& driver_values) = 0;
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
  double gap = 0.0;             // a larger joint gap [m] in a sample's interval: loop_gap
  double divergence_gap = 0.0;  // a larger joint gap [m] at a step: the run diverged there
  // A driver further from its law: the run lost it. In driver_watch_unit; a driver of the other
  // kind (an angle beside a slider) compares against it times or over the mechanism's size.
  double driver = 0.0;
  double singular_rcond = 0.0;   // the fraction of the chain's own conditioning: singular below
  double branch_distance = 0.0;  // a closed configuration further from the reference's [size or
                                 // rad]: branch_jump
};

// The unit of KinematicWatch::driver and of the engines' driver_threshold setting: 1 (rad), or
// the mechanism's size (m) where the swept driver is a slider; rad for a sweep in time.
double driver_watch_unit(const Mechanism& m);

// When a run starts, how it steps, and the exact state it starts from. The steps split each
// sample interval of the usable span into equal ones no longer than the engine's wanted step
// (sample_grid()), so samples fall on steps. A sweep over whole cycles, usable throughout, is
// periodic: the run starts `preroll` steps before its first sample and ends as many after its
// last, so every stencil is central and clear of the start's transient, unless the chain does
// not close well conditioned there (then it starts on the first sample).
struct KinematicPlan {
  Span span;
  TimeGrid grid;
  long preroll = 0;         // steps before the first sample (and after the last)
  Eigen::VectorXd q, qdot;  // the scene mechanism's exact state at grid.time[0]
  // Per driver (Mechanism::drivers order): the reference's value less the definition's law.
  std::vector<double> driver_offset;
  std::string note;  // "" or how the start was made (a perturbed chain started open)
};
// `wanted`: the longest step [s]; `inner`: where steps fall inside an interval; `singular_rcond`:
// the pre-roll's start conditioned worse than this fraction of the chain's own is refused. With
// several drivers the reference is sampled in time, each driver at its law: the grid maps samples
// to steps by time as for one, and a periodic run's pre-roll takes every law before t = 0. Throws
// std::runtime_error when there is nothing to run over, the steps are too many (check_steps) or
// the scene's chain does not close at the start (a perturbed chain then starts open, noted).
KinematicPlan plan_kinematic(const Mechanism& scene_mechanism, const Trajectory& reference,
                             double wanted, InnerTimes inner, long preroll, long max_steps,
                             double singular_rcond, bool perturbed);

// The fastest link's angular speed over the reference's usable samples in `span` [rad/s]: what
// an engine's step length follows (errors grow as (omega dt)^2).
double fastest_rate(const Trajectory& reference, const Span& span);

// The step length rule every engine follows: the longest step is `dt` when given (non-zero);
// else the longest sample interval over `steps_per_sample` (0: no such bound), shorter where the
// reference's fastest link would turn more than `max_step_angle` [rad] in a step (0: no such
// bound); with neither bound, the first sample interval.
double step_length(const Trajectory& reference, const Span& span, double dt, double max_step_angle,
                   int steps_per_sample);

// How a driver's value maps to the scene coordinate that realises it, for an engine that drives
// the coordinate to a target: linear through the start, where the scene assembled at
// `coordinate0` with the driver at its law's value plus the plan's offset (the reference's
// count); `sign` is d(coordinate)/d(driver value).
struct DriveTarget {
  double coordinate0 = 0.0;
  double driver0 = 0.0;        // the driver's value at the start, as the reference counts it
  double driver_offset = 0.0;  // the reference's driver value less the definition's law
  double sign = 1.0;
  // Driver d's (Mechanism::drivers order) over the kinematic plan `plan`.
  static DriveTarget of(const Mechanism& m, const KinematicPlan& plan, size_t d, double coordinate0,
                        double sign);
  // The coordinate the scene is to reach at the definition's driver value `law`.
  double target(double law) const { return coordinate0 + sign * (law + driver_offset - driver0); }
};

// The joints' gap of a pose (the largest residual of the joint rows, angle rows times the size)
// and the driver row's error, from the one constraint layout. A force-closed cam's row counts its
// penetration only: the follower may leave the cam (its separation, separation()).
class JointGap {
 public:
  JointGap(const Mechanism& m, const NewtonSolver& solver);
  // With each driver at its value in `driver_values` (as the reference counts them, in
  // Mechanism::drivers order): the gap (infinite when it or a driver's row is not finite) and
  // each driver row's error in `driver_errors`.
  double at(const Eigen::VectorXd& q, const std::vector<double>& driver_values,
            std::vector<double>& driver_errors);
  // A dynamics run: each driver's row is measured at the engine's own coordinate, so it is zero.
  double at(const Eigen::VectorXd& q);
  // How far the followers of force-closed cams stand off their profiles at q [m] (0 when none
  // does, or the mechanism has no such cam).
  double separation(const Eigen::VectorXd& q);

 private:
  double joints() const;  // the joint rows' gap of phi_
  // phi_ at q with each driver's row at its measured value (zero).
  void measure(const Eigen::VectorXd& q);
  const NewtonSolver& solver_;
  double size_;
  std::vector<int> one_sided_;  // the rows of force-closed cams: a positive residual stands off
  Eigen::VectorXd phi_;
  std::vector<DriverState> drivers_;  // scratch: the drivers' values as the layout takes them
};

// The joints' gap of every pose a run's steps reach, kept as the largest in each sample's interval
// (S_i-1, S_i] of the steps (a pre-roll's in the first and last samples').
class IntervalGaps {
 public:
  IntervalGaps(const Mechanism& scene_mechanism, const TimeGrid& grid, const Span& span,
               int samples)
      : solver_(scene_mechanism),
        gap_(scene_mechanism, solver_),
        grid_(grid),
        last_(span.last),
        interval_(span.first),
        gaps_(Eigen::VectorXd::Zero(samples)) {}
  // Pose k's gap, with each driver row's error at `driver_values` (JointGap::at).
  double at(long k, const Eigen::VectorXd& q, const std::vector<double>& driver_values,
            std::vector<double>& driver_errors) {
    return keep(k, gap_.at(q, driver_values, driver_errors));
  }
  double at(long k, const Eigen::VectorXd& q) { return keep(k, gap_.at(q)); }
  const Eigen::VectorXd& gaps() const { return gaps_; }  // per sample

 private:
  double keep(long k, double gap);
  const NewtonSolver solver_;  // the scene's chain
  JointGap gap_;
  const TimeGrid& grid_;
  int last_, interval_;  // the sample whose interval holds the current step
  Eigen::VectorXd gaps_;
};

// A run's samples as it writes them: each a trajectory row by the exact solver's code (points and
// sliders from the links' coordinates) from state(), with the forces of forces() when the run
// reads them, and its configuration kept for the statuses.
class SampleRows {
 public:
  SampleRows(const Mechanism& m, int samples, bool with_forces)
      : m_(m),
        with_forces_(with_forces),
        writer_(m),
        state_(m),
        forces_(m.joints.size(), m.drivers.size()),
        configuration_(Eigen::MatrixXd::Zero(m.coordinate_count(), samples)),
        recorded_(static_cast<size_t>(samples), false) {}
  KinematicState& state() { return state_; }
  ForceReading& forces() { return forces_; }
  bool with_forces() const { return with_forces_; }
  void write(int i, Trajectory& out) {
    writer_.write_sample(state_, SolveReport{}, out, i);
    if (with_forces_) write_forces(m_, state_, forces_, out, i);
    recorded_[static_cast<size_t>(i)] = true;
    configuration_.col(i) = state_.q;
  }
  bool recorded(int i) const { return recorded_[static_cast<size_t>(i)]; }
  Eigen::VectorXd configuration(int i) const { return configuration_.col(i); }

 private:
  const Mechanism& m_;
  bool with_forces_;
  const NewtonSolver writer_;
  KinematicState state_;
  ForceReading forces_;
  Eigen::MatrixXd configuration_;
  std::vector<bool> recorded_;
};

// Every sample's status and rcond (and out.loop_gap = `gaps`): outside the usable span the
// reference's kept, not written by the run diverged, else `judged(i, projected, closed)` from the
// Newton projection `projected` of the configuration the run wrote onto the definition's
// constraints with the drivers' states `drive(i, probe)` sets (a kinematic run: the reference's,
// reference_drivers; a dynamics run: the coordinates the run measured), `closed` the
// configuration it closes on.
void judge_projected(
    StatusJudge& judge, const Mechanism& m, const Trajectory& reference, const SampleRows& rows,
    const Eigen::VectorXd& gaps, const std::function<void(int, KinematicState&)>& drive,
    const std::function<PoseStatus(int, const SolveReport&, const KinematicState&)>& judged,
    Trajectory& out);

// Every driver's state at the reference's sample i: its law at the sample's time, at the
// reference's value (the definition's law plus the plan's offset).
void reference_drivers(const Mechanism& m, const Trajectory& reference, int i,
                       KinematicState& state);

// Runs `scene` over `plan` and fills `run`: its trajectory (shaped for `definition` with forces
// when `with_forces`) sampled at the reference's samples with each sample's status, its notes
// and its cost (wall time from `begin`). `scene_mechanism` is the chain the scene realises (the
// definition, or its perturbed copy); samples are read as the definition's.
void run_kinematic(const Mechanism& definition, const Mechanism& scene_mechanism,
                   const Trajectory& reference, const KinematicPlan& plan,
                   const KinematicWatch& watch, bool with_forces, KinematicScene& scene,
                   Clock::time_point begin, EngineRun& run);

}  // namespace crosslink::sim
