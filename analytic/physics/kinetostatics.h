// Exact kinetostatics along a prescribed motion: the driver's effort (torque or force) and every
// joint's reaction, from the exact position, velocity and acceleration of a pose.
//
// Method 1, Lagrange multipliers. With q the links' frame coordinates (x, y, theta), the
// equations of motion are M qddot + Phi_q^T lambda = Q. Along a prescribed motion qddot is known,
// so one linear solve with the factorisation of J = Phi_q that the position solve left gives
//   J^T lambda = Q - M qddot,
// the right side assembled per link as the generalised force of the applied loads (gravity at
// the centre of mass, forces at points, torques, springs and dampers) plus d'Alembert's inertia
// force -m a_c at the centre of mass and couple -I alpha. Each joint's rows give the generalised
// constraint force on each of its links, -Phi_q^T lambda restricted to them: a force and a
// moment about the link frame's origin, from which the reaction at the joint's point and, for a
// prismatic joint, its couple follow. The driver's row gives its effort, -lambda_driver (the
// driver equation is coordinate - d(t) = 0, so the effort along the coordinate is -lambda).
//
// Method 2, power balance, with no multipliers: the driver's power equals the rate of change of
// kinetic energy plus that of the potential energy of gravity and springs, plus the power
// dissipated in dampers, minus the power of the loads; divided by the driver's rate.
//
// Gear pairs and racks. Their rows couple rotations (and a travel), so the multiplier of such a
// row acts on its links as pure couples, whereas the teeth push at the pitch point: a force whose
// moment about each gear's centre is that couple, plus the separating force of the pressure
// angle, which the centres' pivots carry. Both systems hold the same motion; the reactions of the
// joints between each gear and its carrier (and of a rack's slide) take the difference: a joint
// on the path from a gear to its carrier at its centre passes the tooth force on. The mesh
// force, of the first gear on the second at the pitch point, is the gear pair's joint force.
//
// Joint friction (Mechanism::Joint::friction). Each friction joint's moment or force opposes its
// relative motion with a magnitude f_j = g_j h_j(R_j) + c_j, where h_j is the load its friction
// grows with (a pin's reaction |R|, a slide's max(|N|, 2 |M| / b)), g_j the friction circle mu r
// or the coefficient mu, c_j the load-independent part. The reactions depend on the friction they
// cause: with G_j the generalised force of a unit friction of joint j (its sign from the relative
// rate), J^T lambda = b + sum_j f_j G_j gives lambda = lambda_0 + sum_j f_j Lambda_j, k extra
// solves with J's factors, and every reaction is linear in lambda (a gear's bearing and a rack's
// slide add the separating force of their tooth force, |c| Q in the gearing's couple c, itself
// linear in lambda: a second kink). That leaves k equations in the
// k magnitudes, f_j = g_j h_j(A_j + sum_i f_i B_ji) + c_j, solved by Newton (with a fixed-point
// step where Newton does not reduce the residual) to round-off. The friction gain, the spectral
// radius of the matrix g_j h_j(B_ji) that bounds the map's slopes, bounds it: below 1 the map
// contracts (in a weighted norm) and its solution is unique; at 1 or above the friction may hold
// the mechanism (self-locking) and the forces are not determined by the motion: the sample is
// flagged `self_locking`. A joint whose
// relative motion stops (a rocker's dead point, a pose at rest) has a friction anywhere in its
// cone: the sample is flagged `friction_indeterminate`, never given a sign.
//
// Shaking force and moment: what the mechanism exerts on the ground (through its joints, the
// driver and springs anchored on it) is the applied gravity and loads minus the rate of change of
// the moving links' momentum (linear, and angular about the world origin).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

// A spring's pull T (positive: drawing its points together), its unit vector from b's point to
// a's, its length and the rate of its length. A spring of zero length has no direction and pulls
// nothing.
struct SpringState {
  double pull = 0.0, length = 0.0, rate = 0.0;
  Eigen::Vector2d towards_a = Eigen::Vector2d::Zero();
};
SpringState spring_state(const Mechanism& m, const Spring& spring, const KinematicState& state);

