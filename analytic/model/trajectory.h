// Trajectory: the kinematic state of a mechanism at a sequence of driver values, as produced by
// every method (exact solvers and engines alike), so the comparator can treat them the same.
//
// Storage is column-major by channel: each matrix has one row per sample and one column per
// link, named point or slider, in the order of the name lists. All values SI.
//
// Channel names (used by the comparator, [[reference]] entries and reports):
//   angle.<link> omega.<link> alpha.<link>                      [rad, rad/s, rad/s^2]
//   x.<point> y.<point> vx.<point> vy.<point> v.<point>         [m, m/s]  (v = |velocity|)
//   ax.<point> ay.<point> a.<point>                             [m/s^2]   (a = |acceleration|)
//   s.<slider> sdot.<slider> sddot.<slider>                     [m, m/s, m/s^2]
// From any method's positions: a four-bar's transmission angle and each cam's pressure angle
//   mu.<C> phi.<cam>                                            [rad]
// From the exact kinematics (has_jerk): each cam's follower's jerk along its motion, a
// translating follower's along its guide, an arm's about its pivot
//   jerk.<cam> | angular_jerk.<cam>                             [m/s^3 | rad/s^3]
// Several drivers (each named, [[driver]]): each driver's value, named as its kind of coordinate
//   angle.<driver> (angular) | s.<driver> (slider)              [rad | m]
// Link angles are continuous (unwrapped) along a sweep. With forces (kinetostatics, has_forces):
//   torque.driver (angular driver) | force.driver (slider)     [N m | N]  the driver's effort on
//                                                               its driven link (CCW; along +s);
//                                                               several drivers: torque.<driver>
//                                                               | force.<driver>, one each
//   fx.<joint> fy.<joint> f.<joint>                            [N]  force of the joint's first
//                                                               link on its second, world axes
//   fn.<slider> moment.<slider>                                [N, N m]  a slide joint's force
//                                                               normal to its line (along the
//                                                               line's left normal) and couple on
//                                                               the slider (pin_in_slot: 0)
//   friction_moment.<joint> | friction_force.<joint>           [N m | N]  a friction joint's
//                                                               (revolute | slide) friction on
//                                                               its second link, CCW | along
//                                                               the line (a slide's fx, fy hold
//                                                               it too)
//   shaking_fx.<ground> shaking_fy.<ground> shaking_moment.<ground>  [N, N m]  force and moment
//                                                               (about the world origin) the
//                                                               moving links exert on the ground
// With the energy balance (forward dynamics, has_energy):
//   energy.kinetic energy.potential                            [J]  kinetic energy; potential
//                                                               energy of gravity and springs
//   energy.work                                                [J]  work done on the mechanism
//                                                               since the first sample by the
//                                                               applied effort, loads and dampers
//   energy.error                                               [J]  kinetic + potential - work -
//                                                               (kinetic + potential at the first
//                                                               sample): zero for exact motion
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/model/constraints.h"
#include "analytic/model/mechanism.h"

namespace crosslink {

// Outcome of solving one pose (or of an engine sample).
enum class PoseStatus : std::uint8_t {
  ok,
  singular,                // Jacobian (near) singular: dead point, toggle or change point
  no_convergence,          // Newton did not converge in its iteration budget
  cannot_assemble,         // the chain cannot close at this driver value
  branch_jump,             // the solution left the branch being followed
  loop_gap,                // engine: a cut joint opened beyond the gap threshold
  diverged,                // engine: NaN or runaway state
  not_finite,              // a value is not a finite number (an overflow, or 0/0, on extreme input)
  not_reached,             // a simulation stopped (its event says why) before this sample's time
  exact_methods_disagree,  // the reference's two exact methods disagree here (trust.h)
  // Joint friction (analytic/physics/kinetostatics.h): the pose is right, its forces are not
  // determined by the motion.
  friction_indeterminate,  // a friction joint has no relative motion: friction in its cone
  self_locking,            // the friction gain is 1 or more: friction can hold the mechanism
  // A force-closed cam's follower leaves the profile: holding it there would take a pull, so the
  // follower is in flight and the pose solved is not its motion.
  contact_lost,
};
std::string_view to_string(PoseStatus status);
inline bool usable(PoseStatus s) {
  return s == PoseStatus::ok;
}
// What a sample holds: a solved pose (ok; or singular, friction_indeterminate, self_locking:
// its position is right, its rates and forces are not given), or nothing. A value that does not
// exist is written null (JSON), left empty (CSV, tables) or drawn as a gap (charts), never as a
// number.
inline bool has_position(PoseStatus s) {
  return s == PoseStatus::ok || s == PoseStatus::singular ||
         s == PoseStatus::friction_indeterminate || s == PoseStatus::self_locking;
}

// A singular position of a mechanism with several drivers (Gosselin & Angeles 1990;
// analytic/kinematics/driver_chains.h): direct, the drivers no longer determine the output (it
// gains a freedom); inverse, a driver's chain at a toggle (the output loses a direction).
enum class ParallelSingularity : std::uint8_t { none, direct, inverse };
std::string_view to_string(ParallelSingularity kind);

enum class Quantity { position, angle, velocity, acceleration, jerk, force, torque, energy };
std::string_view to_string(Quantity q);
// Whether a sample with status `s` has a value of quantity `q` (see has_position).
inline bool value_exists(PoseStatus s, Quantity q) {
  return q == Quantity::position || q == Quantity::angle ? has_position(s) : usable(s);
}

struct Trajectory {
  std::string method;                     // "newton", "dyads", "mujoco", ...
  std::vector<std::string> link_names;    // moving links, in Mechanism order
  std::vector<std::string> point_names;   // Mechanism::named_points() order
  std::vector<std::string> slider_names;  // Mechanism::slide_joints() order
  std::vector<std::string> joint_names;   // Mechanism::joints order
  std::string ground_name;
  SweepAxis axis;  // the mechanism's (Mechanism::axis()): a driver's value, or time
  // Every driver's name and whether it is a slider, in Mechanism::drivers order. In a sweep in
  // time each names its channels (angle.<name> or s.<name>, torque.<name> or force.<name>); the
  // one driver's channels keep their names (torque.driver or force.driver).
  std::vector<std::string> driver_names;
  std::vector<char> driver_sliders;
  // The one driver's effort is a force (else a torque): its channel force.driver or torque.driver.
  bool swept_slider() const { return driver_sliders[static_cast<size_t>(axis.driver)] != 0; }

