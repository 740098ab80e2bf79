// The constraint layout: every row of Phi(q, t) = 0, each joint type's and each driver's rows
// defined once. Newton, the sweep's tracer, kinetostatics and the engines' loop-gap checks all
// read this one definition, so a new joint type is one more kind here.
//
// As Simbody gives every constraint the same per-level methods, each block of rows answers the
// same questions: its position error Phi, its rows of the Jacobian J = dPhi/dq, the part of
// d2Phi/dt2 that does not depend on qddot (the acceleration's velocity-squared terms), and which
// of its rows are angle equations. Only a driver's row depends on time, so the right-hand sides
//   velocity      J qdot  = nu      nu: each driver's rate in its row, 0 elsewhere
//   acceleration  J qddot = gamma   gamma = -(velocity-squared terms) + each driver's accel
//   jerk          J q'''  = eta     eta = -(the terms of d3Phi/dt3 without q''') + driver's jerk
// are assembled by the layout from the drivers' states. As Pinocchio keeps one definition per
// joint type visited by every algorithm, one switch on the kind in constraints.cpp is the only
// place a joint type's equations are written.
//
// Rows: the joints in Mechanism::joints order (revolute 2, prismatic 2: its line then its
// relative angle, pin-in-slot 1: its line, pin in an arc 1: its distance from the centre, pin
// in a spline slot 1: its height over the chord less the curve's, gear
// pair and rack 1: the rolling of the pitch circles), then one row per driver in
// Mechanism::drivers order.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/planar.h"

namespace crosslink {

// The links' frames at one q. The rotations come from cos and sin computed once per q (the
// solver's cache, per moving link) or, without a cache, from q on the spot; the numbers are the
// same.
struct LinkFrames {
  const Eigen::VectorXd& q;
  const Eigen::VectorXd* cos = nullptr;  // per moving link, or null
  const Eigen::VectorXd* sin = nullptr;

  BodyMotion of(int k, const Eigen::VectorXd* qdot = nullptr,
                const Eigen::VectorXd* qddot = nullptr) const {
    if (k < 0 || !cos) return BodyMotion::of(k, q, qdot, qddot);
    return BodyMotion::of(k, q, qdot, qddot, (*cos)(k), (*sin)(k));
  }
};

class SparseJacobian;

// One joint's or one driver's rows: [first_row, first_row + rows()) of Phi.
struct ConstraintRows {
  enum class Kind : std::uint8_t {
    revolute,       // r_a + A_a p_a - r_b - A_b p_b = 0                       (2 rows)
    prismatic,      // n_a . (P_b - O_a) = 0, theta_b - theta_a - angle = 0    (2 rows)
    pin_in_slot,    // n_a . (P_b - O_a) = 0                                   (1 row)
    pin_in_arc,     // |P_b - C_a| - radius = 0                                (1 row)
    pin_in_spline,  // n_a . (P_b - O_a) - y(u_a . (P_b - O_a)) = 0            (1 row)
    cam_pitch,      // |P_b - C_a| - rho(angle(P_b - C_a) - theta_a) = 0       (1 row)
    cam_face,       // n_b . (O_b - C_a) - h(theta_b + angle - theta_a) = 0    (1 row)
    angle_driver,   // theta_b + angle - theta_a - d(t) = 0                    (1 row)
    slider_driver,  // u_a . (P_b - O_a) - d(t) = 0                            (1 row)
    gear,           // theta_a - theta_c + ratio (theta_b - theta_c) - phase = 0   (1 row)
    rack_pinion,    // u_a . (P_b - O_a) - ratio (theta_c - theta_a) - phase = 0  (1 row)
  };
  Kind kind = Kind::revolute;
  int first_row = 0;
  int a = -1, b = -1;  // moving index of the first link (the guide) and the second (-1: ground)
  // Gear pairs: the third link: a gear pair's carrier, a rack's pinion (its guide is a).
  int c = -1;
  double ratio = 0.0;  // gear pairs: the signed ratio (Joint::ratio)
  // Local coordinates: revolute, the points that coincide on a and on b; slides, the line's
  // origin on a and the pin on b.
  Eigen::Vector2d point_a = Eigen::Vector2d::Zero(), point_b = Eigen::Vector2d::Zero();
  // Slides: the axis fixed in a that the pin's offset is projected on: the line's normal n for a
  // joint's line row, its direction u for a slider driver.
  Eigen::Vector2d axis = Eigen::Vector2d::Zero();
  // Prismatic: theta_b - theta_a held [rad]; angle driver: the measured arm's angle in b's frame;
  // gear pairs: the phase [rad or m].
  double angle = 0.0;
  double radius = 0.0;  // pin_in_arc: the arc's, about point_a [m]
  // pin_in_spline: the slot's centreline y(x) over its chord, which starts at point_a and runs
  // along `axis` (u_a; n_a is it turned by +90 degrees).
  std::shared_ptr<const NaturalSpline> slot;
  // Cams: the profile about the cam's centre point_a (rho, or h), on a the cam and b the
  // follower: point_b its knife edge or roller's centre, or its face's origin with the face's
  // normal `axis` (away from the cam) at `angle` in b's frame.
  std::shared_ptr<const cam::Contour> contour;

