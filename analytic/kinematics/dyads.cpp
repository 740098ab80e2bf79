#include "analytic/kinematics/dyads.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "analytic/model/planar.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

double angle_of(const Eigen::Vector2d& v) {
  return std::atan2(v.y(), v.x());
}

void set_angle(BodyMotion& m, double theta) {
  m.theta = theta;
  const double c = std::cos(theta), s = std::sin(theta);
  m.rotation << c, -s, s, c;
}

// The angle nearest `previous` that equals `raw` modulo 2 pi (angles are unwrapped along a sweep).
// A step of less than pi is its own remainder: std::remainder only for a wrap (the same result).
double unwrap(double raw, double previous) {
  const double step = raw - previous;
  return previous + (std::abs(step) < kPi ? step : std::remainder(step, 2.0 * kPi));
}

// Angle of a driver's measured arm in its link's frame (the driver row of newton.cpp).
double arm_angle(const Mechanism& m, const Driver& d) {
  if (d.from < 0 || d.to < 0) return 0.0;
  return angle_of(m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local);
}

int unknowns(const AssurGroup& g) {
  switch (g.kind) {
    case AssurGroup::Kind::input:
      return 0;
    case AssurGroup::Kind::pivot_slot:
    case AssurGroup::Kind::slide_slot:
      return 1;
    case AssurGroup::Kind::dyad:
      return 2;
  }
  return 0;
}
int equations(const Tie& t) {
  return t.kind == Tie::Kind::pin ? 2 : 1;
}

// The driver on joint `joint` of the given type, or -1.
int driver_on(const Mechanism& m, int joint, DriverType type) {
  for (size_t i = 0; i < m.drivers.size(); ++i)
    if (m.drivers[i].type == type && m.drivers[i].joint == joint) return static_cast<int>(i);
  return -1;
}

// The unused rack and pinion whose rack slides on prismatic joint `slide`, or -1.
int rack_on(const Mechanism& m, int slide, const std::vector<char>& used) {
  for (size_t i = 0; i < m.joints.size(); ++i)
    if (m.joints[i].type == JointType::rack_pinion && m.joints[i].slide == slide && !used[i])
      return static_cast<int>(i);
  return -1;
}

// The ties of unplaced link u to placed links, from unused joints and the drivers (each driver
// is a tie of the link it turns or slides). A link_angle driver's tie has no joint: its `joint`
// is -1 - the driver's index (-1 for the first).
std::vector<Tie> ties_of(const Mechanism& m, int u, const std::vector<char>& placed,
                         const std::vector<char>& used) {
  std::vector<Tie> ties;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    const int other = j.link_a == u ? j.link_b : j.link_b == u ? j.link_a : -1;
    if (used[ji] || other < 0 || !placed[other]) continue;
    const int joint = static_cast<int>(ji);
    // No closed form here for a curved slot or a cam: Newton's (below).
    if (j.type == JointType::pin_in_arc || j.type == JointType::pin_in_spline ||
        j.type == JointType::cam)
      continue;
    if (j.type == JointType::gear) {
      // Its other gear and its carrier placed, the rolling of the pitch circles
      // theta_a - theta_c + ratio (theta_b - theta_c) = phase gives u's angle.
      if (j.carrier == u || !placed[static_cast<size_t>(j.carrier)]) continue;
      const bool b = u == j.link_b;
      Tie angle{.kind = Tie::Kind::angle, .joint = joint, .known = other};
      angle.offset = b ? j.phase / j.ratio : j.phase;
      angle.known_scale = b ? -1.0 / j.ratio : -j.ratio;
      angle.second = j.carrier;
      angle.second_scale = b ? 1.0 + 1.0 / j.ratio : 1.0 + j.ratio;
      ties.push_back(angle);
      continue;
    }
    if (j.type == JointType::rack_pinion) {
      // The pinion, its rack and the rack's guide placed: the rolling of the pitch circle on
      // the pitch line, s - ratio (theta_a - theta_c) = phase, gives the pinion's angle from
      // the rack's travel s. (The rack, its pinion placed, is held through its slide: below.)
      if (u != j.link_a || !placed[static_cast<size_t>(j.carrier)]) continue;
      Tie angle{.kind = Tie::Kind::angle, .joint = joint, .known = j.carrier};
      angle.offset = -j.phase / j.ratio;
      angle.rack = joint;
      angle.travel_scale = 1.0 / j.ratio;
      ties.push_back(angle);
      continue;
    }
    if (j.type == JointType::revolute) {
      Tie pin{.kind = Tie::Kind::pin, .joint = joint, .known = other};
      pin.on_known = j.link_a == other ? j.point_a : j.point_b;
      pin.on_link = j.link_a == u ? j.point_a : j.point_b;
      ties.push_back(pin);
      if (const int d = driver_on(m, joint, DriverType::joint_angle); d >= 0) {
        // Newton's driver row: theta_b + arm - theta_a = value.
        const double arm = arm_angle(m, m.drivers[static_cast<size_t>(d)]);
        Tie angle{.kind = Tie::Kind::angle, .joint = joint, .known = other};
        angle.offset = u == j.link_b ? -arm : arm;
        angle.driver_sign = u == j.link_b ? 1.0 : -1.0;
        ties.push_back(angle);
      }
      continue;
    }
    if (driver_on(m, joint, DriverType::slider) >= 0) {
      // The driven slider's point sits at s = driver along the placed guide: a moving pin. (A
      // placed slider does not place its guide this way: the joint stays unused.)
      if (u != j.link_b) continue;
      Tie pin{.kind = Tie::Kind::pin, .joint = joint, .known = other};
      pin.line = j.line;
      pin.on_link = j.point_b;
      pin.driver_slide = true;
      ties.push_back(pin);
    } else if (const int r =
                   j.type == JointType::prismatic && u == j.link_b ? rack_on(m, joint, used) : -1;
               r >= 0 && placed[static_cast<size_t>(m.joints[static_cast<size_t>(r)].link_a)]) {
      // A rack whose pinion (and guide) are placed: its point sits at the travel the pinion
      // gives, s = ratio (theta_pinion - theta_guide) + phase, along the guide's line.
      Tie pin{.kind = Tie::Kind::pin, .joint = joint, .known = other};
      pin.line = j.line;
      pin.on_link = j.point_b;
      pin.driver_slide = true;
      pin.rack = r;
      ties.push_back(pin);
    } else {
      Tie slot{.kind = Tie::Kind::slot, .joint = joint, .known = other};
      slot.slider_is_unplaced = u == j.link_b;
      ties.push_back(slot);
    }
    if (j.type == JointType::prismatic) {
      Tie angle{.kind = Tie::Kind::angle, .joint = joint, .known = other};
      angle.offset = u == j.link_b ? j.relative_angle : -j.relative_angle;
      ties.push_back(angle);
    }
  }
  for (size_t i = 0; i < m.drivers.size(); ++i)
    if (m.drivers[i].type == DriverType::link_angle && m.drivers[i].link == u)
      ties.push_back(Tie{.kind = Tie::Kind::angle,
                         .joint = -1 - static_cast<int>(i),
                         .known = -1,
                         .offset = -arm_angle(m, m.drivers[i]),
                         .driver_sign = 1.0});
  return ties;
}

