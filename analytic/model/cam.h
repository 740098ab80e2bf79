// Disc cams (issue 37): a follower's motion law over the cam angle, and the cam profile
// synthesised from it for a translating or oscillating follower with a knife edge, a roller or a
// flat face, with what a cam designer reads of it: pressure angle and radius of curvature.
//
// Conventions (docs/cams.md): the cam turns about its centre O, the origin, counterclockwise by
// the cam angle theta; its profile is fixed in the cam frame, which is the fixed frame turned by
// theta. A translating follower moves along +y on the line x = offset; an oscillating follower's
// arm turns about its pivot, its angle gamma measured from +x, counterclockwise. The follower's
// displacement s(theta) is a length for a translating follower and the arm's angle past its
// lowest position for an oscillating one. Angles in radians, lengths in metres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace crosslink::cam {

// The standard motion laws over one segment, normalised: y(u) on u in [0, 1], y(0) = 0, y(1) = 1.
enum class Law {
  dwell,            // y = 0: the follower rests (its segment's end equals its start)
  uniform,          // y = u: constant velocity, an infinite acceleration at each end
  simple_harmonic,  // y = (1 - cos(pi u)) / 2
  cycloidal,        // y = u - sin(2 pi u) / (2 pi)
  polynomial_345,   // y = 10 u^3 - 15 u^4 + 6 u^5
  polynomial_4567,  // y = 35 u^4 - 84 u^5 + 70 u^6 - 20 u^7
};
std::string to_string(Law law);

// A normalised law and its first four derivatives in u (the fourth: a roller's path on a profile
// given by its points has a third derivative through the surface's fourth).
struct Normalised {
  double y = 0.0, dy = 0.0, ddy = 0.0, dddy = 0.0, ddddy = 0.0;
};
Normalised normalised(Law law, double u);

// The follower's displacement and its derivatives in the cam angle: s, ds/dtheta, d2s/dtheta2,
// d3s/dtheta3 (and d4s/dtheta4). At a constant cam speed w the follower's velocity is w ds, its
// acceleration w^2 dds and its jerk w^3 ddds.
struct Motion {
  double s = 0.0, ds = 0.0, dds = 0.0, ddds = 0.0, dddds = 0.0;
};

// One segment of a motion program: a law over a cam angle span, from the displacement the
// previous segment ended at to `to`.
struct Segment {
  Law law = Law::dwell;
  double span = 0.0;  // [rad], > 0
  double to = 0.0;    // the follower's displacement at the segment's end
};

// A follower's motion over one turn of the cam: segments back to back from cam angle 0
// (starting at displacement `start`) whose spans make a whole turn and whose last ends at
// `start`; or a table of (cam angle, displacement) through a periodic cubic spline (continuous
// to the acceleration, its jerk piecewise constant).
class MotionProgram {
 public:
  // Throws std::invalid_argument naming the segment (1-based) when a span is not positive, the
  // spans do not make a turn, a dwell moves, or the last segment does not return to `start`.
  MotionProgram(double start, std::vector<Segment> segments);
  // Throws std::invalid_argument when the angles are not increasing within one turn or there
  // are fewer than three points.
  static MotionProgram table(const std::vector<std::pair<double, double>>& points);

  Motion at(double theta) const;  // any theta: the program repeats every turn
  const std::vector<Segment>& segments() const { return segments_; }

 private:
  MotionProgram() = default;
  double start_ = 0.0;
  std::vector<Segment> segments_;
  std::vector<double> begins_;  // each segment's first cam angle
  // The table's spline: knots (cam angle, displacement) and second derivatives there.
  std::vector<double> knot_theta_, knot_s_, knot_m_;
};

enum class FollowerKind { knife_edge, roller, flat_faced };

struct Follower {
  FollowerKind kind = FollowerKind::roller;
  bool oscillating = false;
  double base_radius = 0.0;    // the profile's least radius [m]
  double roller_radius = 0.0;  // roller
  double offset = 0.0;         // translating: the axis's distance from the cam centre, along +x
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();  // oscillating: the arm's pivot
  double arm = 0.0;                                 // oscillating: pivot to the roller's centre
};