// The generalised force of the definition's loads (forces at points, torques) and springs and
// dampers at a state (positions, velocities, driver value): per moving link (force, moment about
// its frame origin), as `out` sized 3 per moving link. Gravity and inertia are not in it. The
// exact method adds them; the engines apply it to their bodies every step.
void applied_loads(const Mechanism& m, const KinematicState& state, Eigen::VectorXd& out);
// A load's force, or (torque, 0), at the state: a table reads the swept driver's value (the
// loader refuses a table in a sweep in time).
inline Eigen::Vector2d load_value(const Load& load, const KinematicState& state) {
  return load.force_at(load.table ? state.swept().value : 0.0);
}

// The forces at one pose, SI.
struct ForceSample {
  Eigen::VectorXd effort;  // per driver (Mechanism::drivers): its torque [N m] or force [N]
  std::vector<Eigen::Vector2d> joint_force;  // per joint: force of its first link on its second
  std::vector<double> normal, moment;        // per slide joint (Mechanism::slide_joints order)
  // Per friction joint (Mechanism::friction_joints order), on its second link: a revolute's
  // friction moment [N m], a slide's friction force along its line [N].
  std::vector<double> friction;
  Eigen::Vector3d shaking = Eigen::Vector3d::Zero();  // on the ground: fx, fy, moment about O
  Eigen::VectorXd generalised, lambda;                // scratch: Q - M qddot and the multipliers
  // ok, or why the forces are not determined: friction_indeterminate (friction joint `cause`
  // does not move), self_locking (the friction gain `gain` is 1 or more; `cause` the joint whose
  // friction its bound grows most with).
  PoseStatus status = PoseStatus::ok;
  int cause = -1;
  double gain = 0.0;
  double pull = 0.0;  // contact_lost: the contact force along the normal joint `cause` needs, < 0
  Eigen::MatrixXd unit_lambda;  // scratch: Lambda_j per friction joint

  // Whether every value is a number: at a pose whose J is singular in floating point the
  // multipliers are not, and such a sample must be flagged, not passed on.
  bool finite() const;
  // Why the status is not ok, for the sample's event ("" when it is).
  std::string why(const Mechanism& m) const;
};

// A gear pair's or rack's row (and an engine's coupling) acts on its links as couples, whereas
// the teeth push at the pitch point. What a force on a gear at its centre passes through: the
// revolute joints from the gear to its carrier at the centre, each with the sign it adds that
// force to its joint force with.
struct GearPaths {
  int joint = -1;                                      // the gearing (Mechanism joint)
  std::vector<std::pair<int, double>> path_a, path_b;  // path_b: a gear pair's second gear
};
GearPaths gear_paths(const Mechanism& m, int joint);

// The tooth force of gearing `g` at `state` from `couple`, the couple its coupling puts on its
// first moving gear (the first gear unless it is the ground) [N m]: written as the gearing's
// joint force (of the first gear on the second at the pitch point) and passed through the joints
// on the paths to the carrier; for a rack, the slide's force loses the tooth force's normal part
// (also taken from `slide_normal`) and the slide's couple on the rack about its point
// (`slide_moment`) the moment of the tooth force's offset from that point.
void pass_tooth_force(const Mechanism& m, const GearPaths& g, const KinematicState& state,
                      double couple, std::vector<Eigen::Vector2d>& joint_force,
                      double* slide_normal, double* slide_moment);
// Gearing g's tooth force on its first moving gear at `state`, at the pitch point, as a function
// of the couple c its coupling puts on that gear: its tangential part is odd in c, the pressure
// angle's separating part keeps its side whichever way c turns.
struct ToothForce {
  Eigen::Vector2d tangential, separating;  // directions: perp(arm) and the pushing side's arm
  double tan_pressure = 0.0, radius = 1.0;
  Eigen::Vector2d pitch;
  Eigen::Vector2d at(double couple) const {
    const double t = couple / radius;
    return (t * tangential + std::abs(t) * tan_pressure * separating) / radius;
  }
};
ToothForce tooth_force(const Mechanism& m, const GearPaths& g, const KinematicState& state);