// Indices of a link's pin, angle and slot ties (the first of each; `second_slot` the next slot).
struct TieIndex {
  int pin = -1, angle = -1, slot = -1, second_slot = -1, pins = 0, angles = 0, slots = 0;
  int equations = 0;
};
TieIndex index_ties(const std::vector<Tie>& ties) {
  TieIndex x;
  for (size_t i = 0; i < ties.size(); ++i) {
    const int k = static_cast<int>(i);
    x.equations += equations(ties[i]);
    switch (ties[i].kind) {
      case Tie::Kind::pin:
        x.pins++, x.pin = x.pin < 0 ? k : x.pin;
        break;
      case Tie::Kind::angle:
        x.angles++, x.angle = x.angle < 0 ? k : x.angle;
        break;
      case Tie::Kind::slot:
        if (x.slot < 0)
          x.slot = k;
        else if (x.second_slot < 0)
          x.second_slot = k;
        x.slots++;
        break;
    }
  }
  return x;
}

// "R" for a link held by a pin, "P" for angle + slot, "" otherwise.
std::string side_letter(const TieIndex& x) {
  if (x.pins == 1 && x.angles == 0 && x.slots == 0) return "R";
  if (x.pins == 0 && x.angles == 1 && x.slots == 1) return "P";
  return "";
}

std::string tie_summary(const Mechanism& m, const std::vector<Tie>& ties) {
  if (ties.empty()) return "no tie to a placed link";
  std::string text;
  for (const Tie& t : ties) {
    if (!text.empty()) text += " + ";
    const std::string known = t.known >= 0 ? m.links[t.known].name : "the driver";
    switch (t.kind) {
      case Tie::Kind::pin:
        text += t.rack >= 0 ? fmt::format("pin on {} at the travel from pinion {}", known,
                                          m.links[m.joints[t.rack].link_a].name)
                            : fmt::format("pin on {}", known);
        break;
      case Tie::Kind::angle:
        text += t.joint < 0     ? std::string("driven angle")
                : t.second >= 0 ? fmt::format("gear angle from {}", known)
                : t.rack >= 0   ? fmt::format("pinion angle from the travel of rack {}",
                                              m.links[m.joints[t.rack].link_b].name)
                                : fmt::format("angle from {}", known);
        break;
      case Tie::Kind::slot:
        text += fmt::format("slot with {}", known);
        break;
    }
  }
  return text;
}

}  // namespace

Decomposition decompose(const Mechanism& m) {
  Decomposition out;
  const int n = static_cast<int>(m.links.size());
  std::vector<char> placed(static_cast<size_t>(n), 0), used(m.joints.size(), 0);
  placed[static_cast<size_t>(m.ground())] = 1;
  int remaining = n - 1;

  auto accept = [&](AssurGroup g) {
    for (int i = 0; i < 2; ++i) {
      if (g.link[i] < 0) continue;
      placed[static_cast<size_t>(g.link[i])] = 1;
      --remaining;
      for (const Tie& t : g.ties[i]) {
        if (t.joint >= 0) used[static_cast<size_t>(t.joint)] = 1;
        if (t.rack >= 0) used[static_cast<size_t>(t.rack)] = 1;
      }
    }
    if (g.inner >= 0) used[static_cast<size_t>(g.inner)] = 1;
    out.groups.push_back(std::move(g));
  };

  while (remaining > 0) {
    bool found = false;
    // Single links first: three equations of ties to placed links.
    for (int u = 0; u < n && !found; ++u) {
      if (placed[static_cast<size_t>(u)]) continue;
      std::vector<Tie> ties = ties_of(m, u, placed, used);
      const TieIndex x = index_ties(ties);
      if (x.equations > 3) {
        out.reason = fmt::format(
            "link '{}' is over-constrained by the links placed before it ({}): a redundant "
            "joint, which the dyad method does not check",
            m.links[u].name, tie_summary(m, ties));
        return out;
      }
      AssurGroup g;
      g.link[0] = u;
      g.pin[0] = x.pin;
      g.angle[0] = x.angle;
      g.slot[0] = x.slot;
      const std::string& name = m.links[u].name;
      if (x.pins == 1 && x.angles == 1 && x.slots == 0) {
        g.kind = AssurGroup::Kind::input;
        g.name = fmt::format("input link {} ({})", name, tie_summary(m, ties));
      } else if (x.pins == 1 && x.angles == 0 && x.slots == 1) {
        g.kind = AssurGroup::Kind::pivot_slot;
        g.equation = x.slot;
        g.slot[0] = -1;
        g.two_solutions = true;
        g.name = fmt::format("slotted link {} ({})", name, tie_summary(m, ties));
      } else if (x.pins == 0 && x.angles == 1 && x.slots == 2) {
        g.kind = AssurGroup::Kind::slide_slot;
        g.equation = x.second_slot;
        g.name = fmt::format("sliding link {} ({})", name, tie_summary(m, ties));
      } else {
        continue;
      }
      g.ties[0] = std::move(ties);
      accept(std::move(g));
      found = true;
    }
    if (found) continue;
    // Dyads: two unplaced links joined by a revolute or prismatic joint, each held by R or P.
    for (size_t ji = 0; ji < m.joints.size() && !found; ++ji) {
      const Joint& j = m.joints[ji];
      // (A pin-in-slot or a gearing joint is no inner joint: it takes one freedom, not two.)
      if (used[ji] || (j.type != JointType::revolute && j.type != JointType::prismatic)) continue;
      if (placed[static_cast<size_t>(j.link_a)] || placed[static_cast<size_t>(j.link_b)]) continue;
      if (std::any_of(m.drivers.begin(), m.drivers.end(), [&](const Driver& d) {
            return d.joint == static_cast<int>(ji) && d.type != DriverType::link_angle;
          }))
        continue;  // a driven joint between two unplaced links
      AssurGroup g;
      g.kind = AssurGroup::Kind::dyad;
      g.inner = static_cast<int>(ji);
      std::string letters[2];
      for (int i = 0; i < 2; ++i) {
        g.link[i] = i == 0 ? j.link_a : j.link_b;
        g.ties[i] = ties_of(m, g.link[i], placed, used);
        const TieIndex x = index_ties(g.ties[i]);
        letters[i] = side_letter(x);
        g.pin[i] = x.pin;
        g.angle[i] = x.angle;
        g.slot[i] = x.slot;
      }
      if (letters[0].empty() || letters[1].empty()) continue;
      const bool inner_r = j.type == JointType::revolute;
      if (!inner_r && letters[0] == "P" && letters[1] == "P") continue;  // PPP does not place
      // Two solutions unless both sides are lines (PRP) or one prismatic side fixes the angle.
      g.two_solutions = inner_r ? !(letters[0] == "P" && letters[1] == "P")
                                : (letters[0] == "R" && letters[1] == "R");
      g.name = fmt::format("{}{}{} dyad {} + {} (joint {})", letters[0], inner_r ? "R" : "P",
                           letters[1], m.links[j.link_a].name, m.links[j.link_b].name, j.name);
      accept(std::move(g));
      found = true;
    }
    if (found) continue;

    // Nothing more places: say what is left and what holds each remaining link.
    std::string placed_names, left;
    for (int u = 0; u < n; ++u) {
      if (placed[static_cast<size_t>(u)]) {
        placed_names += (placed_names.empty() ? "" : ", ") + m.links[u].name;
        continue;
      }
      left += fmt::format("{}{} ({})", left.empty() ? "" : "; ", m.links[u].name,
                          tie_summary(m, ties_of(m, u, placed, used)));
    }
    std::string why =
        "the rest is a group of class III or higher (e.g. a link held by three sliding pins)";
    // A rack and pinion places one side once the other and the rack's guide are placed: one
    // left with both sides (or the guide) unplaced is named.
    for (size_t ji = 0; ji < m.joints.size(); ++ji) {
      const Joint& j = m.joints[ji];
      if (used[ji] || j.type != JointType::rack_pinion) continue;
      const auto is_placed = [&](int l) { return placed[static_cast<size_t>(l)] != 0; };
      why = fmt::format(
          "rack and pinion '{}' places neither its pinion '{}' nor its rack '{}' ({}; it "
          "places either from the other on a placed guide): the rest, the mesh in it, is a "
          "group that no dyad or single link places",
          j.name, m.links[j.link_a].name, m.links[j.link_b].name,
          !is_placed(j.carrier)
              ? fmt::format("their guide '{}' is not placed", m.links[j.carrier].name)
          : !is_placed(j.link_a) && !is_placed(j.link_b)
              ? std::string("neither is placed")
              : fmt::format("'{}' is placed, but the mesh alone does not place '{}'",
                            m.links[is_placed(j.link_a) ? j.link_a : j.link_b].name,
                            m.links[is_placed(j.link_a) ? j.link_b : j.link_a].name));
      break;
    }
    for (const Joint& j : m.joints)
      if (j.type == JointType::pin_in_arc || j.type == JointType::pin_in_spline ||
          j.type == JointType::cam) {
        why = j.type == JointType::cam
                  ? fmt::format("the dyads have no closed form for cam '{}'", j.name)
                  : fmt::format("the dyads have no closed form for pin '{}' in its {}", j.name,
                                j.type == JointType::pin_in_arc ? "arc" : "spline slot");
        break;
      }
    for (const Driver& d : m.drivers)
      if (d.type == DriverType::link_angle && !placed[static_cast<size_t>(d.link)]) {
        why = fmt::format(
            "the driver turns the floating link '{}', whose angle alone does not "
            "place it, so the chain cannot be solved outward from the driver",
            m.links[d.link].name);
        break;
      }
    out.reason = fmt::format(
        "no dyad or single link can be placed after {{{}}}; unplaced: {}. {}: left to Newton",
        placed_names, left, why);
    return out;
  }
  for (size_t ji = 0; ji < m.joints.size(); ++ji)
    if (!used[ji] && m.joints[ji].type == JointType::gear) {
      out.reason = fmt::format(
          "gear pair '{}' places neither gear (each placed before it by other joints): a "
          "redundant coupling, left to Newton",
          m.joints[ji].name);
      return out;
    } else if (!used[ji] && m.joints[ji].type == JointType::rack_pinion) {
      out.reason = fmt::format(
          "rack and pinion '{}' places neither its pinion '{}' nor its rack '{}' (each placed "
          "before it by other joints): a redundant coupling, left to Newton",
          m.joints[ji].name, m.links[m.joints[ji].link_a].name, m.links[m.joints[ji].link_b].name);
      return out;
    } else if (!used[ji]) {
      out.reason = fmt::format(
          "joint '{}' is not used by any group (a redundant joint, or a "
          "slider driver whose guide moves)",
          m.joints[ji].name);
      return out;
    }
  out.complete = true;
  return out;
}

