// The Mechanism: an immutable planar linkage model, in SI units, loaded once from a definition
// file and shared by every method (analytic solvers, engine scenes, comparator).
//
// Frames and coordinates. Each link has a body frame; its named points are fixed in that frame
// (local coordinates). A moving link's configuration is its pose (x, y, theta): the world
// position of its frame origin [m] and the angle of its x axis from the world x axis [rad, CCW].
// The ground link's frame is the world frame.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/cam.h"
#include "analytic/model/spline.h"

namespace crosslink {

// Where a definition said something: for error messages "file.toml:12:5: error: ...".
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;
  std::string str() const;  // "file:line:column" (or "file" when the line is unknown)
};

// Units the definition file was written in; values inside the Mechanism are SI.
struct Units {
  std::string length_name = "m";   // "mm" | "cm" | "m"
  std::string angle_name = "rad";  // "deg" | "rad"
  std::string mass_name = "kg";    // "kg" | "g"
  std::string force_name = "N";    // "N" | "kN"
  double length = 1.0;             // metres per file length unit
  double angle = 1.0;              // radians per file angle unit
  double mass = 1.0;               // kilograms per file mass unit
  double force = 1.0;              // newtons per file force unit
};

// A link's mass properties: mass, centre of mass in the link frame, moment of inertia about the
// centre of mass (z axis). One model shared by every method (exact solvers and engine scenes).
struct MassProperties {
  double mass = 0.0;                              // [kg]
  Eigen::Vector2d com = Eigen::Vector2d::Zero();  // local [m]
  double inertia = 0.0;                           // about the centre of mass [kg m^2]
  bool assumed = true;  // the default model (default_mass_properties), not given in the file
};

struct Point {
  std::string name;
  Eigen::Vector2d local;  // position in the link frame [m]
  SourceLocation where;
};

// A straight line fixed in a link (a slot or a slider guide): through `origin` along `direction`.
struct Line {
  std::string name;
  Eigen::Vector2d origin;     // local [m]; slider displacement s is measured from here
  Eigen::Vector2d direction;  // local unit vector; s grows along it
  SourceLocation where;
};

struct Link {
  std::string name;
  bool ground = false;
  std::vector<Point> points;
  std::vector<Line> lines;
  // Pose (x [m], y [m], theta [rad]) as drawn at the driver's start value. It picks the assembly
  // mode (branch) the solver assembles on; the solver refines it to exact closure.
  std::optional<Eigen::Vector3d> pose;
  SourceLocation pose_where;  // where `pose` was written (line 0: not written)
  MassProperties mass;        // ground: unused
  SourceLocation where;

  int find_point(std::string_view name) const;  // index in points, or -1
  int find_line(std::string_view name) const;   // index in lines, or -1
};

enum class JointType {
  revolute,       // point `point_a` of link_a coincides with point `point_b` of link_b
  prismatic,      // point `point_b` of link_b (the slider) stays on line `line` of link_a (the
                  // guide), and the two links keep their relative angle
  pin_in_slot,    // point `point_b` of link_b stays on line `line` of link_a; rotation free
  pin_in_arc,     // point `point_b` of link_b stays on a circle of link_a (a curved slot, or a
                  // roller's centre about an eccentric cam): radius `radius_a` about point
                  // `centre_a` of link_a; rotation free
  pin_in_spline,  // point `point_b` of link_b stays on a curved slot of link_a: a natural cubic
                  // spline through points `through` of link_a, a graph y(x) over its chord
                  // (`slot`); rotation free
  cam,            // link_b (the follower) touches the profile cut in link_a (the cam) about its
                  // point `centre_a`: a knife edge or a roller's centre, point `point_b`, stays
                  // on the pitch curve; or a flat face, line `line` of link_b, stays tangent to
                  // the profile (`contour`, docs/cams.md); sliding and rolling free
  // Higher pairs (Kutzbach's j2: one freedom taken), coupling rotations by rolling pitch circles:
  gear,         // gear link_a meshes with gear link_b, both turning about points of `carrier`:
                // (theta_a - theta_c) + ratio (theta_b - theta_c) = phase
  rack_pinion,  // pinion link_a turning about a point of the guide (`carrier`) of prismatic
                // joint `slide`, whose slider link_b is the rack: s - ratio (theta_a - theta_c)
                // = phase, s the slide's travel along its line
};
std::string_view to_string(JointType type);

