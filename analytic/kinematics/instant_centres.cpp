#include "analytic/kinematics/instant_centres.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "analytic/model/constraints.h"
#include "analytic/model/planar.h"

namespace crosslink {

std::string_view to_string(InstantCentre::Found found) {
  switch (found) {
    case InstantCentre::Found::primary:
      return "primary";
    case InstantCentre::Found::kennedy:
      return "Kennedy";
    case InstantCentre::Found::velocity:
      return "from velocities";
    case InstantCentre::Found::none:
      return "not placed";
  }
  return "?";
}

namespace {

// Pair (i, j) -> index into InstantCentres::centres.
int pair_index(int n, int i, int j) {
  if (i > j) std::swap(i, j);
  return i * n - i * (i + 1) / 2 + (j - i - 1);
}

// A homogeneous point normalised: w = 1, or w = 0 with a unit direction. A point farther than
// 1e9 mechanism sizes is taken to be at infinity.
Eigen::Vector3d normalise_point(const Eigen::Vector3d& p, double size) {
  if (std::abs(p.z()) * 1e9 * size > p.head<2>().norm()) return p / p.z();
  return Eigen::Vector3d(p.x(), p.y(), 0.0) / p.head<2>().norm();
}

// A homogeneous line (a, b, c): a x + b y + c w = 0, with (a, b) a unit normal.
Eigen::Vector3d normalise_line(const Eigen::Vector3d& l) {
  return l / l.head<2>().norm();
}

// A line known to carry a centre: a slot normal, or the Kennedy line through two centres.
struct Line2 {
  Eigen::Vector3d l;     // homogeneous, unit normal (normalise_line)
  double quality = 1.0;  // how well its direction is known: the centres' distance apart
                         // relative to the mechanism's size (1 for a slot normal)
  std::string how;
};

// A line through two centres closer than this (relative to the size) is not used: its direction
// is rounding. A crossing (sine of the angle between the lines, or their distance apart when
// parallel, times the lines' quality) must be better than kMinCrossing.
constexpr double kMinLineQuality = 1e-9;
constexpr double kMinCrossing = 1e-9;

std::string label(int i, int j) {
  return fmt::format("I({},{})", i + 1, j + 1);
}

BodyMotion motion_of(const Mechanism& m, int link, const Eigen::VectorXd& q,
                     const Eigen::VectorXd* qdot) {
  return BodyMotion::of(m.moving_index(link), q, qdot, nullptr);
}

// A link's velocity field v(P) = v0 + omega perp(P), and how well it is known: the worst
// conditioning (1 = perfect, see follow) of the ratios it was found through.
struct Field {
  bool known = false;
  bool from_geometry = true;
  Eigen::Vector2d v0 = Eigen::Vector2d::Zero();
  double omega = 0.0;
  double quality = 1.0;
  Eigen::Vector2d at(const Eigen::Vector2d& p) const { return v0 + omega * perp(p); }
};

// Below this conditioning a ratio is 0/0 to rounding (coincident centres) and is not used; at
// or above kGoodQuality it loses at most ~1e6 ulp, and a geometric pair is preferred there.
constexpr double kMinQuality = 1e-9;
constexpr double kGoodQuality = 1e-6;

// Link k's field from a known link j's through I(1,k) (`fixed`) and I(j,k) (`common`): I(j,k)
// moves alike on j and k, and k turns about I(1,k) (translates when it is at infinity). Returns
// the conditioning of the step: the distance I(1,k)I(j,k) that divides, relative to the size
// of the mechanism and of the coordinates (whose rounding moves the centres), or the sine
// between the two directions when both centres are at infinity; 0 when there is no ratio.
double follow(const Field& fj, const InstantCentre& fixed, const InstantCentre& common, double size,
              Field& fk) {
  if (!common.at_infinity()) {
    // I(j,k) has one velocity on both links.
    const Eigen::Vector2d p = common.position(), v = fj.at(p);
    if (fixed.at_infinity()) {
      fk.v0 = v;  // k translates
      return size / std::max(size, p.norm());
    }
    const Eigen::Vector2d arm = p - fixed.position();
    const double quality = arm.norm() / std::max({size, p.norm(), fixed.position().norm()});
    if (!(quality > 0.0)) return 0.0;
    fk.omega = v.dot(perp(arm)) / arm.squaredNorm();
    fk.v0 = -fk.omega * perp(fixed.position());
    return quality;
  }
  // j and k in relative translation: the same angular velocity.
  fk.omega = fj.omega;
  if (!fixed.at_infinity()) {
    fk.v0 = -fk.omega * perp(fixed.position());
    return size / std::max(size, fixed.position().norm());
  }
  // Both translate: v_k = v_j + t perp(u_jk), with no component along u_1k.
  const Eigen::Vector2d u = common.position(), w = fixed.position();
  const double across = perp(u).dot(w);
  if (across == 0.0) return 0.0;
  fk.v0 = fj.v0 - (fj.v0.dot(w) / across) * perp(u);
  return std::abs(across);
}

}  // namespace

const InstantCentre& InstantCentres::at(int i, int j) const {
  int n = 2;
  while (n * (n - 1) / 2 < static_cast<int>(centres.size())) ++n;
  return centres[static_cast<size_t>(pair_index(n, i, j))];
}

Eigen::VectorXd coordinates_at(const Mechanism& m, const Trajectory& t, int row) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m.coordinate_count());
  const std::vector<Mechanism::NamedPoint> named = m.named_points();
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const double theta = t.angle(row, k);
    // Any point of the link places its frame: r = P - R p.
    const Point& p = m.links[l].points.front();
    size_t c = 0;
    while (named[c].name != p.name) ++c;
    const Eigen::Vector2d world(t.x(row, static_cast<Eigen::Index>(c)),
                                t.y(row, static_cast<Eigen::Index>(c)));
    q.segment<2>(3 * k) = world - Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local;
    q(3 * k + 2) = theta;
  }
  return q;
}