DyadState::DyadState(const Mechanism& mechanism)
    : kinematics(mechanism), motion(mechanism.links.size()) {}

// Both solutions of one group: the point its loci meet at (or a tangent line's angle). Reused
// from group to group: roots() sets what its group's solutions use.
struct DyadSolver::Roots {
  int count = 0;  // 0: cannot assemble; 1: one solution; 2: two
  // The solved point (circle or line crossings).
  Eigen::Vector2d point[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  double angle[2] = {0.0, 0.0};  // tangent: the guide's angle
  bool tangent = false;          // the roots are angles
  double sine = 1.0;             // how far from the two roots meeting (0: they meet)
  // The world points of the group's pins (of links placed before it), for place().
  Eigen::Vector2d pin[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  Eigen::Vector2d key(int i, double size) const {
    return tangent ? Eigen::Vector2d(size * std::cos(angle[i]), size * std::sin(angle[i]))
                   : point[i];
  }
};

namespace {

// Loci that miss each other by less than this (relative, squared) touch: rounding at a toggle or
// change point must not read as "cannot assemble".
constexpr double kTouching = 1e-10;

struct WorldLine {
  Eigen::Vector2d through, direction;  // direction: unit
};

// Circle (centre, radius) with a line: roots along the line's direction, +1 first.
int circle_line(const Eigen::Vector2d& centre, double radius, const WorldLine& line,
                Eigen::Vector2d out[2], double& sine) {
  const Eigen::Vector2d foot =
      line.through + (centre - line.through).dot(line.direction) * line.direction;
  const double h2 = radius * radius - (centre - foot).squaredNorm();
  if (h2 < -kTouching * radius * radius) return 0;
  const double h = std::sqrt(std::max(h2, 0.0));
  out[0] = foot + h * line.direction;
  out[1] = foot - h * line.direction;
  sine = radius > 0.0 ? h / radius : 0.0;
  return 2;
}

// Two circles: +1 is the root left of the line from the first centre to the second.
int circle_circle(const Eigen::Vector2d& a, double ra, const Eigen::Vector2d& b, double rb,
                  Eigen::Vector2d out[2], double& sine) {
  const Eigen::Vector2d ab = b - a;
  const double l = ab.norm();
  if (l == 0.0) return 0;
  const Eigen::Vector2d u = ab / l;
  const double along = (ra * ra - rb * rb + l * l) / (2.0 * l);
  const double h2 = ra * ra - along * along;
  if (h2 < -kTouching * ra * ra) return 0;
  const double h = std::sqrt(std::max(h2, 0.0));
  out[0] = a + along * u + h * perp(u);
  out[1] = a + along * u - h * perp(u);
  sine = ra > 0.0 && rb > 0.0 ? h * l / (ra * rb) : 0.0;
  return 2;
}

int line_line(const WorldLine& a, const WorldLine& b, Eigen::Vector2d& out, double& sine) {
  const double c = cross(a.direction, b.direction);
  sine = std::abs(c);
  if (c == 0.0) return 0;
  out = a.through + (cross(b.through - a.through, b.direction) / c) * a.direction;
  return 1;
}

// The angle theta of a link whose local direction `normal` turned by theta, n, meets
// n . u = e: +1 is the larger of the two.
int tangent(const Eigen::Vector2d& u, double e, const Eigen::Vector2d& normal, double out[2],
            double& sine) {
  const double l = u.norm();
  if (l == 0.0 || std::abs(e) > (1.0 + kTouching) * l) return 0;
  const double c = std::clamp(e / l, -1.0, 1.0), base = angle_of(u) - angle_of(normal),
               spread = std::acos(c);
  out[0] = base + spread;
  out[1] = base - spread;
  sine = std::sqrt(std::max(0.0, 1.0 - c * c));
  return 2;
}

// Geometry of a joint's line part: guide G carries line (o, d), slider S carries point p.
struct SlotGeometry {
  int guide, slider;
  const Line* line;
  Eigen::Vector2d point;
};
SlotGeometry slot_of(const Mechanism& m, int joint) {
  const Joint& j = m.joints[joint];
  return {j.link_a, j.link_b, &m.links[j.link_a].lines[j.line],
          m.links[j.link_b].points[j.point_b].local};
}

// The state of the driver a tie reads: the one on the tie's joint (a link_angle driver's tie
// holds -1 - its index); a tie no driver moves (driver_sign 0) reads a state at rest.
const DriverState& tie_driver(const Mechanism& m, const Tie& t, const DyadState& s) {
  static constexpr DriverState kNone{};
  const std::vector<DriverState>& states = s.kinematics.drivers;
  if (t.joint < 0) return states[static_cast<size_t>(-1 - t.joint)];
  for (size_t d = 0; d < states.size(); ++d)
    if (m.drivers[d].joint == t.joint && m.drivers[d].type != DriverType::link_angle)
      return states[d];
  return kNone;
}

// The travel s of a sliding pin tie along its line, with its rate and acceleration: the
// driver's, or a rack's from its placed pinion and guide (s = ratio (theta_pinion -
// theta_guide) + phase, the rack and pinion's row in analytic/model/constraints.cpp).
DriverState travel_of(const Mechanism& m, const Tie& t, const DyadState& s) {
  if (t.rack < 0) [[likely]]
    return tie_driver(m, t, s);
  const Joint& j = m.joints[static_cast<size_t>(t.rack)];
  const BodyMotion& pinion = s.motion[static_cast<size_t>(j.link_a)];
  const BodyMotion& guide = s.motion[static_cast<size_t>(j.carrier)];
  DriverState d;
  d.value = j.ratio * (pinion.theta - guide.theta) + j.phase;
  d.rate = j.ratio * (pinion.omega - guide.omega);
  d.accel = j.ratio * (pinion.alpha - guide.alpha);
  return d;
}

// A rack's travel along its slide, with its rate and acceleration, read off its placed guide
// and rack (as a slider driver reads it).
Projection rack_travel(const Mechanism& m, int rack_joint, const DyadState& s) {
  const SlotGeometry g = slot_of(m, m.joints[static_cast<size_t>(rack_joint)].slide);
  return project(s.motion[static_cast<size_t>(g.guide)], g.line->origin, g.line->direction,
                 s.motion[static_cast<size_t>(g.slider)], g.point);
}

// The velocity (accel false) or acceleration of a pin tie's point, its known link's local point
// given (unused when the pin slides with the driver).
Eigen::Vector2d sliding_pin_rate(const Mechanism& m, const Tie& t, bool accel, const DyadState& s);
inline Eigen::Vector2d pin_rate(const Mechanism& m, const Tie& t, const Eigen::Vector2d& on_known,
                                bool accel, const DyadState& s) {
  const BodyMotion& k = s.motion[t.known];
  if (!t.driver_slide) [[likely]]
    return accel ? k.acceleration(on_known) : k.velocity(on_known);
  return sliding_pin_rate(m, t, accel, s);
}
// pin_rate of a pin that slides with the driver.
[[gnu::noinline]] Eigen::Vector2d sliding_pin_rate(const Mechanism& m, const Tie& t, bool accel,
                                                   const DyadState& s) {
  const BodyMotion& k = s.motion[t.known];
  const Line& line = m.links[t.known].lines[t.line];
  const DriverState d = travel_of(m, t, s);
  const Eigen::Vector2d local = line.origin + d.value * line.direction;
  if (!accel) return k.velocity(local) + d.rate * k.turn(line.direction);
  return k.acceleration(local) + 2.0 * d.rate * k.turn_rate(line.direction) +
         d.accel * k.turn(line.direction);
}

// The world position of a pin tie's point, its known link's local point
// given (unused when the pin slides with the driver).
Eigen::Vector2d pin_position(const Mechanism& m, const Tie& t, const Eigen::Vector2d& on_known,
                             const DyadState& s) {
  const BodyMotion& k = s.motion[t.known];
  if (!t.driver_slide) return k.position(on_known);
  const Line& line = m.links[t.known].lines[t.line];
  return k.position(line.origin + travel_of(m, t, s).value * line.direction);
}

// theta, omega, alpha of a link from its angle tie.
Eigen::Vector3d angle_state(const Mechanism& m, const Tie& t, const DyadState& s) {
  const DriverState& d = tie_driver(m, t, s);
  Eigen::Vector3d a(t.offset + t.driver_sign * d.value, t.driver_sign * d.rate,
                    t.driver_sign * d.accel);
  if (t.known >= 0) {
    const BodyMotion& k = s.motion[t.known];
    a += t.known_scale * Eigen::Vector3d(k.theta, k.omega, k.alpha);
  }
  if (t.second >= 0) {
    const BodyMotion& k = s.motion[t.second];
    a += t.second_scale * Eigen::Vector3d(k.theta, k.omega, k.alpha);
  }
  if (t.rack >= 0) {
    const Projection travel = rack_travel(m, t.rack, s);
    a += t.travel_scale * Eigen::Vector3d(travel.value, travel.rate, travel.accel);
  }
  return a;
}

// The world line on which point `x` (local to link u, whose angle is set) runs when u is held
// by slot tie `t` and its angle.
WorldLine slide_line(const Mechanism& m, const Tie& t, int u, const Eigen::Vector2d& x,
                     const DyadState& s) {
  const SlotGeometry g = slot_of(m, t.joint);
  const BodyMotion& link = s.motion[u];
  if (t.slider_is_unplaced) {
    const BodyMotion& guide = s.motion[g.guide];
    return {guide.position(g.line->origin) + link.turn(x - g.point), guide.turn(g.line->direction)};
  }
  return {s.motion[g.slider].position(g.point) + link.turn(x - g.line->origin),
          link.turn(g.line->direction)};
}

}  // namespace

DyadSolver::DyadSolver(const Mechanism& mechanism, Decomposition decomposition,
                       double singular_sine)
    : mechanism_(mechanism),
      decomposition_(std::move(decomposition)),
      size_(mechanism.size()),
      singular_sine_(singular_sine) {
  if (!decomposition_.complete)
    throw std::invalid_argument("the chain does not decompose into dyads: " +
                                decomposition_.reason);
  const Mechanism& m = mechanism_;
  for (size_t l = 0; l < m.links.size(); ++l)
    if (const int i = m.moving_index(static_cast<int>(l)); i >= 0)
      moving_.push_back({static_cast<int>(l), i});
  plans_.resize(decomposition_.groups.size());
  for (size_t gi = 0; gi < plans_.size(); ++gi) {
    const AssurGroup& g = decomposition_.groups[gi];
    Plan& plan = plans_[gi];
    plan.unknowns = unknowns(g);
    plan.rrr = g.kind == AssurGroup::Kind::dyad && m.joints[g.inner].type == JointType::revolute &&
               g.pin[0] >= 0 && g.pin[1] >= 0 && g.angle[0] < 0 && g.angle[1] < 0;
    plan.input = plan.unknowns == 0 && g.link[1] < 0 && g.pin[0] >= 0 && g.angle[0] >= 0;
    if (plan.rrr) {
      const Joint& j = m.joints[g.inner];
      plan.inner[0] = m.links[g.link[0]].points[j.point_a].local;
      plan.inner[1] = m.links[g.link[1]].points[j.point_b].local;
    }
    for (int i = 0; i < 2; ++i) {
      if (g.link[i] < 0) continue;
      Plan::Side& side = plan.side[i];
      if (g.angle[i] >= 0) side.has_angle = true, side.angle = g.ties[i][g.angle[i]];
      if (g.pin[i] < 0) continue;
      side.has_pin = true;
      side.pin = g.ties[i][g.pin[i]];
      side.pin_local = m.links[g.link[i]].points[side.pin.on_link].local;
      if (!side.pin.driver_slide)
        side.pin_known = m.links[side.pin.known].points[side.pin.on_known].local;
      // The point turned about the pin: the slotted pin of a pivot_slot, a dyad's inner joint.
      Eigen::Vector2d x = side.pin_local;
      if (g.kind == AssurGroup::Kind::pivot_slot)
        x = slot_of(m, g.ties[0][g.equation].joint).point;
      else if (g.kind == AssurGroup::Kind::dyad && m.joints[g.inner].type == JointType::revolute) {
        const Joint& j = m.joints[g.inner];
        x = m.links[g.link[i]].points[i == 0 ? j.point_a : j.point_b].local;
      }
      side.radius = (x - side.pin_local).norm();
      side.turn_angle = angle_of(x - side.pin_local);
    }
  }
}

void DyadSolver::roots(const AssurGroup& g, const Plan& plan, DyadState& s, Roots& r) const {
  const Mechanism& m = mechanism_;
  r.count = 0;
  r.tangent = false;
  r.sine = 1.0;
  // Links with an angle tie get their angle first (it is unique); the pins' world points are
  // those of links placed before (place() reuses them).
  for (int i = 0; i < 2; ++i) {
    const Plan::Side& side = plan.side[i];
    if (side.has_angle) {
      const Tie& t = side.angle;
      const DriverState& d = tie_driver(m, t, s);
      double theta = t.offset + t.driver_sign * d.value;
      if (t.known >= 0) theta += t.known_scale * s.motion[t.known].theta;
      if (t.second >= 0) theta += t.second_scale * s.motion[t.second].theta;
      if (t.rack >= 0) theta += t.travel_scale * rack_travel(m, t.rack, s).value;
      set_angle(s.motion[g.link[i]], theta);
    }
    if (side.has_pin) r.pin[i] = pin_position(m, side.pin, side.pin_known, s);
  }
  auto local = [&](int i, int point) -> const Eigen::Vector2d& {
    return m.links[g.link[i]].points[point].local;
  };
  auto pin_local = [&](int i) -> const Eigen::Vector2d& { return plan.side[i].pin_local; };
  auto pin_world = [&](int i) -> const Eigen::Vector2d& { return r.pin[i]; };

  switch (g.kind) {
    case AssurGroup::Kind::input:
      r.count = 1;
      r.point[0] = pin_world(0);
      return;
    case AssurGroup::Kind::pivot_slot: {
      const Tie& t = g.ties[0][g.equation];
      const SlotGeometry sg = slot_of(m, t.joint);
      const Eigen::Vector2d a = pin_world(0);
      if (t.slider_is_unplaced) {
        // The slider's point on a placed line: circle about the pin with the line.
        const BodyMotion& guide = s.motion[sg.guide];
        r.count = circle_line(a, plan.side[0].radius,
                              {guide.position(sg.line->origin), guide.turn(sg.line->direction)},
                              r.point, r.sine);
      } else {
        // A placed point on this link's line: the line through it tangent to a circle.
        r.tangent = true;
        r.count = tangent(s.motion[sg.slider].position(sg.point) - a,
                          perp(sg.line->direction).dot(sg.line->origin - pin_local(0)),
                          perp(sg.line->direction), r.angle, r.sine);
      }
      return;
    }
    case AssurGroup::Kind::slide_slot: {
      const Tie& t = g.ties[0][g.equation];
      const SlotGeometry sg = slot_of(m, t.joint);
      const BodyMotion& u = s.motion[g.link[0]];
      const Eigen::Vector2d x = t.slider_is_unplaced ? sg.point : sg.line->origin;
      const WorldLine other =
          t.slider_is_unplaced
              ? WorldLine{s.motion[sg.guide].position(sg.line->origin),
                          s.motion[sg.guide].turn(sg.line->direction)}
              : WorldLine{s.motion[sg.slider].position(sg.point), u.turn(sg.line->direction)};
      r.count = line_line(slide_line(m, g.ties[0][g.slot[0]], g.link[0], x, s), other, r.point[0],
                          r.sine);
      return;
    }
    case AssurGroup::Kind::dyad:
      break;
  }

  const Joint& j = m.joints[g.inner];
  if (j.type == JointType::revolute) {
    // Inner revolute at C: a circle about each pin, a line for each slide.
    const Eigen::Vector2d c0 = local(0, j.point_a), c1 = local(1, j.point_b);
    const bool pivot0 = g.pin[0] >= 0, pivot1 = g.pin[1] >= 0;
    if (pivot0 && pivot1) {
      r.count = circle_circle(pin_world(0), plan.side[0].radius, pin_world(1), plan.side[1].radius,
                              r.point, r.sine);
    } else if (pivot0 != pivot1) {
      const int p = pivot0 ? 0 : 1, l = 1 - p;
      r.count = circle_line(pin_world(p), plan.side[p].radius,
                            slide_line(m, g.ties[l][g.slot[l]], g.link[l], l == 0 ? c0 : c1, s),
                            r.point, r.sine);
    } else {
      r.count =
          line_line(slide_line(m, g.ties[0][g.slot[0]], g.link[0], c0, s),
                    slide_line(m, g.ties[1][g.slot[1]], g.link[1], c1, s), r.point[0], r.sine);
    }
    return;
  }
  // Inner prismatic: link[0] is the guide (line o, d), link[1] the slider (point p).
  const SlotGeometry sg = slot_of(m, g.inner);
  const Eigen::Vector2d& o = sg.line->origin;
  const Eigen::Vector2d& d = sg.line->direction;
  const Eigen::Matrix2d relative = Eigen::Rotation2Dd(j.relative_angle).toRotationMatrix();
  if (g.pin[0] >= 0 && g.pin[1] >= 0) {
    // RPR: the guide's line through the slider's point as both turn together.
    r.tangent = true;
    r.count = tangent(pin_world(1) - pin_world(0),
                      -perp(d).dot(relative * (sg.point - pin_local(1)) - (o - pin_local(0))),
                      perp(d), r.angle, r.sine);
    return;
  }
  // RPP / PPR: the slide fixes both angles; the pinned link is then placed, and the other's
  // point meets the pinned link's line.
  const int p = g.pin[0] >= 0 ? 0 : 1, l = 1 - p;
  BodyMotion& pinned = s.motion[g.link[p]];
  set_angle(pinned, s.motion[g.link[l]].theta + (p == 0 ? -j.relative_angle : j.relative_angle));
  pinned.r = pin_world(p) - pinned.turn(pin_local(p));
  const BodyMotion& slid = s.motion[g.link[l]];
  const WorldLine across = p == 0 ? WorldLine{pinned.position(o), pinned.turn(d)}
                                  : WorldLine{pinned.position(sg.point), slid.turn(d)};
  r.count = line_line(slide_line(m, g.ties[l][g.slot[l]], g.link[l], p == 0 ? sg.point : o, s),
                      across, r.point[0], r.sine);
}

void DyadSolver::place(const AssurGroup& g, const Plan& plan, const Roots& r, int index,
                       DyadState& s) const {
  const Mechanism& m = mechanism_;
  const Eigen::Vector2d& x0 = r.point[index];
  auto local = [&](int i, int point) -> const Eigen::Vector2d& {
    return m.links[g.link[i]].points[point].local;
  };
  auto pin_local = [&](int i) -> const Eigen::Vector2d& { return plan.side[i].pin_local; };
  auto pin_world = [&](int i) -> const Eigen::Vector2d& { return r.pin[i]; };
  // A pinned link through world point `at` of its plan's turned point.
  auto turn_to = [&](int i, const Eigen::Vector2d& at) {
    BodyMotion& u = s.motion[g.link[i]];
    const Eigen::Vector2d& a = pin_world(i);
    set_angle(u, unwrap(angle_of(at - a) - plan.side[i].turn_angle, u.theta));
    u.r = a - u.turn(pin_local(i));
  };
  auto set_turned = [&](int i, double theta) {
    BodyMotion& u = s.motion[g.link[i]];
    set_angle(u, unwrap(theta, u.theta));
    u.r = pin_world(i) - u.turn(pin_local(i));
  };
  auto slide_to = [&](int i, const Eigen::Vector2d& x, const Eigen::Vector2d& at) {
    BodyMotion& u = s.motion[g.link[i]];
    u.r = at - u.turn(x);
  };

  switch (g.kind) {
    case AssurGroup::Kind::input:
      slide_to(0, pin_local(0), x0);
      return;
    case AssurGroup::Kind::pivot_slot:
      if (r.tangent)
        set_turned(0, r.angle[index]);
      else
        turn_to(0, x0);
      return;
    case AssurGroup::Kind::slide_slot: {
      const Tie& t = g.ties[0][g.equation];
      const SlotGeometry sg = slot_of(m, t.joint);
      slide_to(0, t.slider_is_unplaced ? sg.point : sg.line->origin, x0);
      return;
    }
    case AssurGroup::Kind::dyad:
      break;
  }
  const Joint& j = m.joints[g.inner];
  if (j.type == JointType::revolute) {
    const Eigen::Vector2d c[2] = {local(0, j.point_a), local(1, j.point_b)};
    for (int i = 0; i < 2; ++i) {
      if (g.pin[i] >= 0)
        turn_to(i, x0);
      else
        slide_to(i, c[i], x0);
    }
    return;
  }
  const SlotGeometry sg = slot_of(m, g.inner);
  if (g.pin[0] >= 0 && g.pin[1] >= 0) {
    set_turned(0, r.angle[index]);
    set_turned(1, s.motion[g.link[0]].theta + j.relative_angle);
    return;
  }
  const int l = g.pin[0] >= 0 ? 1 : 0;  // the sliding link; the pinned one is placed by roots()
  slide_to(l, l == 1 ? sg.point : sg.line->origin, x0);
}

void DyadSolver::set_modes(const KinematicState& assembled, DyadState& s) const {
  const Mechanism& m = mechanism_;
  for (size_t l = 0; l < m.links.size(); ++l)
    s.motion[l] = BodyMotion::of(m.moving_index(static_cast<int>(l)), assembled.q, &assembled.qdot,
                                 &assembled.qddot);
  s.kinematics.drivers = assembled.drivers;
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  s.assembly_mode.assign(groups.size(), 0);
  s.previous.assign(groups.size(), Eigen::Vector2d::Zero());
  s.before_previous = s.previous;
  s.rate_matrix.assign(groups.size(), Eigen::Matrix2d::Identity());
  s.rate_matrix_valid = false;
  s.history = 0;
  s.previous_driver = s.before_previous_driver = s.kinematics.parameter();
  // Each two-solution group takes the root nearest the assembled pose of its links.
  const std::vector<BodyMotion> drawn = s.motion;
  Roots r;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    if (!g.two_solutions) continue;
    roots(g, plans_[gi], s, r);
    if (r.count < 2) {
      s.assembly_mode[gi] = 1;
      continue;
    }
    double distance[2];
    for (int i = 0; i < 2; ++i) {
      place(g, plans_[gi], r, i, s);
      distance[i] = 0.0;
      for (int k = 0; k < 2; ++k) {
        if (g.link[k] < 0) continue;
        const BodyMotion& a = s.motion[g.link[k]];
        const BodyMotion& b = drawn[g.link[k]];
        distance[i] += (a.r - b.r).norm() + size_ * std::abs(a.theta - b.theta);
      }
      for (int k = 0; k < 2; ++k)
        if (g.link[k] >= 0) s.motion[g.link[k]] = drawn[g.link[k]];
    }
    s.assembly_mode[gi] = distance[0] <= distance[1] ? 1 : -1;
  }
}

// Two roots of a group closer than this (times the size) are not told apart.
constexpr double kCoincident = 1e-6;

SolveReport DyadSolver::solve_position(DyadState& s) const {
  SolveReport report;
  report.rcond = 1.0;
  s.mode_changes.clear();
  s.smallest_sine = 1.0;
  s.folding_group = -1;
  s.ambiguity = 0.0;
  s.rate_matrix_valid = false;
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  // The prediction is linear in the driver, so unequal steps scale the last difference.
  const double d = s.kinematics.parameter();
  const double last_step = s.previous_driver - s.before_previous_driver;
  const double extrapolation = last_step != 0.0 ? (d - s.previous_driver) / last_step : 1.0;
  Roots r;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    roots(g, plans_[gi], s, r);
    if (r.count == 0) {
      report.status = PoseStatus::cannot_assemble;
      report.message = fmt::format("{} cannot assemble (its loci do not meet)", g.name);
      return report;
    }
    int index = 0;
    Eigen::Vector2d key = r.point[0];
    if (r.count == 2) {
      int& mode = s.assembly_mode[gi];
      index = mode > 0 ? 0 : 1;
      key = r.key(index, size_);
      if (s.history > 0) {
        // Continuity: the root nearest the pose predicted from the last two samples. The squared
        // distances rule out a change; the distances themselves decide one (as always).
        const Eigen::Vector2d predicted =
            s.history > 1
                ? Eigen::Vector2d(s.previous[gi] +
                                  extrapolation * (s.previous[gi] - s.before_previous[gi]))
                : s.previous[gi];
        const Eigen::Vector2d other_key = r.key(1 - index, size_);
        double stay2 = (key - predicted).squaredNorm();
        double other2 = (other_key - predicted).squaredNorm();
        if (other2 < stay2 && std::sqrt(other2) < std::sqrt(stay2)) {
          s.mode_changes.push_back({static_cast<int>(gi), mode, -mode, d});
          mode = -mode;
          index = 1 - index;
          key = other_key;
          std::swap(stay2, other2);
        }
        // Roots closer than round-off lets a double root be resolved (~sqrt(eps) of the size)
        // are one pose: either will do, and the next step's prediction goes on from it.
        if ((other_key - key).norm() > kCoincident * size_)
          s.ambiguity = std::max(s.ambiguity, std::sqrt(stay2 / other2));
      }
    } else if (r.tangent) {
      key = r.key(0, size_);
    }
    place(g, plans_[gi], r, index, s);
    s.before_previous[gi] = s.previous[gi];
    s.previous[gi] = key;
    if (r.count == 2 && r.sine < s.smallest_sine) s.folding_group = static_cast<int>(gi);
    s.smallest_sine = std::min(s.smallest_sine, r.sine);
  }
  s.history = std::min(s.history + 1, 2);
  s.before_previous_driver = s.previous_driver;
  s.previous_driver = d;
  report.rcond = s.smallest_sine;
  if (s.smallest_sine < singular_sine_) {
    report.status = PoseStatus::singular;
    report.message = fmt::format("two assemblies of a group meet (sine {:.2e})", s.smallest_sine);
  }
  publish_position(s);
  return report;
}