// Coulomb friction at a revolute or prismatic joint (docs/mechanism-format.md, "Joint
// friction"): on the joint's second link, opposing its motion relative to the first, a moment
// mu r |R| + constant at a revolute (the friction circle: R the pin's reaction, r its radius) or a
// force mu |N| + constant along a prismatic joint's line (N its normal force; with the slider's
// bearing length b, mu max(|N|, 2 |M| / b): a couple M presses the block's two ends on opposite
// sides). Where the joint's relative motion stops, its value is not determined by the motion.
struct JointFriction {
  double coefficient = 0.0;         // Coulomb's mu (sliding)
  double static_coefficient = 0.0;  // what holds a joint at rest (at least `coefficient`)
  double radius = 0.0;              // revolute: the pin's (journal's) radius [m]
  double length = 0.0;              // prismatic: the slider's bearing length [m]; 0: a point
  double constant = 0.0;            // load-independent: a torque [N m] (revolute) or force [N]
  SourceLocation where;
  // The friction circle's radius (revolute) or the coefficient (prismatic); `at_rest`: the
  // static coefficient's, at the limit that holds a joint still.
  double load_gain(bool revolute, bool at_rest = false) const {
    const double mu = at_rest ? static_coefficient : coefficient;
    return revolute ? mu * radius : mu;
  }
  // The load it grows with: a pin's reaction |R| (`force` its magnitude), a slide's normal force
  // |N| (`force`), or with a bearing length b, max(|N|, 2 |M| / b) for the couple M.
  double load(bool revolute, double force, double moment = 0.0) const {
    if (revolute || length <= 0.0) return std::abs(force);
    return std::max(std::abs(force), 2.0 * std::abs(moment) / length);
  }
  // Its largest magnitude under that load.
  double limit(bool revolute, double load, bool at_rest = false) const {
    return constant + load_gain(revolute, at_rest) * load;
  }
  bool load_dependent() const { return coefficient > 0.0 || static_coefficient > 0.0; }
};

struct Joint {
  std::string name;
  JointType type = JointType::revolute;
  int link_a = -1;   // revolute: first link; slides and pin_in_arc: the guide (its line or arc)
  int link_b = -1;   // revolute: second link; slides and pin_in_arc: the slider / pin link
  int point_a = -1;  // revolute only: point index on link_a
  int point_b = -1;  // point index on link_b
  int line = -1;     // prismatic, pin_in_slot: line index on link_a (cam: the face, on link_b)
  double relative_angle = 0.0;  // prismatic: theta_b - theta_a, held constant [rad]
  // Gear pairs (gear, rack_pinion). The ratio is signed: a gear pair's + r_b / r_a when external
  // (the gears turn opposite ways relative to the carrier), - r_b / r_a when internal; a rack's
  // +r or -r [m/rad], the sign by the side of the rack's line the pinion's centre is on.
  int carrier = -1;  // the link both centres are fixed on (ground by default; the guide of a rack)
  int slide = -1;    // rack_pinion: the prismatic joint that carries the rack
  // The centres on the carrier (points of it); rack: centre_a; pin_in_arc: the arc's centre on
  // link_a; cam: the cam's centre on link_a.
  int centre_a = -1, centre_b = -1;
  double ratio = 0.0;
  double phase = 0.0;                     // [rad] for a gear pair, [m] for a rack
  double radius_a = 0.0, radius_b = 0.0;  // pitch radii [m] (a rack's: radius_a); the arc's
  double pressure_angle = 0.0;            // of the teeth: the line of action's tilt [rad]
  std::optional<JointFriction> friction;  // revolute and prismatic joints only
  // cam: the profile cut in link_a, in link_a's frame about point centre_a (its own frame's
  // axes are link_a's); `line`, for a flat face, is link_b's.
  std::shared_ptr<const cam::Contour> contour;
  // pin_in_spline: the slot's points on link_a, first to last; its chord, from the first point
  // (`chord_start`, link_a's frame) along the unit `chord_axis` towards the last; and its
  // centreline y(x), x along the chord, y to its left (docs/cams.md, "Spline slots").
  std::vector<int> through;
  Eigen::Vector2d chord_start = Eigen::Vector2d::Zero(), chord_axis = Eigen::Vector2d::UnitX();
  std::shared_ptr<const NaturalSpline> slot;
  // cam: a groove holds the follower on both sides (form closure); else the contact only pushes
  // and a spring or gravity keeps the follower on the cam (force closure), which it leaves where
  // the motion would need a pull (PoseStatus::contact_lost).
  bool form_closed = false;
  SourceLocation where;