// Forward dynamics with several free coordinates: each friction joint's phase (Mechanism::
// friction_joints order), its direction of sliding (+1 or -1) or 0, held at rest relative to its
// first link by `holding` (its friction on the second link; the unknown the motion solves for).
struct FrictionPhase {
  std::vector<int> direction;
  Eigen::VectorXd holding;
};

class Kinetostatics {
 public:
  // A joint's reaction at multipliers `lambda` (linear in them): its rows' force on its second
  // link, and for a slide the normal force and the couple on the slider about its point.
  struct Reaction {
    Eigen::Vector2d on_b = Eigen::Vector2d::Zero();
    double normal = 0.0, moment = 0.0;
  };

  explicit Kinetostatics(const NewtonSolver& solver);

  // Sized for the mechanism; then solve() allocates nothing.
  ForceSample make_sample() const;
  // Method 1 at a pose solved by the solver (solve_position, then solve_velocity and
  // solve_acceleration with the real driver state). With joint friction, out.status says whether
  // the forces are determined (see above); when it is not ok, out's values are not.
  void solve(KinematicState& state, ForceSample& out) const;
  // The same with each friction joint's sign from `moving`'s rates (a state at the same pose),
  // not the state's own: the forward dynamics keeps a phase's direction of sliding across the
  // instant its rate reaches zero (so that the instant can be located on smooth motion), and at
  // rest asks whether the mechanism breaks away along `moving`, with each friction at its static
  // limit (`at_rest`: static_coefficient).
  // With `phase`, each friction joint's sign is its phase's direction instead, and a joint held
  // at rest takes the phase's friction as given.
  void solve(KinematicState& state, ForceSample& out, const KinematicState& moving, bool at_rest,
             const FrictionPhase* phase = nullptr) const;
  // A state at rest, held by friction, under the driver's effort `effort` (forward dynamics: the
  // effort is given, not solved for): with one friction joint, its friction is the one that
  // holds the mechanism, f = (effort - e0) / e1 (e0 the effort that would hold it without
  // friction, e1 the effort per unit of friction), inside its cone since it holds; with more, how
  // the load divides among them is not determined (friction_indeterminate).
  void solve_held(KinematicState& state, ForceSample& out, double effort) const;
  // Method 2, the power balance: the drivers' power, the sum over drivers of effort x rate [W],
  // as the rate of change of the kinetic energy and of the potential energy of gravity and
  // springs, plus the power dissipated in dampers and in joint friction, less the power of the
  // loads. The friction's magnitudes are method 1's (`forces`, required with joint friction).
  double input_power(const KinematicState& state, const ForceSample* forces = nullptr) const;
  // With one driver, its effort: input_power over its rate; none when the driver is at rest
  // (its rate is zero, so power says nothing about the effort) or there are several (the
  // balance gives only the sum of their powers: input_power).
  std::optional<double> power_balance(const KinematicState& state,
                                      const ForceSample* forces = nullptr) const;
  // The power of joint friction at the state, the sum of each friction's moment or force times
  // its joint's relative rate [W] (negative or zero: it dissipates).
  double friction_power(const KinematicState& state, const ForceSample& forces) const;
  // Friction joint f's (Mechanism::friction_joints order) relative rate: a revolute's second
  // link's angular velocity less its first's [rad/s], a slide's slider's velocity along the line
  // relative to the guide's point under it [m/s].
  double relative_rate(const KinematicState& state, int f) const;
  // The relative rate at or below which friction joint f is at rest relative to its first link
  // in `moving`: 1e-9 of the drivers' fastest rate (times the size for a slide).
  double rest_rate(const KinematicState& moving, int f) const;
  // Its rate's time derivative at the state [rad/s^2 or m/s^2].
  double relative_acceleration(const KinematicState& state, int f) const;
  // Friction joint f's limit under the reactions of `forces` [N m or N] (its static one
  // `at_rest`): what a joint held at rest may take before it slides.
  double friction_limit(int f, const ForceSample& forces, bool at_rest) const;

