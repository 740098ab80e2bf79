// What both engine models share when they apply the definition's loads and read the constraint
// forces back: the loads and springs as a wrench on each body, the auxiliary block's mass, and
// the forces of one sample in the Trajectory's conventions (trajectory.h) with the shaking force
// summed over what the moving links exert on the ground.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "analytic/physics/kinetostatics.h"

namespace crosslink::sim {

// The definition's loads, springs and dampers on one moving link, at its centre of mass.
struct BodyLoad {
  Eigen::Vector2d force = Eigen::Vector2d::Zero();  // world axes [N]
  double moment = 0.0;                              // about the centre of mass [N m]
};

// Per moving link (Mechanism order), from positions, velocities and the driver's value.
class AppliedLoads {
 public:
  explicit AppliedLoads(const Mechanism& m);
  bool any() const { return !m_.loads.empty() || !m_.springs.empty(); }
  const std::vector<BodyLoad>& at(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                                  double driver_value);

 private:
  const Mechanism& m_;
  KinematicState state_;
  Eigen::VectorXd generalised_;
  std::vector<BodyLoad> out_;
};

// Forward dynamics (a [dynamics] case): everything that acts on the mechanism besides gravity and
// the joints, as a wrench on each body at its centre of mass, and the energy balance of a state.
// Each free coordinate's applied effort acts along its driver's coordinate d: its generalised
// force is effort(t) times the driver's row of the constraint Jacobian, dd/dq (a torque on the
// driven link and the opposite one on its base for a joint angle, a force along the guide at the
// slider's point and its reaction for a slider), as in the exact equation of motion
// (analytic/physics/dynamics.h).
class DynamicsLoads {
 public:
  explicit DynamicsLoads(const Mechanism& m);
  // Whether anything but gravity acts: loads, springs or dampers, or an effort.
  bool any() const { return any_; }
  // Per moving link (Mechanism order) at time t [s] and state (q, qdot): the loads at the driver
  // coordinates measured at q, the springs and dampers, and each coordinate's effort(t) along it.
  const std::vector<BodyLoad>& at(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot);
  // Driver d's coordinate measured at q [rad or m] (Mechanism::drivers order), and its rate at
  // (q, qdot).
  double coordinate(const Eigen::VectorXd& q, int d = 0) const {
    return solver_.driver_value(q, d);
  }
  double rate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, int d = 0);
  // Every driver's state in `state` at (q, qdot): its coordinate, its rate and time t.
  void measure(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
               KinematicState& state);
  // [J]: the kinetic energy (Link::mass), and the potential energy of gravity and springs.
  double kinetic(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot);
  double potential(const Eigen::VectorXd& q);
  // [W]: the power of the efforts, the loads and the dampers (the springs' is potential energy).
  double power(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot);

 private:
  // Every driver's value in state_ at q.
  void set_coordinates(const Eigen::VectorXd& q);
  // f(effort, its driver's row of the constraint Jacobian at q) for each coordinate whose effort
  // at t is not zero; the Jacobian evaluated once, and only when one is.
  template <class F>
  void for_each_effort(double t, const Eigen::VectorXd& q, F&& f);

  const Mechanism& m_;
  NewtonSolver solver_;
  Kinetostatics kinetostatics_;
  KinematicState state_;
  Eigen::MatrixXd jacobian_;
  Eigen::VectorXd generalised_;
  std::vector<BodyLoad> out_;
  bool any_ = false;
};

// The energy a reference run moves (Trajectory::energy_scale of its states): the largest of the
// peak kinetic energy and the range of the potential energy over its usable samples [J].
double reference_energy_scale(const Mechanism& m, const Trajectory& reference);

// Driver d's generalised inertia (Mechanism::drivers order), the diagonal of the inertia along
// the drivers: 2 T with driver d at unit rate and the others held (T the kinetic energy,
// Link::mass), its largest over the reference's usable samples; what the driver moves, in kg m^2
// for an angle or kg for a slider.
double driver_inertia(const Mechanism& m, const Trajectory& reference, int d);

// Mass of a body an engine needs that the mechanism does not have (a pin-in-slot's sliding
// block): 1e-6 of the lightest link, so its d'Alembert force m a is below 1e-6 of the forces
// of the links around it (docs/engines.md).
double auxiliary_mass(const Mechanism& m);

// A link's mass properties in an engine's scene: the definition's, except that an engine needs a
// positive mass and inertia, so a massless link (a pendulum's rod, a massless crank) gets
// auxiliary_mass() and a point mass (a piston) the inertia of auxiliary_mass() at a tenth of the
// mechanism's size: negligible against the forces around them in the same way.
MassProperties scene_mass(const Mechanism& m, int link);