  bool is_slide() const { return type == JointType::prismatic || type == JointType::pin_in_slot; }
  bool is_gearing() const { return type == JointType::gear || type == JointType::rack_pinion; }
  // Freedoms it allows between its two links (a higher pair allows 2: Kutzbach's j2).
  int dof() const {
    return type == JointType::pin_in_slot || type == JointType::pin_in_arc ||
                   type == JointType::pin_in_spline || type == JointType::cam || is_gearing()
               ? 2
               : 1;
  }
};

// A unit as the definition wrote it, to show a value back in it: file value = SI value / si.
struct FileUnit {
  std::string name = "rad/s";  // "rpm", "deg/s", "mm/s", ...
  double si = 1.0;             // SI value of one of it
};

// The motion law of the driver coordinate q_d(t), in SI (rad or m, and seconds).
struct MotionLaw {
  enum class Kind { constant_speed, constant_acceleration, polynomial, table };
  Kind kind = Kind::constant_speed;
  // constant_speed: dq/dt [rad/s or m/s], sign = direction (0: a single pose at rest, a position
  // problem: no sweep); constant_acceleration: dq/dt at t = 0
  double speed = 0.0;
  FileUnit speed_unit;        // the unit the definition gave the speed in
  double acceleration = 0.0;  // constant_acceleration: d2q/dt2 [rad/s^2 or m/s^2]
  FileUnit acceleration_unit{"rad/s^2", 1.0};
  std::vector<double> coefficients;  // polynomial: q = start + c1 t + c2 t^2 + ... (c1 first)
  std::vector<double> table_time;    // table: knots [s], strictly increasing
  std::vector<double> table_value;   // table: q at the knots (natural cubic spline between)
  double duration = 0.0;             // the laws in time (all but constant_speed): the cycle [s]
  SourceLocation where;              // the law's key: speed, acceleration, polynomial or table
};
// The key that states the law in a definition: "speed", "acceleration", "polynomial", "table".
std::string_view to_string(MotionLaw::Kind kind);

// The driver's value and its first three time derivatives at one instant.
struct DriverState {
  double time = 0.0;   // [s]
  double value = 0.0;  // [rad] or [m]
  double rate = 0.0;   // [rad/s] or [m/s]
  double accel = 0.0;  // [rad/s^2] or [m/s^2]
  double jerk = 0.0;   // [rad/s^3] or [m/s^3]
};

enum class DriverType {
  joint_angle,  // angle of (joint point -> `to`) on link_b, measured in link_a's frame
  slider,       // displacement s of a prismatic or pin-in-slot joint along its line
  link_angle,   // absolute angle of the direction `from` -> `to` of one link
};
std::string_view to_string(DriverType type);

struct Driver {
  // A [[driver]]'s name (its channels: angle.<name> or s.<name>, torque.<name> or force.<name>);
  // empty for the one-driver form [driver], whose channels keep the names torque.driver and
  // force.driver.
  std::string name;
  DriverType type = DriverType::joint_angle;
  int joint = -1;  // joint_angle, slider
  int link = -1;   // link_angle: the link; joint_angle: link_b of the joint
  int from = -1;   // point indices on `link` defining the measured direction
  int to = -1;
  double start = 0.0;  // driver value at t = 0 (the drawn position) [rad or m]
  MotionLaw law;
  std::optional<std::pair<double, double>> range;  // optional sweep range [rad or m]
  SourceLocation where;                            // the [driver] table
  SourceLocation range_where;                      // its 'range', when given

  bool angular() const { return type != DriverType::slider; }
  // A constant speed of 0: a position problem, one pose at rest, with no cycle to sweep.
  bool at_rest() const { return law.kind == MotionLaw::Kind::constant_speed && law.speed == 0.0; }
  DriverState at_time(double t) const;  // from the motion law
  // The time its law takes over one cycle [s]: a law in time's duration; at constant speed, a
  // duration if given, else one turn of an angular driver or its range's length of a slider's
  // (0: it has none, at rest or a slider without a range).
  double cycle() const;
};

// The default mass model of a link whose definition gives no `mass`: a uniform slender bar
// between its two farthest points (at least 5 % of the mechanism's size long), 1 kg per
// mechanism size of length, 10:1 slender: mass = l / size, centre of mass at the bar's middle,
// inertia m (l^2 + w^2) / 12 with w = l / 10. Masses are then of order one in any unit system.
MassProperties default_mass_properties(const Link& link, double size);