  Eigen::VectorXd time;  // [s]
  // Every driver's value, one column per driver (Mechanism::drivers order) [rad or m].
  Eigen::MatrixXd driver_values;
  // The swept driver's value at sample `row` [rad or m]; a sweep in time has none
  // (std::logic_error).
  double swept(int row) const {
    if (axis.timed()) throw std::logic_error("a sweep in time has no swept driver");
    return driver_values(row, axis.driver);
  }
  // The sweep's parameter at sample `row`: the swept driver's value [rad or m], or the time [s].
  double along(int row) const { return axis.timed() ? time(row) : swept(row); }
  // A sample's `driver` field and column (docs/json.md): the swept driver's value, and in a sweep
  // in time the first driver's (every driver's is in `drivers` and in its channels).
  double driver_field(int row) const { return driver_values(row, axis.timed() ? 0 : axis.driver); }
  Eigen::MatrixXd angle, omega, alpha;
  Eigen::MatrixXd x, y, vx, vy, ax, ay;
  Eigen::MatrixXd s, sdot, sddot;
  std::vector<PoseStatus> status;  // per sample
  // Engines: the samples outside the run (sim::StatusJudge::outside), which keep the reference's
  // flag (a singular one says a position exists) but hold no value of the method: its arrays
  // there are placeholders, never to be read. Empty when every sample was run.
  std::vector<char> not_run;
  bool was_run(int row) const { return not_run.empty() || !not_run[static_cast<size_t>(row)]; }
  // Whether sample `row` holds a value of quantity `q`: its status says so and it was run.
  bool has_value(int row, Quantity q) const {
    return was_run(row) && value_exists(status[static_cast<size_t>(row)], q);
  }
  Eigen::VectorXd rcond;     // analytic: reciprocal condition estimate of the Jacobian
  Eigen::VectorXd loop_gap;  // engines: largest cut-joint violation [m]; 0 for analytic
  // Forces, when the method computes them (see the channel list above).
  bool has_forces = false;
  Eigen::MatrixXd effort;      // per driver (Mechanism::drivers): torque [N m] or force [N]
  Eigen::MatrixXd fx, fy;      // per joint [N]
  Eigen::MatrixXd fn, moment;  // per slider [N, N m]
  Eigen::MatrixXd shaking;     // 3 columns: fx, fy [N], moment [N m]
  // Per friction joint (Mechanism::friction_joints order): its name, whether it slides (its
  // channel friction_force, else friction_moment), and its friction [N or N m].
  std::vector<std::string> friction_names;
  std::vector<char> friction_sliding;
  Eigen::MatrixXd friction;
  // A four-bar's pivots B, C, D (analytic/model/fourbar.h), empty otherwise: the channel mu.<C>,
  // the transmission angle at C, from any method's positions.
  std::vector<std::string> transmission;
  // Each cam joint with a pressure angle (CamReading, analytic/model/constraints.h): the channel
  // phi.<joint> from any method's positions, each of its links' frames placed by a named point of
  // the link (its index in point_names, -1 for the ground's frame, and its local coordinates).
  struct CamChannel {
    CamReading reading;
    int cam_point = -1, follower_point = -1;
    Eigen::Vector2d cam_local = Eigen::Vector2d::Zero(), follower_local = Eigen::Vector2d::Zero();
    // The cam's and the follower's frames at sample `row` of `t`, from their positions.
    CamReading::Pose at(const Trajectory& t, int row) const;
  };
  std::vector<CamChannel> cams;
  // Each cam channel's follower jerk (CamReading::follower_jerk), one column per cam, when the
  // method solves the third derivatives (the exact kinematics; has_jerk); an engine's state and
  // forward dynamics have none, and no such channel.
  bool has_jerk = false;
  Eigen::MatrixXd jerk;
  void drop_jerk();
  // The energy balance, when the method keeps it (see the channel list above).
  bool has_energy = false;
  Eigen::MatrixXd energy;  // 4 columns: kinetic, potential, work, error [J]
  // Shapes `energy` for every sample (zeros) and sets has_energy.
  void add_energy();
  // The energy a run moves: the largest of the peak kinetic energy, the range of the potential
  // energy and the peak |work| over the usable samples [J]; 0 without energy channels. The scale
  // of the energy channels' % of peak (potential energy and the balance's error have no scale
  // of their own: one depends on where the origin is, the other is zero when exact).
  double energy_scale() const;