// The follower's pose and the profile's geometry at one cam angle.
struct ProfilePoint {
  // The follower in the fixed frame: the roller's centre or the knife's edge (for a flat face,
  // the point of its face on its axis); and, oscillating, the arm's angle.
  Eigen::Vector2d follower = Eigen::Vector2d::Zero();
  double arm_angle = 0.0;
  // In the cam frame: the pitch point (the roller's centre, the knife's edge, or for a flat face
  // the contact point) and the profile point the follower touches, with the profile's outward
  // unit normal there.
  Eigen::Vector2d pitch = Eigen::Vector2d::Zero();
  Eigen::Vector2d contact = Eigen::Vector2d::Zero();
  Eigen::Vector2d normal = Eigen::Vector2d::Zero();
  // The angle from the follower's direction of motion (a larger s) to the common normal at the
  // contact, counterclockwise positive: positive on a rise of a radial translating follower.
  double pressure_angle = 0.0;
  // The profile's radius of curvature at the contact (positive where convex, negative where
  // concave), and the pitch curve's (a roller's centre's path; equal for a knife or a flat face).
  double radius_of_curvature = 0.0;
  double pitch_radius_of_curvature = 0.0;
};

// Throws std::invalid_argument when the follower cannot reach the base circle (an oscillating
// arm too short or too long for it) or its dimensions are not positive.
ProfilePoint profile_at(const MotionProgram& motion, const Follower& follower, double theta);

// The follower's reference point F in the fixed frame (the roller's centre or the knife's edge;
// a flat face's point on its axis) at cam angle theta, its first three derivatives in theta, and
// the direction a larger displacement moves it. Throws as profile_at.
struct FollowerPath {
  Eigen::Vector2d F = Eigen::Vector2d::Zero(), dF = Eigen::Vector2d::Zero(),
                  ddF = Eigen::Vector2d::Zero(), dddF = Eigen::Vector2d::Zero(),
                  along = Eigen::Vector2d::Zero();
  double arm_angle = 0.0;  // oscillating: the arm's angle
};
FollowerPath follower_path(const MotionProgram& motion, const Follower& follower, double theta);

// A tangent cam (Rattan, Theory of Machines, "tangent cam"; Khurmi, "cams with specified
// contours"): a base circle about the cam's centre, a nose circle of a smaller radius about a
// point on the nose's axis, and straight flanks tangent to both. A radial follower rises over
// the angle of ascent alpha, cos alpha = (Rb - Rn) / c, by the lift c + Rn - Rb, whatever its
// roller.
struct TangentCam {
  double base_radius = 0.0;  // Rb
  double nose_radius = 0.0;  // Rn, below Rb
  double distance = 0.0;     // c: the nose circle's centre from the cam's centre
  double nose_angle = 0.0;   // the nose axis's direction in the cam frame [rad]
  double lift() const { return distance + nose_radius - base_radius; }
  double ascent() const;
  // From the base circle, the lift, and the angle of ascent or (NaN) the nose radius given
  // instead. Throws std::invalid_argument naming the key at fault ("lift", "ascent",
  // "nose_radius", "base_radius") when no tangent cam has them.
  static TangentCam from_lift(double base_radius, double lift, double ascent, double nose_radius,
                              double nose_angle);
};

// An eccentric cam: a circular disc of radius R whose centre is the eccentricity e from the cam's
// centre, in the direction `angle` of the cam frame. A knife edge or a roller (of radius r) on a
// radial translating follower moves as the slider of a slider-crank of crank e and rod R + r; a
// flat face square to its motion as a Scotch yoke's, by e sin of the cam angle.
struct EccentricCam {
  double radius = 0.0;        // R, more than e: the disc holds the cam's centre
  double eccentricity = 0.0;  // e
  double angle = 0.0;         // the disc centre's direction in the cam frame [rad]
};

// A function of an angle in the cam frame, with its first three derivatives in that angle (the
// third: the follower's jerk).
struct Polar {
  double value = 0.0, d = 0.0, dd = 0.0, ddd = 0.0;
};