// Link i of group g moves with one unknown rate x of its own tie (omega about a pin, or the slide
// rate along a slot); its velocity is affine in x and the rest of it does not depend on x (nor on
// the group's other link): the pin's velocity, or the slider's motion along and across its slot
// with the link's own translation taken as zero. The same for accelerations.
struct DyadSolver::Rate {
  BodyMotion* link = nullptr;
  bool pinned = false, fixed = false;             // fixed: its angle tie gives its rate (x unused)
  double angular = 0.0;                           // fixed: omega or alpha from the angle tie
  Eigen::Vector2d pin = Eigen::Vector2d::Zero();  // pinned: the pin's velocity or acceleration
  Eigen::Vector2d arm = Eigen::Vector2d::Zero();  // pinned: the pin's offset, turned to world axes
  Eigen::Vector2d w = Eigen::Vector2d::Zero();    // sliding: the slot's world direction
  double along = 0.0, across = 0.0, sign = 1.0;   // sliding: the slot's rates at zero slide

  // Sets the link's omega and v (velocity) or alpha and a (acceleration) at unknown x.
  void velocity(double x) const {
    BodyMotion& u = *link;
    if (pinned) {
      u.omega = fixed ? angular : x;
      u.v = pin - u.omega * perp(arm);
      return;
    }
    u.omega = angular;
    u.v = sign * ((x - along) * w - across * perp(w));
  }
  void acceleration(double x) const {
    BodyMotion& u = *link;
    if (pinned) {
      u.alpha = fixed ? angular : x;
      u.a = pin - (u.alpha * perp(arm) - u.omega * u.omega * arm);
      return;
    }
    u.alpha = angular;
    u.a = sign * ((x - along) * w - across * perp(w));
  }
};