// An applied load, constant or tabulated over the driver coordinate (linear between rows; an
// angular driver's value is taken modulo one turn from the first row; past the ends, the end
// rows hold).
struct Load {
  enum class Kind { force, torque };
  Kind kind = Kind::force;
  std::string name;
  int link = -1;
  Eigen::Vector2d local = Eigen::Vector2d::Zero();  // force: point of application, link frame [m]
  std::string point;                                // force: the named point, if one was named
  // Constant: one row; table: rows (driver [rad or m], fx [N], fy [N]) or (driver, torque [N m],
  // 0). World axes; torque counter-clockwise.
  std::vector<Eigen::Vector3d> rows;
  bool table = false;
  bool over_turns = false;  // a table over an angular driver's value: read modulo one turn
  SourceLocation where;

  Eigen::Vector2d force_at(double driver) const;  // force, or (torque, 0)
};

// A linear spring and damper between a point of one link and a point of another:
// force = stiffness (length - free_length) + damping d(length)/dt, pulling the points together
// when positive.
struct Spring {
  std::string name;
  int link_a = -1, link_b = -1;
  Eigen::Vector2d local_a = Eigen::Vector2d::Zero(), local_b = Eigen::Vector2d::Zero();  // [m]
  std::string point_a, point_b;
  double stiffness = 0.0;    // [N/m]
  double free_length = 0.0;  // [m]
  double damping = 0.0;      // [N s/m]
  SourceLocation where;
};

// One free coordinate of a forward-dynamics case (one driver's): its initial rate and the effort
// applied along it.
struct FreeCoordinate {
  double rate = 0.0;  // the coordinate's initial rate [rad/s or m/s]
  // The effort applied along the coordinate (torque [N m] on the driven link, or force [N] along
  // a slider), as (time [s], value) rows, linear between rows and held beyond; none: free motion.
  std::vector<std::pair<double, double>> effort;

  double effort_at(double t) const;
};

// A forward-dynamics case ([dynamics]): each driver names an independent coordinate, which then
// moves under gravity, loads, springs and an applied effort from its start value and initial rate
// instead of following a motion law. The first driver's coordinate is the case itself (rate,
// effort: every place that assumes one free coordinate reads them by these names), the other
// drivers' are `others`, in Mechanism::drivers order (docs/mechanism-format.md, "[dynamics]").
struct DynamicsCase : FreeCoordinate {
  double duration = 0.0;  // [s]
  double interval = 0.0;  // between output samples [s]
  std::vector<FreeCoordinate> others;
  SourceLocation where;
  SourceLocation duration_where;  // its 'duration'

  int coordinate_count() const { return 1 + static_cast<int>(others.size()); }
  const FreeCoordinate& coordinate(int d) const {
    return d == 0 ? *this : others[static_cast<size_t>(d - 1)];
  }
};

// A published value to compare against (a hand calculation, Working Model, ...), in SI.
struct Reference {
  bool within_rounding(double exact) const { return std::abs(exact - value) <= 0.5 * precision; }
  std::string quantity;  // a channel name, e.g. "omega.coupler", "vy.G" (see trajectory.h)
  double driver_value;   // [rad or m]
  double value;          // SI: m, rad, m/s, rad/s, m/s^2, rad/s^2
  std::string printed;   // the value as written in the file (file units), e.g. "-12.00"
  // The unit of the printed value's last digit (SI): `precision` in the file, or from how the
  // value is written ("-12.00": 0.01). A value within half of it of the exact one is within
  // rounding.
  double precision = 0.0;
  std::string source;  // where the value was printed
  // A [[derived]] quantity's value ("Q", or one of its fields "S.at_max") instead of a channel at
  // a driver value: `quantity` names it and driver_value is not used.
  bool derived = false;
  // Its own verdict in `crosslink compare` ('tolerance' in the file): it holds within
  // tolerance_pct % of the exact value, or within its printed rounding; neither given: shown
  // beside the exact value, not judged.
  std::optional<double> tolerance_pct;
  bool to_rounding = false;
  bool judged() const { return tolerance_pct.has_value() || to_rounding; }
  SourceLocation where;
};