// A cam's profile as a joint holds a follower to it, fixed in the cam frame about the cam's
// centre. For a knife edge or a roller: the pitch curve in polar form, its radius rho(psi) at
// the polar angle psi. For a flat face: the support function, the distance h(alpha) of the face
// from the centre where the face's normal (away from the cam) makes the angle alpha. Either is
// one smooth function of one angle, so a joint's constraint row is |P - C| - rho(psi) = 0 or
// n . (O - C) - h(alpha) = 0 (docs/cams.md, "Cam joints").
class Contour {
 public:
  // Throws std::invalid_argument, saying why, when the profile cannot be cut: a dimension
  // profile_at refuses; a pitch curve that is not star-shaped about the centre (a ray from it
  // would cross the curve twice, as when the follower's path turns faster than the cam); a
  // roller larger than a convex stretch of the pitch curve's radius of curvature (the profile
  // undercuts); a flat face on a profile whose radius of curvature h + h'' is not positive (a
  // cusp); an oscillating flat face.
  Contour(MotionProgram motion, Follower follower);
  // A tangent cam's profile for a knife edge or a roller (a flat face would jump from the base
  // circle to the nose: refused); the follower's motion is then whatever its guide makes it.
  Contour(TangentCam shape, Follower follower);
  // An eccentric cam's profile for any follower; throws std::invalid_argument ("radius: ...",
  // "eccentricity: ...") when the disc does not hold the cam's centre.
  Contour(EccentricCam shape, Follower follower);
  // A profile given by its points: the cam's surface r(phi) in polar form about its centre, a
  // periodic cubic spline through them (MotionProgram::table's, phi for the cam angle and r for
  // the displacement), for any follower. A roller's centre runs on the surface moved out by its
  // radius along the normal, a flat face on its support function. Throws std::invalid_argument
  // where the follower cannot follow it: a radius that is not positive, a concave stretch
  // tighter than the roller, any concave stretch under a flat face.
  static Contour from_points(MotionProgram surface, Follower follower);

  // rho(psi) for a knife edge or a roller, h(alpha) for a flat face: any angle, every turn.
  Polar at(double angle) const;
  // The cam angle theta at which the follower touches the profile at that polar angle (knife
  // edge, roller) or normal angle (flat face); a profile cut from a motion law only.
  double cam_angle(double angle) const;

  // The tangent or eccentric cam's shape, or null for another profile.
  const TangentCam* tangent() const { return tangent_ ? &*tangent_ : nullptr; }
  const EccentricCam* eccentric() const { return eccentric_ ? &*eccentric_ : nullptr; }
  const Follower& follower() const { return follower_; }
  bool flat_faced() const { return follower_.kind == FollowerKind::flat_faced; }
  // A profile given by its points (from_points), or null.
  const MotionProgram* surface() const { return surface_ ? &*surface_ : nullptr; }
  // Over one turn, sampled every 0.1 degree: the profile's least radius of curvature where
  // convex, and the largest pressure angle's magnitude (NaN for a profile given by its shape: it
  // is the follower's guide's).
  double least_radius_of_curvature() const { return least_radius_; }
  double largest_pressure_angle() const { return largest_pressure_; }

 private:
  // A profile given by its shape or points: checks the roller's radius.
  explicit Contour(Follower follower);
  std::optional<MotionProgram> motion_;
  std::optional<TangentCam> tangent_;
  std::optional<EccentricCam> eccentric_;
  std::optional<MotionProgram> surface_;  // a profile given by its points: r(phi)
  // A profile given by its points: the surface angle phi at which the follower touches it when
  // its pitch point's polar angle (or its face's normal's angle) is `angle`; psi_ then holds
  // that angle at phi_k = k 2 pi / n (k = 0..n), rising by a turn over a turn.
  double surface_angle(double angle) const;
  Follower follower_;
  // The pitch point's polar angle psi(theta) = angle(F) - theta, unwrapped, at theta_k = k
  // 2 pi / n (k = 0..n): it falls by a turn over a turn. Newton's start for cam_angle.
  std::vector<double> psi_;
  double least_radius_ = 0.0, largest_pressure_ = 0.0;
};

}  // namespace crosslink::cam