  int rows() const { return kind == Kind::revolute || kind == Kind::prismatic ? 2 : 1; }
  // Whether row `r` of the block (0-based) is an angle equation [rad] rather than a length [m].
  bool angle_row(int r) const {
    return (kind == Kind::prismatic && r == 1) || kind == Kind::angle_driver || kind == Kind::gear;
  }
  // Writes the block's rows of Phi at the frames (a driver's row: its measured value, d(t) not
  // taken off).
  void position(const LinkFrames& frames, Eigen::VectorXd& phi) const;
  // Writes the block's rows of d2Phi/dt2 with qddot = 0: the velocity-squared terms.
  void velocity_squared(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                        Eigen::VectorXd& out) const;
  // Writes the block's rows of d3Phi/dt3 with q''' = 0: 3 Phi_qq[qdot, qddot] + Phi_qqq[qdot^3].
  void jerk_terms(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                  const Eigen::VectorXd& qddot, Eigen::VectorXd& out) const;
  // Writes the block's rows of dPhi/dq into `jac`, whose other entries of those rows are zero.
  // The same entries, in the same order, whatever holds them (dense, or the layout's pattern).
  void jacobian(const LinkFrames& frames, Eigen::MatrixXd& jac) const;
  void jacobian(const LinkFrames& frames, SparseJacobian& jac) const;
  // A one-row block's value: a driver's measured coordinate.
  double value(const LinkFrames& frames) const;
};

// A cam joint's contact at its links' motions (a the cam, b the follower): where the follower
// touches the profile, and the common normal there pointing away from the cam, in world axes.
struct CamContact {
  Eigen::Vector2d point = Eigen::Vector2d::Zero(), normal = Eigen::Vector2d::UnitY();
};
CamContact cam_contact(const Mechanism& m, const Joint& cam, const BodyMotion& a,
                       const BodyMotion& b);
// The same from the joint's rows in a layout (ConstraintLayout::joint), without rebuilding them.
CamContact cam_contact(const ConstraintRows& cam, const BodyMotion& a, const BodyMotion& b);
// A cam joint's profile in its cam link's own frame: where the follower touches it, and the
// normal there, at `count` angles over a turn, in order around it (an engine's mesh of it).
std::vector<CamContact> cam_profile(const Mechanism& m, const Joint& cam, int count);

// A cam joint's pressure angle from its links' poses alone (docs/cams.md, "Pressure angle"): the
// angle from the follower's direction of motion to the common normal, counterclockwise positive,
// within [-90, 90] degrees. The direction is its guide's on the ground (square to the arm about a
// pivot, along a prismatic joint's line) at the knife edge, the roller's centre or the face's
// contact, taken the way the contact pushes: it exists whatever the follower's speed, at a dwell
// too, and equals a textbook's (Norton, ch. 8) on a rise and on a return.
struct CamReading {
  std::string joint;     // the cam joint's name
  ConstraintRows rows;   // its rows (a the cam, b the follower: moving indices, -1 the ground)
  bool pivoted = false;  // the follower turns about a pivot
  Eigen::Vector2d guide = Eigen::Vector2d::Zero();  // the pivot [m], or the line's direction

  // The follower's jerk: an arm's angular, a translating follower's linear (docs/cams.md).
  std::string_view jerk_kind() const { return pivoted ? "angular_jerk" : "jerk"; }
  std::string jerk_channel() const { return std::string(jerk_kind()) + "." + joint; }

  // At the links' poses: the cam's centre and angle, the contact, where the direction of motion
  // is taken and it (a unit vector), and the pressure angle.
  struct Pose {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double cam_angle = 0.0;
    CamContact contact;
    Eigen::Vector2d at = Eigen::Vector2d::Zero(), motion = Eigen::Vector2d::UnitY();
    double pressure_angle = 0.0;
    // The profile's curvature at the contact [1/m]: positive where convex, 0 on a straight
    // stretch (its radius of curvature is 1 / curvature).
    double curvature = 0.0;
  };
  Pose at(const BodyMotion& cam, const BodyMotion& follower) const;
  double pressure_angle(const BodyMotion& cam, const BodyMotion& follower) const {
    return at(cam, follower).pressure_angle;
  }
  // The profile the follower touches, in the cam's frame about its centre (the centre at the
  // origin), at `count` angles over a turn, in order around it.
  std::vector<Eigen::Vector2d> outline(int count) const;
  // The follower's jerk from the coordinates' third derivatives: an arm's angular jerk about its
  // pivot [rad/s^3], or a translating follower's along its guide's line [m/s^3] (the sense its
  // slide s grows in).
  double follower_jerk(const Eigen::VectorXd& qdddot) const;
};
// Every cam joint whose follower has one guide on the ground (a revolute joint, or a prismatic
// joint whose line is the ground's); a follower guided otherwise has no pressure angle here.
std::vector<CamReading> cam_readings(const Mechanism& m);

class ConstraintLayout {
 public:
  explicit ConstraintLayout(const Mechanism& mechanism);