// The forces one engine read at one pose, in the mechanism's terms.
struct ForceReading {
  // The drivers' efforts, torque [N m] or force [N]: `effort` the first's, `other_efforts` the
  // rest in Mechanism::drivers order (as KinematicState holds their states).
  double effort = 0.0;
  std::vector<double> other_efforts;
  std::vector<Eigen::Vector2d> joint_force;  // per joint: force of its first link on its second
  std::vector<double> couple;                // per joint: prismatic couple on the slider about
                                             // its point [N m]; 0 otherwise
  // Per joint: a gear pair's or rack's coupling as the couple it puts on the gearing's first
  // moving gear [N m] (write_forces moves it onto the teeth: pass_tooth_force); 0 otherwise. An
  // engine's coupling acts as couples, as the exact method's row does, so the joints' forces read
  // beside it are those the exact method has before its own tooth force is passed on.
  std::vector<double> gear_couple;
  // Per joint: its friction on its second link, a pin's moment [N m] or a slide's force along
  // its line [N] (which joint_force also holds, as the exact method's); 0 without friction.
  std::vector<double> friction;
  explicit ForceReading(size_t joints = 0, size_t drivers = 1)
      : other_efforts(drivers > 1 ? drivers - 1 : 0, 0.0),
        joint_force(joints, Eigen::Vector2d::Zero()),
        couple(joints, 0.0),
        gear_couple(joints, 0.0),
        friction(joints, 0.0) {}
  // Driver d's effort (Mechanism::drivers order).
  double& effort_of(int d) { return d == 0 ? effort : other_efforts[static_cast<size_t>(d - 1)]; }
  double effort_of(int d) const {
    return d == 0 ? effort : other_efforts[static_cast<size_t>(d - 1)];
  }
  void set_zero();
  void add(double weight, const ForceReading& other);  // this += weight * other
};

// Writes effort, fx, fy, fn, moment and shaking of row `row` from a reading at `state`
// (positions, velocities, driver value of the sample): the normal force along the line's left
// normal, and the shaking force and moment as the sum of what the ground's joints, the driver
// and the springs anchored on the ground exert on it.
void write_forces(const Mechanism& m, const KinematicState& state, const ForceReading& reading,
                  Trajectory& out, int row);

// The reference's forces at sample `row` as a reading (zero where it has none).
ForceReading reference_reading(const Mechanism& m, const Trajectory& reference, int row);

// Every gearing's paths (gear_paths), and a reading's gear couples moved onto the teeth at `state`
// (pass_tooth_force): the reactions of the gears' bearings and racks' slides an exact method gives.
std::vector<GearPaths> gearings_of(const Mechanism& m);
void move_tooth_forces(const Mechanism& m, const std::vector<GearPaths>& gearings,
                       const KinematicState& state, ForceReading& reading);

// The reference's forces at time t near its first usable sample `first`, and their rate [per s]
// between it and the next: where an engine whose joint friction follows the reactions of its
// steps before starts from.
struct ReadingTrend {
  ForceReading at, rate;
};
ReadingTrend reference_trend(const Mechanism& m, const Trajectory& reference, int first, double t);

// Joint friction in an engine that bounds it per step (docs/engines.md, "Joint friction"): the
// load each step's limit is taken from, the reactions of the steps before: the last step's (one
// step late: an error first order in the step), or extrapolated linearly from the last two
// (second order). Until `transients` steps have passed (an engine's first readings are transients
// of its start) the start's trend stands for them.
class FrictionLoads {
 public:
  FrictionLoads(const Mechanism& m, ReadingTrend start, bool extrapolated, int transients);
  // The load for the next step, of h.
  const ForceReading& next(double h);
  // Whether the step about to end is read (the reading then goes to record).
  bool reads() const { return steps_ + 1 > transients_; }
  // Whether record reads the pose: a gearing's couple is moved onto its teeth, which push on the
  // gears' bearings and a rack's slide (pass_tooth_force).
  bool geared() const { return !gearings_.empty(); }
  // The step of h ended with `reading` (null when reads() was false; with h = 0 the reading
  // replaces the last, at the same instant, and the rate stands), read at pose q (when geared()).
  void record(const ForceReading* reading, double h, const Eigen::VectorXd& q);

 private:
  const Mechanism& m_;
  std::vector<GearPaths> gearings_;     // with joint friction
  std::optional<KinematicState> pose_;  // scratch: the pose a reading was read at
  ForceReading moved_;                  // scratch: a reading with its tooth forces moved
  ForceReading last_, rate_;            // the last reading and its rate [per s]
  ForceReading load_;                   // scratch: the next step's load
  bool extrapolated_;
  int transients_;
  long steps_ = 0;
};

// Joint `joint`'s friction limit under `load` (its reaction) at pose q: the constant part, plus the
// gain times a pin's |R| or a slide's |N| (with a bearing length, max(|N|, 2 |M| / b)); the static
// limit when `held`.
double friction_limit(const Mechanism& m, int joint, const Eigen::VectorXd& q,
                      const ForceReading& load, bool held);