// A quantity a designer reads off a sweep ([[derived]], docs/mechanism-format.md), computed by
// analytic/derived/derived.h: exactly on the exact solution, or from any method's samples.
struct DerivedSpec {
  enum class Kind {
    extremes,      // max and min of a channel over the interval, with the driver values there
    stroke,        // max - min of a channel between its two reversals, and its end positions
    time_ratio,    // slow stroke's time over the fast one's (constant speed, a full cycle)
    dead_points,   // the driver values where a channel reverses (its link or slider turns back)
    toggles,       // the driver values of the sweep's toggles (limits of the assembling range)
    transmission,  // a four-bar's transmission angle mu.<C>: its extremes
    straightness,  // a point's path: its deviation from the minimum-zone line, and its extent
    circularity,   // a point's path: its deviation from the minimum-zone circle, its radius, centre
    jump_speed,    // a force-closed cam's: the least driver speed at which its follower leaves it
    least_radius,  // a cam's: the least radius of curvature of its profile where the follower
                   // touches it (convex), and the driver value there
  };
  std::string name;
  Kind kind = Kind::extremes;
  std::string channel;  // the channel it reads (straightness: none; transmission: mu.<C>)
  std::string point;    // straightness, circularity: the point whose path it reads
  std::string cam;      // jump_speed, least_radius: the cam joint
  std::optional<std::pair<double, double>> range;  // a driver interval [rad or m]; none: the sweep
  // Of the design summary (docs/mechanism-format.md, "Design summary"): added by the loader for
  // every one-driver definition without being declared, not written in the file.
  bool summary = false;
  SourceLocation where;
};
std::string_view to_string(DerivedSpec::Kind kind);

// Verdict tolerances in % of the reference's peak over the cycle, per quantity class.
// Absent entries fall back to the comparator's defaults.
struct ToleranceOverrides {
  std::optional<double> position, angle, velocity, acceleration, force, torque;
};

// Expected singular behaviour written in a definition's optional [expect] table (SI), derived
// by hand in closed form; the stability catalogue's tests check the sweep against it, and
// `crosslink check` judges each (analytic/derived/claims.h) to `tolerance`.
struct Expectations {
  std::optional<std::pair<double, double>> limits;  // the driver's assembling range
  std::vector<double> toggles;                      // driver values of toggles (dead points)
  std::vector<double> change_points;                // driver values of change points
  std::string grashof;  // four-bars: "Grashof" | "change point" | "non-Grashof"; "" = not given
  // Where each key's value is written (limits, toggles, change_points, grashof).
  SourceLocation limits_at, toggles_at, change_points_at, grashof_at;
  // In percent of the claimed value (analytic/derived/claims.h; kClaimTolerancePct when not given).
  std::optional<double> tolerance_pct;
  // [expect.derived]: a [[derived]] quantity ("Q") or field ("S.at_max") and its value (SI).
  struct Derived {
    std::string quantity;
    double value = 0.0;
    SourceLocation where;
  };
  std::vector<Derived> derived;
  SourceLocation where;
};

// An assembly mode named in the definition ([[branch]]): at the driver's start value, the
// triangle of three named points turns counter-clockwise or clockwise (in a four-bar A B C D,
// B -> C -> D names the circuit: it turns one way all along it). analytic/kinematics/branch.h finds
// the assembly that has it.
struct BranchChoice {
  std::vector<std::string> names;           // the three points
  std::vector<std::pair<int, int>> points;  // each as (link, point index)
  bool counter_clockwise = true;
  SourceLocation where;
  std::string text() const;  // "B -> C -> D turns counter-clockwise"
};

// What a sweep runs over, chosen once from the drivers (docs/mechanism-format.md, "Several
// drivers"): one driver's value, followed over its range, law and cycle; or time, each driver at
// its law's value at t over Mechanism::cycle_period(). Samples, events, singular positions and
// `--at` are placed along it.
struct SweepAxis {
  int driver = -1;  // the driver whose value is the axis (Mechanism::drivers); -1: time
  bool timed() const { return driver < 0; }
};

