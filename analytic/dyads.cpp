#include "analytic/dyads.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}
double angle_of(const Eigen::Vector2d& v) {
  return std::atan2(v.y(), v.x());
}

void set_angle(BodyMotion& m, double theta) {
  m.theta = theta;
  const double c = std::cos(theta), s = std::sin(theta);
  m.rotation << c, -s, s, c;
}

// The angle nearest `previous` that equals `raw` modulo 2 pi (angles are unwrapped along a sweep).
double unwrap(double raw, double previous) {
  return previous + std::remainder(raw - previous, 2.0 * kPi);
}

// Angle of the driver's measured arm in its link's frame (the driver row of newton.cpp).
double arm_angle(const Mechanism& m) {
  const Driver& d = m.driver;
  if (d.from < 0 || d.to < 0) return 0.0;
  return angle_of(m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local);
}

int equations(const Tie& t) {
  return t.kind == Tie::Kind::pin ? 2 : 1;
}

// The ties of unplaced link u to placed links, from unused joints and the driver.
std::vector<Tie> ties_of(const Mechanism& m, int u, const std::vector<char>& placed,
                         const std::vector<char>& used) {
  const Driver& d = m.driver;
  std::vector<Tie> ties;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    const int other = j.link_a == u ? j.link_b : j.link_b == u ? j.link_a : -1;
    if (used[ji] || other < 0 || !placed[other]) continue;
    const int joint = static_cast<int>(ji);
    if (j.type == JointType::revolute) {
      Tie pin{.kind = Tie::Kind::pin, .joint = joint, .known = other};
      pin.on_known = j.link_a == other ? j.point_a : j.point_b;
      pin.on_link = j.link_a == u ? j.point_a : j.point_b;
      ties.push_back(pin);
      if (d.type == DriverType::joint_angle && d.joint == joint) {
        // Newton's driver row: theta_b + arm - theta_a = value.
        Tie angle{.kind = Tie::Kind::angle, .joint = joint, .known = other};
        angle.offset = u == j.link_b ? -arm_angle(m) : arm_angle(m);
        angle.driver_sign = u == j.link_b ? 1.0 : -1.0;
        ties.push_back(angle);
      }
      continue;
    }
    if (d.type == DriverType::slider && d.joint == joint) {
      // The driven slider's point sits at s = driver along the placed guide: a moving pin. (A
      // placed slider does not place its guide this way: the joint stays unused.)
      if (u != j.link_b) continue;
      Tie pin{.kind = Tie::Kind::pin, .joint = joint, .known = other};
      pin.line = j.line;
      pin.on_link = j.point_b;
      pin.driver_slide = true;
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
  if (d.type == DriverType::link_angle && d.link == u)
    ties.push_back(Tie{.kind = Tie::Kind::angle,
                       .joint = -1,
                       .known = -1,
                       .offset = -arm_angle(m),
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
        text += fmt::format("pin on {}", known);
        break;
      case Tie::Kind::angle:
        text += t.joint < 0 ? "driven angle" : fmt::format("angle from {}", known);
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
      for (const Tie& t : g.ties[i])
        if (t.joint >= 0) used[static_cast<size_t>(t.joint)] = 1;
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
      if (used[ji] || j.type == JointType::pin_in_slot) continue;
      if (placed[static_cast<size_t>(j.link_a)] || placed[static_cast<size_t>(j.link_b)]) continue;
      if (m.driver.joint == static_cast<int>(ji) && m.driver.type != DriverType::link_angle)
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
    if (m.driver.type == DriverType::link_angle && !placed[static_cast<size_t>(m.driver.link)])
      why = fmt::format(
          "the driver turns the floating link '{}', whose angle alone does not "
          "place it, so the chain cannot be solved outward from the driver",
          m.links[m.driver.link].name);
    out.reason = fmt::format(
        "no dyad or single link can be placed after {{{}}}; unplaced: {}. {}: left to Newton",
        placed_names, left, why);
    return out;
  }
  for (size_t ji = 0; ji < m.joints.size(); ++ji)
    if (!used[ji]) {
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

DyadSolver::DyadSolver(const Mechanism& mechanism, Decomposition decomposition,
                       double singular_sine)
    : mechanism_(mechanism),
      decomposition_(std::move(decomposition)),
      size_(mechanism.size()),
      singular_sine_(singular_sine) {
  if (!decomposition_.complete)
    throw std::invalid_argument("the chain does not decompose into dyads: " +
                                decomposition_.reason);
}

// Both solutions of one group: the point its loci meet at (or a tangent line's angle).
struct DyadSolver::Roots {
  int count = 0;  // 0: cannot assemble; 1: one solution; 2: two
  Eigen::Vector2d point[2] = {Eigen::Vector2d::Zero(),
                              Eigen::Vector2d::Zero()};  // the solved
                                                         // point (circle or line crossings)
  double angle[2] = {0.0, 0.0};                          // tangent: the guide's angle
  bool tangent = false;                                  // the roots are angles
  double sine = 1.0;  // how far from the two roots meeting (0: they meet)
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
struct PinState {
  Eigen::Vector2d p, v, a;
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

PinState pin_state(const Mechanism& m, const Tie& t, const DyadState& s) {
  const BodyMotion& k = s.motion[t.known];
  if (!t.driver_slide) {
    const Eigen::Vector2d& local = m.links[t.known].points[t.on_known].local;
    return {k.position(local), k.velocity(local), k.acceleration(local)};
  }
  const Line& line = m.links[t.known].lines[t.line];
  const DriverState& d = s.kinematics.driver;
  const Eigen::Vector2d local = line.origin + d.value * line.direction;
  return {k.position(local), k.velocity(local) + d.rate * k.turn(line.direction),
          k.acceleration(local) + 2.0 * d.rate * k.turn_rate(line.direction) +
              d.accel * k.turn(line.direction)};
}

// theta, omega, alpha of a link from its angle tie.
Eigen::Vector3d angle_state(const Tie& t, const DyadState& s) {
  const DriverState& d = s.kinematics.driver;
  Eigen::Vector3d a(t.offset + t.driver_sign * d.value, t.driver_sign * d.rate,
                    t.driver_sign * d.accel);
  if (t.known >= 0) {
    const BodyMotion& k = s.motion[t.known];
    a += Eigen::Vector3d(k.theta, k.omega, k.alpha);
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

void DyadSolver::roots(const AssurGroup& g, DyadState& s, Roots& r) const {
  const Mechanism& m = mechanism_;
  r = Roots{};
  // Links with an angle tie get their angle first (it is unique).
  for (int i = 0; i < 2; ++i)
    if (g.link[i] >= 0 && g.angle[i] >= 0)
      set_angle(s.motion[g.link[i]], angle_state(g.ties[i][g.angle[i]], s)(0));
  auto local = [&](int i, int point) -> const Eigen::Vector2d& {
    return m.links[g.link[i]].points[point].local;
  };
  auto pin_local = [&](int i) -> const Eigen::Vector2d& {
    return local(i, g.ties[i][g.pin[i]].on_link);
  };
  auto pin_world = [&](int i) { return pin_state(m, g.ties[i][g.pin[i]], s).p; };

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
        r.count = circle_line(a, (sg.point - pin_local(0)).norm(),
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
      r.count = circle_circle(pin_world(0), (c0 - pin_local(0)).norm(), pin_world(1),
                              (c1 - pin_local(1)).norm(), r.point, r.sine);
    } else if (pivot0 != pivot1) {
      const int p = pivot0 ? 0 : 1, l = 1 - p;
      const Eigen::Vector2d& c = p == 0 ? c0 : c1;
      r.count = circle_line(pin_world(p), (c - pin_local(p)).norm(),
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

void DyadSolver::place(const AssurGroup& g, const Roots& r, int index, DyadState& s) const {
  const Mechanism& m = mechanism_;
  const Eigen::Vector2d& x0 = r.point[index];
  auto local = [&](int i, int point) -> const Eigen::Vector2d& {
    return m.links[g.link[i]].points[point].local;
  };
  auto pin_local = [&](int i) -> const Eigen::Vector2d& {
    return local(i, g.ties[i][g.pin[i]].on_link);
  };
  auto pin_world = [&](int i) { return pin_state(m, g.ties[i][g.pin[i]], s).p; };
  // A pinned link through world point `at` of its local point `x`.
  auto turn_to = [&](int i, const Eigen::Vector2d& x, const Eigen::Vector2d& at) {
    BodyMotion& u = s.motion[g.link[i]];
    const Eigen::Vector2d a = pin_world(i);
    set_angle(u, unwrap(angle_of(at - a) - angle_of(x - pin_local(i)), u.theta));
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
        turn_to(0, slot_of(m, g.ties[0][g.equation].joint).point, x0);
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
        turn_to(i, c[i], x0);
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
  s.kinematics.driver = assembled.driver;
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  s.assembly_mode.assign(groups.size(), 0);
  s.previous.assign(groups.size(), Eigen::Vector2d::Zero());
  s.before_previous = s.previous;
  s.history = 0;
  // Each two-solution group takes the root nearest the assembled pose of its links.
  const std::vector<BodyMotion> drawn = s.motion;
  Roots r;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    if (!g.two_solutions) continue;
    roots(g, s, r);
    if (r.count < 2) {
      s.assembly_mode[gi] = 1;
      continue;
    }
    double distance[2];
    for (int i = 0; i < 2; ++i) {
      place(g, r, i, s);
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

SolveReport DyadSolver::solve_position(DyadState& s) const {
  SolveReport report;
  report.rcond = 1.0;
  s.mode_changes.clear();
  s.smallest_sine = 1.0;
  const std::vector<AssurGroup>& groups = decomposition_.groups;
  Roots r;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const AssurGroup& g = groups[gi];
    roots(g, s, r);
    if (r.count == 0) {
      report.status = PoseStatus::cannot_assemble;
      report.message = fmt::format("{} cannot assemble (its loci do not meet)", g.name);
      return report;
    }
    int index = 0;
    if (r.count == 2) {
      int& mode = s.assembly_mode[gi];
      index = mode > 0 ? 0 : 1;
      if (s.history > 0) {
        // Continuity: the root nearest the pose predicted from the last two samples.
        const Eigen::Vector2d predicted =
            s.history > 1 ? Eigen::Vector2d(2.0 * s.previous[gi] - s.before_previous[gi])
                          : s.previous[gi];
        const double stay = (r.key(index, size_) - predicted).norm();
        const double other = (r.key(1 - index, size_) - predicted).norm();
        if (other < stay) {
          s.mode_changes.push_back({static_cast<int>(gi), mode, -mode});
          mode = -mode;
          index = 1 - index;
        }
      }
    }
    place(g, r, index, s);
    s.before_previous[gi] = s.previous[gi];
    s.previous[gi] = r.key(index, size_);
    s.smallest_sine = std::min(s.smallest_sine, r.sine);
  }
  s.history = std::min(s.history + 1, 2);
  report.rcond = s.smallest_sine;
  if (s.smallest_sine < singular_sine_) {
    report.status = PoseStatus::singular;
    report.message = fmt::format("two assemblies of a group meet (sine {:.2e})", s.smallest_sine);
  }
  publish(s);
  return report;
}

void DyadSolver::set_rate(const AssurGroup& g, int i, double rate, DyadState& s) const {
  const Mechanism& m = mechanism_;
  BodyMotion& u = s.motion[g.link[i]];
  if (g.pin[i] >= 0) {
    // About the pin: omega from the angle tie or the unknown rate.
    u.omega = g.angle[i] >= 0 ? angle_state(g.ties[i][g.angle[i]], s)(1) : rate;
    u.v = pin_state(m, g.ties[i][g.pin[i]], s).v -
          u.turn_rate(m.links[g.link[i]].points[g.ties[i][g.pin[i]].on_link].local);
    return;
  }
  // Along the slot at slide rate `rate`, with no motion across it.
  const Tie& t = g.ties[i][g.slot[i]];
  const SlotGeometry sg = slot_of(m, t.joint);
  u.omega = angle_state(g.ties[i][g.angle[i]], s)(1);
  u.v.setZero();
  const BodyMotion& guide = s.motion[sg.guide];
  const BodyMotion& slider = s.motion[sg.slider];
  const double along = project(guide, sg.line->origin, sg.line->direction, slider, sg.point).rate;
  const double across =
      project(guide, sg.line->origin, perp(sg.line->direction), slider, sg.point).rate;
  const Eigen::Vector2d w = guide.turn(sg.line->direction);
  u.v = (t.slider_is_unplaced ? 1.0 : -1.0) * ((rate - along) * w - across * perp(w));
}

void DyadSolver::set_accel(const AssurGroup& g, int i, double accel, DyadState& s) const {
  const Mechanism& m = mechanism_;
  BodyMotion& u = s.motion[g.link[i]];
  if (g.pin[i] >= 0) {
    u.alpha = g.angle[i] >= 0 ? angle_state(g.ties[i][g.angle[i]], s)(2) : accel;
    u.a = pin_state(m, g.ties[i][g.pin[i]], s).a -
          u.turn_accel(m.links[g.link[i]].points[g.ties[i][g.pin[i]].on_link].local);
    return;
  }
  const Tie& t = g.ties[i][g.slot[i]];
  const SlotGeometry sg = slot_of(m, t.joint);
  u.alpha = angle_state(g.ties[i][g.angle[i]], s)(2);
  u.a.setZero();
  const BodyMotion& guide = s.motion[sg.guide];
  const BodyMotion& slider = s.motion[sg.slider];
  // project's accel carries the Coriolis term 2 w' . d' of a slide on a turning line.
  const double along = project(guide, sg.line->origin, sg.line->direction, slider, sg.point).accel;
  const double across =
      project(guide, sg.line->origin, perp(sg.line->direction), slider, sg.point).accel;
  const Eigen::Vector2d w = guide.turn(sg.line->direction);
  u.a = (t.slider_is_unplaced ? 1.0 : -1.0) * ((accel - along) * w - across * perp(w));
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

namespace {
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
}  // namespace

// The group's rate equations are affine in its unknowns x: f(x) = J x + f(0). J's columns are
// read off f at unit unknowns, then J x = -f(0) is solved (2x2 by Cramer's rule, 1x1 directly).
// Velocity and acceleration share J; the acceleration's f(0) holds the velocity-squared and
// Coriolis terms.
template <typename Set, typename Residual>
static Eigen::Vector2d solve_rates(int n, Set set, Residual residual) {
  for (int i = 0; i < n; ++i) set(i, 0.0);
  if (n == 0) {
    set(0, 0.0);
    return Eigen::Vector2d::Zero();
  }
  const Eigen::Vector2d f0 = residual();
  Eigen::Matrix2d j = Eigen::Matrix2d::Identity();
  for (int k = 0; k < n; ++k) {
    set(k, 1.0);
    j.col(k) = residual() - f0;
    set(k, 0.0);
  }
  Eigen::Vector2d x;
  if (n == 1) {
    x << -f0(0) / j(0, 0), 0.0;
  } else {
    const double det = j(0, 0) * j(1, 1) - j(0, 1) * j(1, 0);
    x << (-f0(0) * j(1, 1) + f0(1) * j(0, 1)) / det, (-f0(1) * j(0, 0) + f0(0) * j(1, 0)) / det;
  }
  for (int i = 0; i < n; ++i) set(i, x(i));
  return x;
}

void DyadSolver::solve_velocity(DyadState& s) const {
  for (const AssurGroup& g : decomposition_.groups)
    solve_rates(
        unknowns(g), [&](int i, double v) { set_rate(g, i, v, s); },
        [&] { return rate_residual(g, s, false); });
  publish(s);
}

void DyadSolver::solve_acceleration(DyadState& s) const {
  for (const AssurGroup& g : decomposition_.groups)
    solve_rates(
        unknowns(g), [&](int i, double v) { set_accel(g, i, v, s); },
        [&] { return rate_residual(g, s, true); });
  publish(s);
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

void DyadSolver::publish(DyadState& s) const {
  const Mechanism& m = mechanism_;
  KinematicState& k = s.kinematics;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int i = m.moving_index(static_cast<int>(l));
    if (i < 0) continue;
    const BodyMotion& b = s.motion[l];
    k.q.segment<3>(3 * i) << b.r, b.theta;
    k.qdot.segment<3>(3 * i) << b.v, b.omega;
    k.qddot.segment<3>(3 * i) << b.a, b.alpha;
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

Trajectory dyad_sweep(const Mechanism& mechanism, const Trajectory& grid) {
  const Driver& d = mechanism.driver;
  Trajectory out;
  out.method = "dyads";
  out.resize(mechanism, grid.samples());
  out.time = grid.time;
  out.driver = grid.driver;
  Decomposition decomposition = decompose(mechanism);
  const NewtonSolver newton(mechanism);
  KinematicState assembled(mechanism);
  const SolveReport start = newton.assemble(assembled);
  PoseStatus failure = PoseStatus::ok;
  std::string why;
  if (!decomposition.complete) {
    failure = PoseStatus::no_convergence;
    why = "does not decompose into dyads: " + decomposition.reason;
  } else if (start.status != PoseStatus::ok && start.status != PoseStatus::singular) {
    failure = start.status;
    why = start.message;
  }
  if (failure != PoseStatus::ok) {
    out.status.assign(static_cast<size_t>(out.samples()), failure);
    out.events.push_back({d.start, failure, why});
    return out;
  }
  const DyadSolver solver(mechanism, std::move(decomposition));
  DyadState state(mechanism);
  solver.set_modes(assembled, state);

  auto driver_at = [&](int row) {
    DriverState s = d.at_time(grid.time(row));
    s.value = grid.driver(row);
    return s;
  };
  auto solve_row = [&](int row) {
    state.kinematics.driver = driver_at(row);
    const SolveReport r = solver.solve(state);
    for (const DyadState::ModeChange& c : state.mode_changes)
      out.events.push_back(
          {grid.driver(row), PoseStatus::singular,
           fmt::format("assembly mode of {} changes from {} to {}: its two assemblies meet "
                       "here and the motion is followed continuously",
                       solver.decomposition().groups[static_cast<size_t>(c.group)].name,
                       solver.describe_mode(c.group, c.from),
                       solver.describe_mode(c.group, c.to))});
    if (r.status == PoseStatus::cannot_assemble &&
        (out.events.empty() || out.events.back().kind != PoseStatus::cannot_assemble))
      out.events.push_back({grid.driver(row), r.status, r.message});
    if (r.status == PoseStatus::cannot_assemble) {
      state.kinematics.q.setZero();
      state.kinematics.qdot.setZero();
      state.kinematics.qddot.setZero();
    }
    newton.write_sample(state.kinematics, r, out, row);
  };
  if (grid.samples() == 0) return out;

  // From the sample nearest the start value (reached in steps no longer than the grid's) forward,
  // then from it backward.
  int first = 0;
  for (int i = 1; i < grid.samples(); ++i)
    if (std::abs(grid.driver(i) - d.start) < std::abs(grid.driver(first) - d.start)) first = i;
  // One sample (a single driver value): march in 1 degree (or size / 50) steps.
  const double step = grid.samples() > 1 ? std::abs(grid.driver(1) - grid.driver(0))
                      : d.angular()      ? kPi / 180.0
                                         : mechanism.size() / 50.0;
  if (step > 0.0) {
    const double gap = grid.driver(first) - d.start;
    const int substeps = static_cast<int>(std::ceil(std::abs(gap) / step));
    for (int k = 1; k < substeps; ++k) {
      state.kinematics.driver.value = d.start + gap * k / substeps;
      solver.solve_position(state);
    }
  }
  solve_row(first);
  const DyadState at_first = state;
  for (int i = first + 1; i < grid.samples(); ++i) solve_row(i);
  state = at_first;
  for (int i = first - 1; i >= 0; --i) solve_row(i);
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const auto& a, const auto& b) { return a.driver < b.driver; });
  return out;
}

Trajectory dyad_sweep(const Mechanism& mechanism, const SweepOptions& options) {
  return dyad_sweep(mechanism, sweep(mechanism, options));
}

}  // namespace crosslink