DyadSolver::Rate DyadSolver::prepare_rate(const AssurGroup& g, const Plan& plan, int i, bool accel,
                                          DyadState& s) const {
  const Mechanism& m = mechanism_;
  const Plan::Side& side = plan.side[i];
  Rate rate;
  BodyMotion& u = s.motion[g.link[i]];
  rate.link = &u;
  if (side.has_angle) {
    rate.fixed = true;
    rate.angular = angle_state(mechanism_, side.angle, s)(accel ? 2 : 1);
  }
  if (side.has_pin) {
    // About the pin: omega from the angle tie or the unknown rate.
    rate.pinned = true;
    rate.pin = pin_rate(m, side.pin, side.pin_known, accel, s);
    rate.arm = u.turn(side.pin_local);
    return rate;
  }
  // Along the slot at the unknown slide rate, with no motion across it. project's accel carries
  // the Coriolis term 2 w' . d' of a slide on a turning line.
  const Tie& t = g.ties[i][g.slot[i]];
  const SlotGeometry sg = slot_of(m, t.joint);
  if (accel) {
    u.alpha = rate.angular;
    u.a.setZero();
  } else {
    u.omega = rate.angular;
    u.v.setZero();
  }
  const BodyMotion& guide = s.motion[sg.guide];
  const BodyMotion& slider = s.motion[sg.slider];
  const Projection along = project(guide, sg.line->origin, sg.line->direction, slider, sg.point);
  const Projection across =
      project(guide, sg.line->origin, perp(sg.line->direction), slider, sg.point);
  rate.along = accel ? along.accel : along.rate;
  rate.across = accel ? across.accel : across.rate;
  rate.w = guide.turn(sg.line->direction);
  rate.sign = t.slider_is_unplaced ? 1.0 : -1.0;
  return rate;
}