  void write_sample(const ForceSample& sample, Trajectory& out, int row) const;

  // The kinetic energy and the potential energy of gravity and springs at the state [J].
  double kinetic_energy(const KinematicState& state) const;
  double potential_energy(const KinematicState& state) const;
  // d/dt of the kinetic energy at the state, qdot^T M qddot [W].
  double kinetic_energy_rate(const KinematicState& state) const;
  // a^T M b for coordinate rates a and b (3 per moving link) at the state's pose: the kinetic
  // energy's bilinear form (twice the kinetic energy when a = b) [kg m^2 / s^2 per unit rates].
  double inertia_product(const KinematicState& state, const Eigen::VectorXd& a,
                         const Eigen::VectorXd& b) const;
  // The power of the loads less the dampers' dissipation at the state [W].
  double load_power(const KinematicState& state) const;

  // Q - M qddot at the state: per moving link, the generalised applied and inertia forces (force,
  // and moment about the frame origin); Q alone (loads, springs, dampers, gravity) without
  // `inertia`. Forward dynamics builds its equation from it.
  void generalised_forces(const KinematicState& state, Eigen::VectorXd& out,
                          bool inertia = true) const;

 private:
  struct Gearing {
    GearPaths paths;
    int slide = -1;  // a rack's slide, its index in slide_joints_
  };
  // The tooth force at the multipliers, and what it changes in the other joints' reactions.
  void add_tooth_force(const Gearing& g, const KinematicState& state, ForceSample& out) const;
  // The couple gearing g's row puts on its first moving gear per unit of its multiplier, and
  // that row.
  std::pair<double, int> couple_per_multiplier(const Gearing& g, const KinematicState& state) const;
  // What gearing g's tooth force adds to joint `joint`'s reaction (add_tooth_force), per unit of
  // its couple (`odd`) and of the couple's magnitude (`even`); none off its paths and its slide.
  struct ToothShare {
    bool any = false;
    Reaction odd, even;
  };
  ToothShare tooth_share(const Gearing& g, const KinematicState& state, int joint) const;
  Reaction reaction(const KinematicState& state, int joint, const Eigen::VectorXd& lambda) const;
  // The efforts, reactions and shaking force from out.lambda and out.friction.
  void write_forces(KinematicState& state, ForceSample& out) const;
  // Friction joint f (Mechanism::friction_joints order).
  const Joint& friction_joint(size_t f) const {
    return solver_.mechanism().joints[static_cast<size_t>(friction_joints_[f])];
  }
  // The load friction joint f's magnitude grows with: (|R| of a pin, or max(|N|, 2 |M| / b) of a
  // slide), and its derivative along a change `d` of the reaction.
  double friction_load(int f, const Reaction& r) const;
  double friction_load_slope(int f, const Reaction& r, const Reaction& d) const;
  // Adds the generalised force of a unit friction of friction joint f, opposing its rate's sign.
  void add_unit_friction(const KinematicState& state, int f, double sign, Eigen::VectorXd& g) const;
  // The friction magnitudes and the multipliers they give (see above); false with out.status
  // set when they are not determined.
  bool solve_friction(KinematicState& state, ForceSample& out, const KinematicState& moving,
                      bool at_rest, const FrictionPhase* phase) const;

  const NewtonSolver& solver_;
  std::vector<int> slide_joints_;
  std::vector<Gearing> gearings_;
  std::vector<int> friction_joints_;
  std::vector<int> pushing_cams_;  // force-closed cam joints: their contact only pushes
  double size_ = 1.0;              // Mechanism::size(): relative sliding rates against it
};

}  // namespace crosslink