Eigen::VectorXd rates_at(const Mechanism& m, const Trajectory& t, int row) {
  const Eigen::VectorXd q = coordinates_at(m, t, row);
  Eigen::VectorXd qdot = Eigen::VectorXd::Zero(m.coordinate_count());
  const std::vector<Mechanism::NamedPoint> named = m.named_points();
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const double omega = t.omega(row, k);
    const Point& p = m.links[l].points.front();
    size_t c = 0;
    while (named[c].name != p.name) ++c;
    const Eigen::Vector2d v(t.vx(row, static_cast<Eigen::Index>(c)),
                            t.vy(row, static_cast<Eigen::Index>(c)));
    // v_P = v_r + omega perp(R p)
    qdot.segment<2>(3 * k) =
        v - omega * perp(Eigen::Rotation2Dd(q(3 * k + 2)).toRotationMatrix() * p.local);
    qdot(3 * k + 2) = omega;
  }
  return qdot;
}

InstantCentres instant_centres(const Mechanism& m, const Trajectory& exact, int row) {
  const int n = static_cast<int>(m.links.size());
  const double size = m.size();
  const Eigen::VectorXd q = coordinates_at(m, exact, row);
  InstantCentres out;
  out.centres.resize(static_cast<size_t>(n * (n - 1) / 2));
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      InstantCentre& c = out.centres[static_cast<size_t>(pair_index(n, i, j))];
      c.i = i;
      c.j = j;
    }
  // Lines known to carry a centre before Kennedy (slot normals), per pair.
  std::vector<std::vector<Line2>> slot_lines(out.centres.size());

  // Primary centres.
  for (const Joint& jt : m.joints) {
    InstantCentre& c = out.centres[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))];
    const BodyMotion a = motion_of(m, jt.link_a, q, nullptr);
    const BodyMotion b = motion_of(m, jt.link_b, q, nullptr);
    if (jt.is_gearing()) {  // rolling without slip: the pitch point has no relative velocity
      c.found = InstantCentre::Found::primary;
      c.point << motion_of(m, jt.carrier, q, nullptr).position(pitch_point(m, jt)), 1.0;
      c.how = fmt::format("primary: {} {}, at the pitch point", to_string(jt.type), jt.name);
      continue;
    }
    if (jt.type == JointType::revolute) {
      c.found = InstantCentre::Found::primary;
      c.point << a.position(m.links[jt.link_a].points[jt.point_a].local), 1.0;
      c.how = fmt::format("primary: revolute {}", jt.name);
      continue;
    }
    if (jt.type == JointType::pin_in_arc) {  // on the arc's normal at the pin: through its centre
      const Eigen::Vector2d pin = b.position(m.links[jt.link_b].points[jt.point_b].local);
      const Eigen::Vector2d centre = a.position(m.links[jt.link_a].points[jt.centre_a].local);
      slot_lines[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))].push_back(
          {normalise_line(Eigen::Vector3d(pin.x(), pin.y(), 1.0)
                              .cross(Eigen::Vector3d(centre.x(), centre.y(), 1.0))),
           1.0, fmt::format("normal to arc {} at the pin", jt.name)});
      continue;
    }
    if (jt.type == JointType::pin_in_spline) {  // on the slot's normal at the pin
      const Eigen::Vector2d &start = jt.chord_start, &chord = jt.chord_axis;
      const Eigen::Vector2d pin = b.position(m.links[jt.link_b].points[jt.point_b].local);
      const double x = a.turn(chord).dot(pin - a.position(start));
      const Eigen::Vector2d u = a.turn(perp(chord) - jt.slot->at(x).dy * chord);
      slot_lines[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))].push_back(
          {normalise_line(
               Eigen::Vector3d(pin.x(), pin.y(), 1.0).cross(Eigen::Vector3d(u.x(), u.y(), 0.0))),
           1.0, fmt::format("normal to spline slot {} at the pin", jt.name)});
      continue;
    }
    if (jt.type == JointType::cam) {  // on the common normal at the contact
      const CamContact contact = cam_contact(m, jt, a, b);
      const Eigen::Vector2d &p = contact.point, &u = contact.normal;
      slot_lines[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))].push_back(
          {normalise_line(
               Eigen::Vector3d(p.x(), p.y(), 1.0).cross(Eigen::Vector3d(u.x(), u.y(), 0.0))),
           1.0, fmt::format("common normal of cam {} at the contact", jt.name)});
      continue;
    }
    const Eigen::Vector2d direction = a.turn(m.links[jt.link_a].lines[jt.line].direction);
    if (jt.type == JointType::prismatic) {
      c.found = InstantCentre::Found::primary;
      c.point << perp(direction), 0.0;
      c.how = fmt::format("primary: prismatic {}, at infinity normal to its line", jt.name);
      continue;
    }
    // Pin-in-slot: on the normal to the slot at the pin.
    const Eigen::Vector3d pin(b.position(m.links[jt.link_b].points[jt.point_b].local).x(),
                              b.position(m.links[jt.link_b].points[jt.point_b].local).y(), 1.0);
    const Eigen::Vector3d normal_direction(perp(direction).x(), perp(direction).y(), 0.0);
    slot_lines[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))].push_back(
        {normalise_line(pin.cross(normal_direction)), 1.0,
         fmt::format("normal to slot {} at the pin", jt.name)});
  }

  // Kennedy, best first: of every centre not yet placed, the one whose best crossing of two
  // lines is the best-conditioned is placed, then the rest are looked at again with it, until
  // none can be placed. A line through two centres is known only as well as the centres are
  // apart: two centres in one place (to rounding: two links about one ground pivot put I(1,j),
  // I(1,k) and I(j,k) there) give no line, and neither do two centres at infinity.
  auto line_through = [&](const InstantCentre& a, const InstantCentre& b, Line2& line) {
    if (a.at_infinity() && b.at_infinity()) return false;
    const Eigen::Vector3d l = a.point.cross(b.point);
    if (a.at_infinity() || b.at_infinity()) {
      const Eigen::Vector2d p = (a.at_infinity() ? b : a).position();
      line.quality = size / std::max(size, p.norm());
    } else {
      line.quality = (a.position() - b.position()).norm() /
                     std::max({size, a.position().norm(), b.position().norm()});
    }
    if (!(line.quality >= kMinLineQuality)) return false;
    line.l = normalise_line(l);
    return true;
  };
  struct Crossing {
    double strength = 0.0;
    Eigen::Vector3d point;
    std::string how;
  };
  std::vector<Line2> lines;
  auto best_crossing = [&](const InstantCentre& c) {
    lines = slot_lines[static_cast<size_t>(pair_index(n, c.i, c.j))];
    for (int k = 0; k < n; ++k) {
      if (k == c.i || k == c.j) continue;
      const InstantCentre& a = out.centres[static_cast<size_t>(pair_index(n, c.i, k))];
      const InstantCentre& b = out.centres[static_cast<size_t>(pair_index(n, k, c.j))];
      if (!a.placed() || !b.placed() || a.found == InstantCentre::Found::velocity ||
          b.found == InstantCentre::Found::velocity)
        continue;
      Line2 line;
      if (!line_through(a, b, line)) continue;
      line.how = fmt::format("{}-{}", label(std::min(c.i, k), std::max(c.i, k)),
                             label(std::min(k, c.j), std::max(k, c.j)));
      lines.push_back(std::move(line));
    }
    // The best-conditioned crossing of two lines (the same line twice crosses nowhere), each
    // line weighed by how well it is known.
    Crossing best;
    best.strength = kMinCrossing;
    int best_x = -1, best_y = -1;
    for (size_t x = 0; x < lines.size(); ++x)
      for (size_t y = x + 1; y < lines.size(); ++y) {
        const Eigen::Vector3d p = lines[x].l.cross(lines[y].l);
        const double strength = std::hypot(p.z(), p.head<2>().norm() / size) *
                                std::min(lines[x].quality, lines[y].quality);
        if (strength > best.strength)
          best.strength = strength, best_x = static_cast<int>(x), best_y = static_cast<int>(y);
      }
    if (best_x < 0) {
      best.strength = 0.0;
      return best;
    }
    best.point = normalise_point(lines[best_x].l.cross(lines[best_y].l), size);
    best.how = fmt::format("Kennedy: {} x {}", lines[best_x].how, lines[best_y].how);
    return best;
  };
  for (;;) {
    InstantCentre* chosen = nullptr;
    Crossing best;
    for (InstantCentre& c : out.centres) {
      if (c.placed()) continue;
      Crossing crossing = best_crossing(c);
      if (crossing.strength > best.strength) best = std::move(crossing), chosen = &c;
    }
    if (!chosen) break;
    chosen->point = best.point;
    chosen->found = InstantCentre::Found::kennedy;
    chosen->how = std::move(best.how);
  }

  // What Kennedy could not place, from the exact velocities: where the relative velocity of
  // the two links vanishes, P = (omega_i r_i - omega_j r_j + perp(v_i - v_j)) / (omega_i -
  // omega_j) with v, r of the frame origins; at infinity across (v_i - v_j) when omega_i = omega_j.
  // A pair with no relative motion (to round-off of the chain's own) has no centre: every point
  // is one (IFToMM A02's two coupler halves at its drawn pose gave 0/0, a NaN centre that
  // stopped the report's script). It stays unplaced, with why.
  const Eigen::VectorXd qdot = rates_at(m, exact, row);
  double motion = 0.0;  // the largest |omega| size + |v| of a moving link's frame
  for (int k = 0; k < m.moving_count(); ++k)
    motion = std::max(motion, std::abs(qdot(3 * k + 2)) * size + qdot.segment<2>(3 * k).norm());
  for (InstantCentre& c : out.centres) {
    if (c.placed()) continue;
    ++out.kennedy_unplaced;
    const BodyMotion a = motion_of(m, c.i, q, &qdot), b = motion_of(m, c.j, q, &qdot);
    const Eigen::Vector2d top = a.omega * a.r - b.omega * b.r + perp(a.v - b.v);
    if (!(top.norm() + std::abs(a.omega - b.omega) * size > 1e-12 * motion)) {
      c.how = "undefined: the pair has no relative motion at this pose (every point is a centre)";
      continue;
    }
    c.point = normalise_point(Eigen::Vector3d(top.x(), top.y(), a.omega - b.omega), size);
    c.found = InstantCentre::Found::velocity;
    c.how = "Kennedy cannot place it: from the velocity solution";
  }
  return out;
}