Eigen::Vector2d DyadSolver::rate_residual(const AssurGroup& g, const DyadState& s,
                                          bool accel) const {
  const Mechanism& m = mechanism_;
  auto slot_rate = [&](int joint) {
    const SlotGeometry sg = slot_of(m, joint);
    const Projection p = project(s.motion[sg.guide], sg.line->origin, perp(sg.line->direction),
                                 s.motion[sg.slider], sg.point);
    return accel ? p.accel : p.rate;
  };
  if (g.kind != AssurGroup::Kind::dyad)
    return {g.equation >= 0 ? slot_rate(g.ties[0][g.equation].joint) : 0.0, 0.0};
  const Joint& j = m.joints[g.inner];
  const BodyMotion& a = s.motion[j.link_a];
  const BodyMotion& b = s.motion[j.link_b];
  if (j.type == JointType::revolute) {
    const Eigen::Vector2d& pa = m.links[j.link_a].points[j.point_a].local;
    const Eigen::Vector2d& pb = m.links[j.link_b].points[j.point_b].local;
    return accel ? Eigen::Vector2d(a.acceleration(pa) - b.acceleration(pb))
                 : Eigen::Vector2d(a.velocity(pa) - b.velocity(pb));
  }
  return {accel ? b.alpha - a.alpha : b.omega - a.omega, slot_rate(g.inner)};
}

