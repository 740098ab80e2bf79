// Instantaneous centres of velocity by the Kennedy–Aronhold theorem: an independent velocity
// check from the geometry of one pose.
//
// Centres are homogeneous points (x, y, w): w = 1 for a point, w = 0 for a centre at infinity,
// whose (x, y) is then the direction in which it lies (a link pair in relative translation).
//   primary    a revolute joint: its point; a prismatic joint: at infinity, perpendicular to
//              the slider's line; a pin-in-slot: not a point but a line, the normal to the slot
//              at the pin, on which the centre lies
//   kennedy    I(i,k) lies on the line through I(i,j) and I(j,k) for every third link j; a
//              centre is placed where two independent such lines (or a slot normal) cross,
//              repeated over all n(n-1)/2 pairs until no more can be placed, best-conditioned
//              crossing first; two centres in one place (to rounding) give no line
//   velocity   a centre Kennedy's theorem alone cannot place (some six-bars, chains driven from
//              a floating link) is placed from the exact velocity solution, and says so
// Velocities from the centres: each link's velocity field v(P) = V0 + omega perp(P) follows from
// a placed link j through I(1,k) and I(j,k) (I(j,k) moves alike on j and k; k turns about I(1,k),
// or translates when I(1,k) is at infinity): the ratio omega_k / omega_j = I(1,j)I(j,k) /
// I(1,k)I(j,k) in vector form. Of the links j that could give k, the best-conditioned pair is
// used (one of only geometric centres when it is well-conditioned); a pair whose I(1,k) and
// I(j,k) coincide (two links turning about one ground pivot, as link 6 and the crank of
// mechanisms/sixbar_slider_guide.toml about A) gives 0/0 and is never used, however small the
// rounding that separates them. Links are numbered 1.. in the definition's order.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

struct InstantCentre {
  enum class Found { primary, kennedy, velocity, none };
  int i = -1, j = -1;  // link indices (Mechanism::links), i < j
  Found found = Found::none;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // homogeneous, w = 1 or 0 (see above) [m]
  std::string how;  // "revolute A", "Kennedy: I(1,2)-I(2,6) x I(1,6)-I(6,2)", ...

  bool placed() const { return found != Found::none; }
  bool at_infinity() const { return point.z() == 0.0; }
  Eigen::Vector2d position() const { return point.head<2>(); }  // w = 1 [m]; else direction
};
std::string_view to_string(InstantCentre::Found found);

struct InstantCentres {
  std::vector<InstantCentre> centres;  // every pair i < j, in order (0,1), (0,2), ... (1,2), ...
  int kennedy_unplaced = 0;  // pairs Kennedy's theorem could not place (then from velocities)
  const InstantCentre& at(int i, int j) const;  // either order
};

// All centres at sample `row` of an exact trajectory: primary and Kennedy from the positions
// alone; the rest from the trajectory's velocities, labelled Found::velocity.
InstantCentres instant_centres(const Mechanism& mechanism, const Trajectory& exact, int row);

// Velocities found from the centres and the driver's speed at sample `row` (positions taken
// from the trajectory; its velocities are not used).
struct CentreVelocities {
  std::vector<double> omega;           // per moving link, Trajectory::link_names order [rad/s]
  std::vector<Eigen::Vector2d> point;  // per named point, Trajectory::point_names order [m/s]
  std::vector<bool> from_geometry;     // per moving link: every centre used was primary or
                                       // Kennedy (no centre placed from the velocity solution)
  bool complete = false;               // every link's velocity was found
  std::string message;                 // why not, when not complete
};
CentreVelocities centre_velocities(const Mechanism& mechanism, const InstantCentres& centres,
                                   const Trajectory& exact, int row);

// Link frame coordinates (x, y, theta per moving link, as NewtonSolver's q) and their rates at
// sample `row`, rebuilt from the trajectory's link angles and point channels.
Eigen::VectorXd coordinates_at(const Mechanism& mechanism, const Trajectory& t, int row);
Eigen::VectorXd rates_at(const Mechanism& mechanism, const Trajectory& t, int row);

}  // namespace crosslink
