#include "analytic/instant_centres.h"

#include <fmt/format.h>

#include <cmath>

#include "analytic/planar.h"

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

std::string label(int i, int j) {
  return fmt::format("I({},{})", i + 1, j + 1);
}

BodyMotion motion_of(const Mechanism& m, int link, const Eigen::VectorXd& q,
                     const Eigen::VectorXd* qdot) {
  return BodyMotion::of(m.moving_index(link), q, qdot, nullptr);
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
  std::vector<std::vector<std::pair<Eigen::Vector3d, std::string>>> slot_lines(out.centres.size());

  // Primary centres.
  for (const Joint& jt : m.joints) {
    InstantCentre& c = out.centres[static_cast<size_t>(pair_index(n, jt.link_a, jt.link_b))];
    const BodyMotion a = motion_of(m, jt.link_a, q, nullptr);
    const BodyMotion b = motion_of(m, jt.link_b, q, nullptr);
    if (jt.type == JointType::revolute) {
      c.found = InstantCentre::Found::primary;
      c.point << a.position(m.links[jt.link_a].points[jt.point_a].local), 1.0;
      c.how = fmt::format("primary: revolute {}", jt.name);
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
        {normalise_line(pin.cross(normal_direction)),
         fmt::format("normal to slot {} at the pin", jt.name)});
  }

  // Kennedy: repeat until a pass places nothing.
  for (bool placed_any = true; placed_any;) {
    placed_any = false;
    for (InstantCentre& c : out.centres) {
      if (c.placed()) continue;
      std::vector<std::pair<Eigen::Vector3d, std::string>> lines =
          slot_lines[static_cast<size_t>(pair_index(n, c.i, c.j))];
      for (int k = 0; k < n; ++k) {
        if (k == c.i || k == c.j) continue;
        const InstantCentre& a = out.centres[static_cast<size_t>(pair_index(n, c.i, k))];
        const InstantCentre& b = out.centres[static_cast<size_t>(pair_index(n, k, c.j))];
        if (!a.placed() || !b.placed() || a.found == InstantCentre::Found::velocity ||
            b.found == InstantCentre::Found::velocity)
          continue;
        const Eigen::Vector3d line = a.point.cross(b.point);
        // Two centres in one place (or both at infinity) give no line.
        if (line.head<2>().norm() < 1e-12 * (1.0 + std::abs(line.z()) / size)) continue;
        lines.push_back(
            {normalise_line(line), fmt::format("{}-{}", label(std::min(c.i, k), std::max(c.i, k)),
                                               label(std::min(k, c.j), std::max(k, c.j)))});
      }
      // The best-conditioned crossing of two lines (same line twice crosses nowhere).
      double best = 1e-9;
      int best_a = -1, best_b = -1;
      for (size_t x = 0; x < lines.size(); ++x)
        for (size_t y = x + 1; y < lines.size(); ++y) {
          const Eigen::Vector3d p = lines[x].first.cross(lines[y].first);
          const double strength = std::hypot(p.z(), p.head<2>().norm() / size);
          if (strength > best)
            best = strength, best_a = static_cast<int>(x), best_b = static_cast<int>(y);
        }
      if (best_a < 0) continue;
      c.point = normalise_point(lines[best_a].first.cross(lines[best_b].first), size);
      c.found = InstantCentre::Found::kennedy;
      c.how = fmt::format("Kennedy: {} x {}", lines[best_a].second, lines[best_b].second);
      placed_any = true;
    }
  }

  // What Kennedy could not place, from the exact velocities: where the relative velocity of
  // the two links vanishes, P = (omega_i r_i - omega_j r_j + perp(v_i - v_j)) / (omega_i -
  // omega_j) with v, r of the frame origins; at infinity across (v_i - v_j) when omega_i = omega_j.
  const Eigen::VectorXd qdot = rates_at(m, exact, row);
  for (InstantCentre& c : out.centres) {
    if (c.placed()) continue;
    ++out.kennedy_unplaced;
    const BodyMotion a = motion_of(m, c.i, q, &qdot), b = motion_of(m, c.j, q, &qdot);
    const Eigen::Vector2d top = a.omega * a.r - b.omega * b.r + perp(a.v - b.v);
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
  // Each link's velocity field v(P) = v0 + omega perp(P).
  struct Field {
    bool known = false;
    bool from_geometry = true;
    Eigen::Vector2d v0 = Eigen::Vector2d::Zero();
    double omega = 0.0;
    Eigen::Vector2d at(const Eigen::Vector2d& p) const { return v0 + omega * perp(p); }
  };
  std::vector<Field> field(static_cast<size_t>(n));
  field[static_cast<size_t>(ground)].known = true;
  auto geometric = [](const InstantCentre& c) { return c.found != InstantCentre::Found::velocity; };

  // The driver: the input link's motion relative to the link it is measured from.
  const Driver& d = m.driver;
  const double rate = d.at_time(exact.time(row)).rate;
  const Eigen::VectorXd q = coordinates_at(m, exact, row);
  auto rotate_about = [&](int k, double omega, const InstantCentre& c) {
    Field& f = field[static_cast<size_t>(k)];
    f.known = true;
    f.omega = omega;
    f.v0 = c.at_infinity() ? Eigen::Vector2d::Zero() : Eigen::Vector2d(-omega * perp(c.position()));
    f.from_geometry = geometric(c);
  };
  CentreVelocities out;
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

  // Propagate: link k from a known link j through I(1,k) and I(j,k).
  for (bool progress = true; progress;) {
    progress = false;
    for (int k = 0; k < n; ++k) {
      if (field[static_cast<size_t>(k)].known) continue;
      const InstantCentre& fixed = centres.at(ground, k);
      for (int j = 0; j < n && !field[static_cast<size_t>(k)].known; ++j) {
        if (j == k || j == ground || !field[static_cast<size_t>(j)].known) continue;
        const InstantCentre& common = centres.at(j, k);
        const Field& fj = field[static_cast<size_t>(j)];
        Field fk;
        fk.known = true;
        fk.from_geometry = fj.from_geometry && geometric(fixed) && geometric(common);
        if (!common.at_infinity()) {
          // I(j,k) has one velocity on both links.
          const Eigen::Vector2d p = common.position(), v = fj.at(p);
          if (fixed.at_infinity()) {
            fk.v0 = v;  // k translates
          } else {
            const Eigen::Vector2d arm = p - fixed.position();
            if (arm.squaredNorm() == 0.0) continue;  // I(1,k) = I(j,k): no ratio here
            fk.omega = v.dot(perp(arm)) / arm.squaredNorm();
            fk.v0 = -fk.omega * perp(fixed.position());
          }
        } else {
          // j and k in relative translation: the same angular velocity.
          fk.omega = fj.omega;
          if (!fixed.at_infinity()) {
            fk.v0 = -fk.omega * perp(fixed.position());
          } else {
            // Both translate: v_k = v_j + t perp(u_jk), with no component along u_1k.
            const Eigen::Vector2d u = common.position(), w = fixed.position();
            const double across = perp(u).dot(w);
            if (std::abs(across) < 1e-12) continue;
            fk.v0 = fj.v0 - (fj.v0.dot(w) / across) * perp(u);
          }
        }
        field[static_cast<size_t>(k)] = fk;
        progress = true;
      }
    }
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