// The group's rate equations are affine in its unknowns x: f(x) = J x + f(0). J's columns are
// read off f at unit unknowns, then J x = -f(0) is solved (2x2 by Cramer's rule, 1x1 directly).
// Velocity and acceleration share J (the acceleration's f(0) holds the velocity-squared and
// Coriolis terms): `known` says that `j` already holds it (from the velocity solve at this
// pose), else it is read off here. `set(i, x)` moves link i at unknown x.
template <typename Set, typename Residual>
static void solve_rates(int n, Set set, Residual residual, Eigen::Matrix2d& j, bool known) {
  if (n == 0) {
    set(0, 0.0);
    return;
  }
  for (int i = 0; i < n; ++i) set(i, 0.0);
  const Eigen::Vector2d f0 = residual();
  if (!known) {
    j.setIdentity();
    for (int k = 0; k < n; ++k) {
      set(k, 1.0);
      j.col(k) = residual() - f0;
      set(k, 0.0);
    }
  }
  if (n == 1) {
    set(0, -f0(0) / j(0, 0));
    return;
  }
  const double det = j(0, 0) * j(1, 1) - j(0, 1) * j(1, 0);
  set(0, (-f0(0) * j(1, 1) + f0(1) * j(0, 1)) / det);
  set(1, (-f0(1) * j(0, 0) + f0(0) * j(1, 0)) / det);
}