CentreVelocities centre_velocities(const Mechanism& m, const InstantCentres& centres,
                                   const Trajectory& exact, int row) {
  const int n = static_cast<int>(m.links.size());
  const int ground = m.ground();
  const double size = m.size();
  std::vector<Field> field(static_cast<size_t>(n));
  field[static_cast<size_t>(ground)].known = true;
  auto geometric = [](const InstantCentre& c) { return c.found != InstantCentre::Found::velocity; };

  // The drivers: each input link's motion relative to the link it is measured from.
  const Eigen::VectorXd q = coordinates_at(m, exact, row);
  auto rotate_about = [&](int k, double omega, const InstantCentre& c) {
    Field& f = field[static_cast<size_t>(k)];
    f.known = true;
    f.omega = omega;
    f.v0 = c.at_infinity() ? Eigen::Vector2d::Zero() : Eigen::Vector2d(-omega * perp(c.position()));
    f.from_geometry = geometric(c);
  };
  CentreVelocities out;
  for (const Driver& d : m.drivers) {
    const double rate = d.at_time(exact.time(row)).rate;
    if (d.type == DriverType::joint_angle && m.joints[d.joint].link_a == ground) {
      rotate_about(d.link, rate, centres.at(ground, d.link));
    } else if (d.type == DriverType::link_angle) {
      const InstantCentre& c = centres.at(ground, d.link);
      if (c.at_infinity()) {
        out.message = "the driven link translates: its angle cannot drive it";
        return out;
      }
      rotate_about(d.link, rate, c);
    } else if (d.type == DriverType::slider && m.joints[d.joint].link_a == ground &&
               m.joints[d.joint].type == JointType::prismatic) {
      const Joint& j = m.joints[d.joint];
      Field& f = field[static_cast<size_t>(j.link_b)];
      f.known = true;
      f.v0 = rate * m.links[ground].lines[j.line].direction;
    } else {
      out.message = "the driver is not on a ground joint: its link's motion needs another link's";
      return out;
    }
  }

  // Propagate: link k from a known link j through I(1,k) and I(j,k). Of all the pairs that
  // could give a link next, the best-conditioned is taken (a link's field is no better than the
  // one it came from); one whose centres are all geometric is preferred when well-conditioned.
  // A pair whose I(1,k) and I(j,k) coincide (two links turning about one ground pivot: then
  // I(1,j) is there too) gives the ratio 0/0: rounding makes its centres differ by ~1e-17 m,
  // so an exact-zero test passes it and the ratio comes out as any number (it returned omega_j).
  for (;;) {
    Field best;
    int best_k = -1;
    double best_score = 0.0;
    bool best_geometric = false;
    for (int k = 0; k < n; ++k) {
      if (field[static_cast<size_t>(k)].known) continue;
      const InstantCentre& fixed = centres.at(ground, k);
      if (!fixed.placed()) continue;
      for (int j = 0; j < n; ++j) {
        if (j == k || j == ground || !field[static_cast<size_t>(j)].known) continue;
        if (!centres.at(j, k).placed()) continue;
        const Field& fj = field[static_cast<size_t>(j)];
        Field fk;
        const double quality = follow(fj, fixed, centres.at(j, k), size, fk);
        fk.known = true;
        fk.from_geometry = fj.from_geometry && geometric(fixed) && geometric(centres.at(j, k));
        fk.quality = std::min(fj.quality, quality);
        if (fk.quality < kMinQuality) continue;
        // A geometric pair wins over a better-conditioned one that uses the velocity solution
        // unless it is poorly conditioned itself.
        const bool geometric_ok = fk.from_geometry && fk.quality >= kGoodQuality;
        if (best_k >= 0 && (best_geometric && !geometric_ok)) continue;
        if (best_k >= 0 && best_geometric == geometric_ok && fk.quality <= best_score) continue;
        best = fk, best_k = k, best_score = fk.quality, best_geometric = geometric_ok;
      }
    }
    if (best_k < 0) break;
    field[static_cast<size_t>(best_k)] = best;
  }

  out.complete = true;
  for (int l = 0; l < n; ++l) {
    if (l == ground) continue;
    const Field& f = field[static_cast<size_t>(l)];
    if (!f.known) {
      out.complete = false;
      out.message = fmt::format("no velocity for link '{}' from the centres", m.links[l].name);
    }
    out.omega.push_back(f.omega);
    out.from_geometry.push_back(f.from_geometry);
  }
  for (const Mechanism::NamedPoint& p : m.named_points()) {
    const BodyMotion body = BodyMotion::of(m.moving_index(p.link), q, nullptr, nullptr);
    out.point.push_back(field[static_cast<size_t>(p.link)].at(
        body.position(m.links[p.link].points[p.point].local)));
  }
  return out;
}

}  // namespace crosslink