// Whether a step's friction (its force or moment) held its joint under `limit`: inside it, since a
// solver meets its bounds to round-off (within 1e-6 of the limit is at it, sliding).
bool friction_held(double friction, double limit);

// Joint friction an engine bounds per step as the largest force of a row or a motor at rest (ODE,
// Bullet and MuJoCo): before each step, each friction joint's limit (friction_limit) under the
// loads of the steps before (FrictionLoads), the static limit after a step that held the joint;
// after it, whether the step held each joint (friction_held) and the friction's work.
class FrictionBounds {
 public:
  // What a step did at a friction joint: its friction on the joint's second link (a pin's moment
  // [N m], a slide's force along its line [N]) and that link's displacement relative to the
  // first over the step [rad or m].
  struct Step {
    double friction = 0.0, moved = 0.0;
  };
  // For the Mechanism joints `joints`, each with friction, in the engine's own order: the index
  // that bound and settle hand back.
  FrictionBounds(const Mechanism& m, std::vector<int> joints, ReadingTrend start, bool extrapolated,
                 int transients);
  bool any() const { return !joints_.empty(); }
  // Whether the step about to be taken is read (its reactions are the next steps' load).
  bool reads() const { return loaded_ && loads_.reads(); }
  // Whether bound reads its pose: a load-dependent slide's normal is across its guide's line, and
  // a gear's teeth push on its bearing.
  bool reads_pose() const { return slide_loaded_ || (loaded_ && loads_.geared()); }
  // Before a step of h from pose q (read only when reads_pose()): each joint's limit [N m or N],
  // handed to set(i, limit).
  void bound(double h, const Eigen::VectorXd& q, const std::function<void(size_t, double)>& set);
  // After the step of h, with its reading (null unless reads()): what the step did at joint i,
  // from stepped(i). Returns the friction's work over the step [J].
  double settle(double h, const ForceReading* reading, const std::function<Step(size_t)>& stepped);

 private:
  struct Rough {
    int joint = -1;
    double limit = 0.0;
    bool held = false;
  };
  const Mechanism& m_;
  std::vector<Rough> joints_;
  bool loaded_ = false;        // a friction grows with its joint's reaction
  bool slide_loaded_ = false;  // a slide's among them
  FrictionLoads loads_;
  Eigen::VectorXd pose_;  // the pose of the step's start (when the loads are geared)
};

// Forces of pose k come from the step that leaves it (k -> k+1), whose acceleration is the
// second difference over poses k-1, k, k+1; a pose is `clean` when neither neighbour is the
// start (pose 0, exact, without the stepping residual): 2 <= k <= last_step - 1. The weights of
// the clean poses that give a sample at time t (the step on it, or a 3-point quadratic through
// the nearest clean poses, extrapolated at the ends).
struct ForceStencil {
  std::vector<long> steps;
  std::vector<double> weights;
};
ForceStencil force_stencil(double t, long last_step, const std::vector<double>& step_time);

// A sample's reading: the readings of its stencil's poses (by step), weighted, into `out`.
void combine_readings(const ForceStencil& stencil,
                      const std::function<const ForceReading&(long step)>& reading,
                      ForceReading& out);

}  // namespace crosslink::sim

namespace crosslink::sim {

// How far an engine's forces are from the exact ones, over the samples the engine calls usable
// and the reference trusts for forces (analytic/reference/trust.h, `untrusted`): the driver's
// effort (against 1e-3 of the largest reaction, times the size for a torque, where it is zero by
// design), each joint's reaction (vector difference) and the shaking force, each as its worst
// difference over the peak of its exact value; a prismatic couple against its joint's peak force
// times the mechanism's size. Zero when either trajectory has no forces (then `compared` is 0).
struct ForceAgreement {
  double effort = 0.0, reaction = 0.0, couple = 0.0, shaking = 0.0;
  std::string worst_joint;
  int compared = 0;
};
ForceAgreement force_agreement(const Mechanism& m, const Trajectory& exact,
                               const Trajectory& engine);

// How far an engine holds gearing `joint` (a gear pair or a rack) and reads its mesh force, over
// the samples the engine calls usable: the drift, the worst difference of the coupling
// (theta_a - theta_c) + ratio (theta_b - theta_c) [rad], or a rack's s - ratio (theta_a -
// theta_c) [m], from the exact one (which holds it to the solver's tolerance); and the mesh
// force's worst vector difference over its exact peak, at least 1e-3 of the largest exact
// reaction (no forces: none).
struct GearingAgreement {
  double drift = 0.0;
  std::optional<double> mesh;
  int compared = 0;
};
GearingAgreement gearing_agreement(const Mechanism& m, const Trajectory& exact,
                                   const Trajectory& engine, int joint);

}  // namespace crosslink::sim