// An RRR dyad's rates in closed form (what solve_rates reads off by probing, without it): each
// link turns about its pin P_i at omega_i, and the inner joint C moves alike on both,
//   v_P0 + omega_0 perp(e_0) = v_P1 + omega_1 perp(e_1)      e_i = C - P_i (world)
//   a_P0 + alpha_0 perp(e_0) - omega_0^2 e_0 = a_P1 + alpha_1 perp(e_1) - omega_1^2 e_1,
// one 2x2 matrix [perp(e_0), -perp(e_1)] for both, solved by Cramer's rule.
void DyadSolver::rrr_rates(const AssurGroup& g, const Plan& plan, bool accel, DyadState& s) const {
  BodyMotion* u[2];
  Eigen::Vector2d arm[2], e[2], pin[2], f[2];
  for (int i = 0; i < 2; ++i) {
    u[i] = &s.motion[g.link[i]];
    arm[i] = u[i]->turn(plan.side[i].pin_local);
    e[i] = u[i]->turn(plan.inner[i]) - arm[i];
    pin[i] = pin_rate(mechanism_, plan.side[i].pin, plan.side[i].pin_known, accel, s);
    f[i] = accel ? Eigen::Vector2d(pin[i] - u[i]->omega * u[i]->omega * e[i]) : pin[i];
  }
  const Eigen::Vector2d j0 = perp(e[0]), j1 = -perp(e[1]), f0 = f[0] - f[1];
  const double det = j0.x() * j1.y() - j1.x() * j0.y();
  const double x[2] = {(-f0.x() * j1.y() + f0.y() * j1.x()) / det,
                       (-f0.y() * j0.x() + f0.x() * j0.y()) / det};
  for (int i = 0; i < 2; ++i) {
    BodyMotion& b = *u[i];
    if (accel) {
      b.alpha = x[i];
      b.a = pin[i] - (b.alpha * perp(arm[i]) - b.omega * b.omega * arm[i]);
    } else {
      b.omega = x[i];
      b.v = pin[i] - b.omega * perp(arm[i]);
    }
  }
}

// An input link (a pin and an angle tie, no unknown): what prepare_rate and Rate give at x
// unused, without them.
void DyadSolver::input_rates(const AssurGroup& g, const Plan& plan, bool accel,
                             DyadState& s) const {
  const Plan::Side& side = plan.side[0];
  const Tie& t = side.angle;
  const DriverState& d = tie_driver(mechanism_, t, s);
  BodyMotion& u = s.motion[g.link[0]];
  double angular = t.driver_sign * (accel ? d.accel : d.rate);
  if (t.known >= 0)
    angular += t.known_scale * (accel ? s.motion[t.known].alpha : s.motion[t.known].omega);
  if (t.second >= 0)
    angular += t.second_scale * (accel ? s.motion[t.second].alpha : s.motion[t.second].omega);
  if (t.rack >= 0) {
    const Projection travel = rack_travel(mechanism_, t.rack, s);
    angular += t.travel_scale * (accel ? travel.accel : travel.rate);
  }
  const Eigen::Vector2d pin = pin_rate(mechanism_, side.pin, side.pin_known, accel, s);
  const Eigen::Vector2d arm = u.turn(side.pin_local);
  if (accel) {
    u.alpha = angular;
    u.a = pin - (u.alpha * perp(arm) - u.omega * u.omega * arm);
  } else {
    u.omega = angular;
    u.v = pin - u.omega * perp(arm);
  }
}

void DyadSolver::solve_velocity(DyadState& s) const {
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    const Plan& plan = plans_[gi];
    if (plan.rrr) {
      rrr_rates(g, plan, false, s);
      continue;
    }
    if (plan.input) {
      input_rates(g, plan, false, s);
      continue;
    }
    Rate rate[2];
    for (int i = 0; i < 2; ++i)
      if (g.link[i] >= 0) rate[i] = prepare_rate(g, plan, i, false, s);
    solve_rates(
        plan.unknowns, [&](int i, double x) { rate[i].velocity(x); },
        [&] { return rate_residual(g, s, false); }, s.rate_matrix[gi], false);
  }
  s.rate_matrix_valid = true;
  publish_velocity(s);
}

void DyadSolver::solve_acceleration(DyadState& s) const {
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  const bool known = s.rate_matrix_valid;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    const Plan& plan = plans_[gi];
    if (plan.rrr) {
      rrr_rates(g, plan, true, s);
      continue;
    }
    if (plan.input) {
      input_rates(g, plan, true, s);
      continue;
    }
    Rate rate[2];
    for (int i = 0; i < 2; ++i)
      if (g.link[i] >= 0) rate[i] = prepare_rate(g, plan, i, true, s);
    solve_rates(
        plan.unknowns, [&](int i, double x) { rate[i].acceleration(x); },
        [&] { return rate_residual(g, s, true); }, s.rate_matrix[gi], known);
  }
  publish_acceleration(s);
}

SolveReport DyadSolver::solve(DyadState& s) const {
  SolveReport report = solve_position(s);
  if (report.status == PoseStatus::ok) {
    solve_velocity(s);
    solve_acceleration(s);
  } else {
    s.kinematics.qdot.setZero();
    s.kinematics.qddot.setZero();
  }
  return report;
}

// Each copies one of q, qdot, qddot: a pose copies each once.
void DyadSolver::publish_position(DyadState& s) const {
  Eigen::VectorXd& q = s.kinematics.q;
  for (const auto& [l, i] : moving_) {
    const BodyMotion& b = s.motion[static_cast<size_t>(l)];
    q(3 * i) = b.r.x(), q(3 * i + 1) = b.r.y(), q(3 * i + 2) = b.theta;
  }
}
void DyadSolver::publish_velocity(DyadState& s) const {
  Eigen::VectorXd& qdot = s.kinematics.qdot;
  for (const auto& [l, i] : moving_) {
    const BodyMotion& b = s.motion[static_cast<size_t>(l)];
    qdot(3 * i) = b.v.x(), qdot(3 * i + 1) = b.v.y(), qdot(3 * i + 2) = b.omega;
  }
}
void DyadSolver::publish_acceleration(DyadState& s) const {
  Eigen::VectorXd& qddot = s.kinematics.qddot;
  for (const auto& [l, i] : moving_) {
    const BodyMotion& b = s.motion[static_cast<size_t>(l)];
    qddot(3 * i) = b.a.x(), qddot(3 * i + 1) = b.a.y(), qddot(3 * i + 2) = b.alpha;
  }
}

std::string DyadSolver::describe_mode(int group, int mode) const {
  const AssurGroup& g = decomposition_.groups[static_cast<size_t>(group)];
  const char* sign = mode > 0 ? "+1" : "-1";
  if (g.kind == AssurGroup::Kind::pivot_slot || g.pin[0] < 0 || g.pin[1] < 0 ||
      mechanism_.joints[g.inner].type != JointType::revolute)
    return fmt::format("{} ({} root)", sign, mode > 0 ? "first" : "second");
  return fmt::format("{} (inner joint {} of the line between the pins)", sign,
                     mode > 0 ? "left" : "right");
}

}  // namespace crosslink