struct Mechanism {
  std::string name;
  std::string description;
  std::string citation;  // where the dimensions come from
  std::string file;      // the definition file it was loaded from
  Units units;
  std::vector<Link> links;  // exactly one has ground = true
  std::vector<Joint> joints;
  // The drivers, each one row of the constraints (analytic/model/constraints.h) and one effort: one
  // [driver] table or several [[driver]] tables. A Mechanism starts with one.
  std::vector<Driver> drivers = std::vector<Driver>(1);
  // What a sweep runs over: the one driver's value, or time with several (the one place the
  // regime is chosen; see SweepAxis).
  SweepAxis axis() const { return {drivers.size() == 1 ? 0 : -1}; }
  // The driver whose value the sweep runs over: its range, law, cycle and start are the sweep's.
  // Only for an axis that is not timed (std::logic_error otherwise).
  const Driver& swept() const;
  // Every driver at rest (a constant speed of 0): one pose, a position problem, no sweep.
  bool at_rest() const {
    return std::ranges::all_of(drivers, [](const Driver& d) { return d.at_rest(); });
  }
  Eigen::Vector2d gravity = Eigen::Vector2d::Zero();  // [m/s^2]; zero: none
  std::vector<Load> loads;
  std::vector<Spring> springs;
  std::vector<Reference> references;
  std::vector<DerivedSpec> derived;  // [[derived]]
  ToleranceOverrides tolerances;
  std::optional<Expectations> expect;  // [expect], when the definition has one
  std::vector<BranchChoice> branches;  // [[branch]]: the assembly at the start, by name
  // [dynamics], when the definition is a forward-dynamics case. Kinematic commands then drive the
  // coordinate at its initial rate (1 unit/s when that is 0).
  std::optional<DynamicsCase> dynamics;

  int ground() const;                          // index of the ground link
  int find_link(std::string_view name) const;  // index, or -1
  // Whether the file draws the assembly: a link's `pose` is written (apply_branches may add
  // poses that are not).
  bool drawn() const;
  int find_joint(std::string_view name) const;
  // Moving links are numbered 0..n-1 in link order; -1 for ground. Coordinates of moving link k
  // are q[3k .. 3k+2] = (x, y, theta).
  int moving_index(int link) const;
  int moving_count() const { return static_cast<int>(links.size()) - 1; }
  int coordinate_count() const { return 3 * moving_count(); }
  // Size of the mechanism [m]: the largest distance between two points drawn at their posed
  // positions, over the links drawn in place (reached from the ground through links whose drawn
  // points come within the linkage's span of each other; the span is the sum of the links' own
  // extents, each link's largest distance between two of its points or lines' origins), at
  // least the longest link's extent and at most the span: a link drawn far from where it
  // assembles does not make it. Scales position tolerances, default masses, engine scales.
  double size() const;
  // Slide joints in joint order: the mechanism's "sliders" (s, sdot, sddot outputs).
  std::vector<int> slide_joints() const;
  // Joints with friction, in joint order (their friction_moment or friction_force channels).
  std::vector<int> friction_joints() const;
  bool has_friction() const {
    return std::any_of(joints.begin(), joints.end(), [](const auto& j) { return j.friction; });
  }
  bool has_cam() const {
    return std::any_of(joints.begin(), joints.end(),
                       [](const auto& j) { return j.type == JointType::cam; });
  }
  // Distinct point names in first-appearance order, and the (link, point) each is read from.
  struct NamedPoint {
    std::string name;
    int link;
    int point;
  };
  std::vector<NamedPoint> named_points() const;
  // Length of one cycle of the driver: 2 pi for an angular driver at constant speed. Several
  // drivers: the longest of their cycles (Driver::cycle()).
  double cycle_period() const;  // [s]
};

// A gear pair's or a rack and pinion's pitch point in its carrier's frame: where the pitch
// circles (or the pinion's circle and the rack's pitch line) touch. It is the two gears'
// relative instantaneous centre, and the tooth force acts there.
Eigen::Vector2d pitch_point(const Mechanism& m, const Joint& gear);

// Grübler–Kutzbach count: M = 3 (n - 1) - 2 j1 - j2.
struct Mobility {
  int links = 0;        // n, ground included
  int full_joints = 0;  // j1: revolute and prismatic
  int half_joints = 0;  // j2: pin-in-slot, gear pairs, racks and pinions
  int mobility = 0;
  std::string explain() const;  // "M = 3(6-1) - 2*7 - 0 = 1"
};
Mobility mobility(const Mechanism& mechanism);

// One problem in a definition, pointing at where it was written.
struct Diagnostic {
  SourceLocation where;
  std::string message;
  std::string str() const;  // "file:line:col: error: message"
};

// Thrown by the loader for bad input: every problem found, each with its location.
class DefinitionError : public std::runtime_error {
 public:
  explicit DefinitionError(std::vector<Diagnostic> diagnostics);
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  std::vector<Diagnostic> diagnostics_;
};

}  // namespace crosslink