  int rows() const { return rows_; }               // joint rows and driver rows
  int joint_row_count() const { return joints_; }  // the rows before the first driver's
  const ConstraintRows& joint(int j) const { return blocks_[static_cast<size_t>(j)]; }
  const ConstraintRows& driver(int d) const {
    return blocks_[joint_count_ + static_cast<size_t>(d)];
  }
  int driver_count() const { return static_cast<int>(blocks_.size() - joint_count_); }
  int driver_row(int d) const { return driver(d).first_row; }
  const std::vector<ConstraintRows>& blocks() const { return blocks_; }
  // Whether row r is an angle equation (scaled by the mechanism's size to compare it in metres).
  bool angle_row(int r) const { return angle_rows_[static_cast<size_t>(r)] != 0; }

  // Phi at the frames with each driver's row at its measured value (drivers[d].value not taken
  // off): the joints' rows are the loop closure, the drivers' rows their coordinates.
  void position(const LinkFrames& frames, Eigen::VectorXd& phi) const;
  // Phi with driver d's row less drivers[d] (one state per driver).
  void residual(const LinkFrames& frames, std::span<const DriverState> drivers,
                Eigen::VectorXd& phi) const;
  void jacobian(const LinkFrames& frames, Eigen::MatrixXd& jac) const;  // all of dPhi/dq
  void jacobian(const LinkFrames& frames, SparseJacobian& jac) const;   // the same, its pattern
  // nu: each driver's rate in its row, 0 in the joints' rows.
  void velocity_rhs(std::span<const DriverState> drivers, Eigen::VectorXd& nu) const;
  // gamma = -(velocity-squared terms of d2Phi/dt2) + each driver's acceleration in its row.
  void acceleration_rhs(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                        std::span<const DriverState> drivers, Eigen::VectorXd& gamma) const;
  // eta = -(the jerk terms of d3Phi/dt3) + each driver's jerk in its row (docs/cams.md, "Jerk").
  void jerk_rhs(const LinkFrames& frames, const Eigen::VectorXd& qdot, const Eigen::VectorXd& qddot,
                std::span<const DriverState> drivers, Eigen::VectorXd& eta) const;

 private:
  std::vector<ConstraintRows> blocks_;  // the joints', then the drivers'
  size_t joint_count_ = 0;
  int joints_ = 0, rows_ = 0;
  std::vector<char> angle_rows_;  // per row
};

}  // namespace crosslink

namespace crosslink {

// dPhi/dq held as its pattern only: the entries the layout's rows write (3 to 6 a row, whatever
// q is), by column. A chain of b bodies has about 15 b of them against the dense 9 b^2, so
// building, scaling and factorising it cost in proportion to the bodies (docs/decisions.md, "One
// factorisation per pose").
class SparseJacobian {
 public:
  SparseJacobian() = default;
  // The pattern of `layout`'s rows over `columns` coordinates (3 per moving link).
  SparseJacobian(const ConstraintLayout& layout, int columns);
  // The pattern and values of a dense matrix's nonzeros (for checks).
  explicit SparseJacobian(const Eigen::MatrixXd& dense);

  int rows() const { return rows_; }
  int cols() const { return static_cast<int>(column_start_.size()) - 1; }
  int nonzeros() const { return static_cast<int>(row_index_.size()); }
  // The entry (row, column) of the pattern; it must be one.
  double& operator()(int row, int column) { return values_[slot(row, column)]; }
  // Entry (row, column), 0 off the pattern.
  double coeff(int row, int column) const;
  void setZero() { std::fill(values_.begin(), values_.end(), 0.0); }
  // Column c's entries are [column_start(c), column_start(c + 1)), rows increasing.
  int column_start(int c) const { return column_start_[static_cast<size_t>(c)]; }
  int row_index(int e) const { return row_index_[static_cast<size_t>(e)]; }
  double value(int e) const { return values_[static_cast<size_t>(e)]; }
  double& value(int e) { return values_[static_cast<size_t>(e)]; }
  Eigen::MatrixXd dense() const;  // for tests and checks
  // This pattern with row `row` full (a bordered system's dense row), its values zero.
  SparseJacobian with_full_row(int row) const;
  // The Euclidean norm of row `row`, its entries summed in column order.
  double row_norm(int row) const;

 private:
  int slot(int row, int column) const;
  // The pattern of (column, row) entries, sorted and unique.
  void set_pattern(int rows, int columns, const std::vector<std::pair<int, int>>& entries);
  int rows_ = 0;
  std::vector<int> column_start_, row_index_;
  std::vector<double> values_;
  // Row r's entries: (column, index into values_) in [row_start_[r], row_start_[r + 1]).
  std::vector<int> row_start_;
  std::vector<std::pair<int, int>> row_entries_;
};

}  // namespace crosslink