  // Named events along the sweep (limits, singular positions, branch changes...).
  struct Event {
    Event(double driver_, PoseStatus kind_, std::string message_,
          ParallelSingularity singularity_ = ParallelSingularity::none, std::string chain_ = {})
        : driver(driver_),
          kind(kind_),
          message(std::move(message_)),
          singularity(singularity_),
          chain(std::move(chain_)) {}
    double driver;  // [rad or m]; several drivers: the time [s]
    PoseStatus kind;
    std::string message;
    // Several drivers: a singular position's kind (analytic/kinematics/driver_chains.h), and for an
    // inverse one the driver whose chain is at a toggle; none otherwise.
    ParallelSingularity singularity;
    std::string chain;
  };
  std::vector<Event> events;
  // Forward dynamics with joint friction: the instants [s] a friction joint's sliding stops (to
  // turn back or to be held) or, held, breaks away, where its acceleration and its friction jump.
  std::vector<double> stops;
  // At rest, held by friction, over each (from, to) [s] (to: the run's end when it stays).
  std::vector<std::pair<double, double>> held;

  // Shapes every array for `samples` rows from the mechanism's name lists (the only allocation;
  // solvers then write rows in place). Force arrays are shaped and has_forces set only
  // `with_forces`.
  void resize(const Mechanism& mechanism, int samples, bool with_forces = false);
  // The same for a run of `reference`'s sweep (an engine's): its samples' times and drivers'
  // values, with an energy balance when `energy`, without jerk.
  void resize_as(const Mechanism& mechanism, const Trajectory& reference, bool with_forces,
                 bool energy = false);
  int samples() const { return static_cast<int>(time.size()); }
  // Whether sample `row` is next to a sample flagged singular. One grid step from a dead point
  // or change point the Jacobian's condition is 10 to 40 times worse than elsewhere, so exact
  // methods agree there only to round-off amplified by it and engines' step errors are
  // dominated by the singularity: comparisons keep such samples out of their verdicts.
  bool beside_singular(int row) const;
  // Whether a friction joint's sliding stops between sample `row`'s neighbours (`stops`; in a
  // sweep, a friction that changes side between them or a neighbour flagged
  // friction_indeterminate): its accelerations and friction take either side of a jump, and a
  // method that differences poses or reads a step's forces there (an engine) smears it over its
  // step.
  bool beside_stop(int row) const;

  // Flags sample `row` not_finite when a value in it is not a finite number while its status says
  // it was solved, and puts finite placeholders (zeros) over every non-finite value of the row
  // whatever its status: no NaN or infinity is ever written. Returns whether it flagged the row.
  bool flag_non_finite(int row);
  // Every sample, and one event at the first flagged sample (unless there is one); returns how
  // many it flagged.
  int flag_non_finite();

  // Every channel name, in a fixed order (links, points, sliders).
  std::vector<std::string> channel_names() const;
  // The column of one channel over all samples, or nullopt for an unknown name.
  std::optional<Eigen::VectorXd> channel(std::string_view name) const;
  // One channel's value at one sample (nullopt for an unknown name or a row out of range).
  std::optional<double> sample(std::string_view name, int row) const;
  static Quantity quantity_of(std::string_view channel);  // by the prefix before '.'
  // An angle or a rate of one (omega, alpha, angular_jerk), whose unit has no length in it.
  static bool angular(std::string_view channel);
  // A channel's unit in the units a definition is written in: its name, and the SI value of one
  // of it (what a value in it is multiplied by to give the SI one).
  struct Unit {
    double si = 1.0;
    std::string name;
  };
  static Unit unit_in(const Units& units, std::string_view channel);
  // The SI unit of a channel's values: "m", "rad", "m/s", "rad/s", "m/s^2", "rad/s^2", "m/s^3",
  // "rad/s^3", "N", "N m" or "J" (JSON and CSV hold SI).
  static std::string si_unit(std::string_view channel) { return unit_in(Units{}, channel).name; }
  // A channel held in one of the matrices above: its column, samples() values in a row, or null
  // for one computed from others (a magnitude v, a or f; mu, phi) or no channel at all.
  const double* stored(std::string_view name) const;

 private:
  // Rows first .. first + count - 1 of one channel: channel's whole column, sample's one value.
  std::optional<Eigen::VectorXd> rows_of(std::string_view name, int first, int count) const;
};

}  // namespace crosslink
