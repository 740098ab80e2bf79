#include "sim/mujoco/scene.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "analytic/planar.h"
#include "sim/forces.h"

namespace crosslink::sim::mujoco_scene {
namespace {

Eigen::Matrix2d rotation(double theta) {
  return Eigen::Rotation2Dd(theta).toRotationMatrix();
}

Eigen::Vector2d world(const SceneLink& link, const Eigen::Vector2d& local) {
  return link.pose.head<2>() + rotation(link.pose(2)) * local;
}

// Minimal union-find for Kruskal's spanning tree.
struct Components {
  std::vector<int> parent;
  explicit Components(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int i) { return parent[i] == i ? i : parent[i] = find(parent[i]); }
  bool join(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    parent[a] = b;
    return true;
  }
};

// The tree joint that realises the definition's driver, and how its value maps to the driver.
DrivenJoint choose_driven(const Mechanism& m, const std::vector<SceneJoint>& joints,
                          const std::vector<int>& scene_of_link,
                          const std::vector<int>& scene_of_joint) {
  const Driver& d = m.driver();
  DrivenJoint driven;
  double arm = 0.0;  // angle of the measured direction in its link's frame
  if (d.from >= 0 && d.to >= 0) {
    const Eigen::Vector2d v =
        m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local;
    arm = std::atan2(v.y(), v.x());
  }
  if (d.type == DriverType::slider) {
    driven.joint = scene_of_joint[d.joint];  // the slide (a pin-in-slot's block slide)
    return driven;
  }
  if (d.type == DriverType::joint_angle) {
    driven.joint = scene_of_joint[d.joint];  // value = theta_b - theta_a = driver - arm
    driven.offset = arm;
    return driven;
  }
  // Link angle: direct when the link turns about a ground pivot.
  const int ground = scene_of_link[m.ground()], link = scene_of_link[d.link];
  for (size_t j = 0; j < joints.size(); ++j) {
    const SceneJoint& sj = joints[j];
    if (sj.kind != SceneJoint::Kind::hinge) continue;
    if ((sj.a == ground && sj.b == link) || (sj.a == link && sj.b == ground)) {
      driven.joint = static_cast<int>(j);
      driven.offset = arm;
      driven.sign = sj.b == link ? 1.0 : -1.0;
      return driven;
    }
  }
  // A floating link's angle: the sum of the hinges from the ground to the link (a fixed tendon,
  // driver_tendon()), which is the link's absolute angle. One of the link's hinges goes first
  // into the tree.
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].kind == SceneJoint::Kind::hinge && (joints[j].a == link || joints[j].b == link)) {
      driven.joint = static_cast<int>(j);
      driven.offset = arm;
      driven.tendon = true;
      return driven;
    }
  throw std::runtime_error(
      "the driver is the angle of a link that no revolute joint turns: nothing can drive it");
}

// Places the child of tree joint j from its parent and the joint's value.
void place_child(Scene& s, const SceneJoint& j) {
  SceneLink& child = s.links[j.child];
  const SceneLink& parent = s.links[j.parent];
  const bool child_is_b = j.child == j.b;
  if (j.kind == SceneJoint::Kind::hinge) {
    if (child_is_b) {
      child.pose(2) = parent.pose(2) + j.value;
      child.pose.head<2>() = world(parent, j.ua) - rotation(child.pose(2)) * j.ub;
    } else {
      child.pose(2) = parent.pose(2) - j.value;
      child.pose.head<2>() = world(parent, j.ub) - rotation(child.pose(2)) * j.ua;
    }
    return;
  }
  if (child_is_b) {
    child.pose(2) = parent.pose(2) + j.relative_angle;
    child.pose.head<2>() =
        world(parent, j.origin + j.value * j.direction) - rotation(child.pose(2)) * j.ub;
  } else {
    child.pose(2) = parent.pose(2) - j.relative_angle;
    child.pose.head<2>() =
        world(parent, j.ub) - rotation(child.pose(2)) * (j.origin + j.value * j.direction);
  }
}

}  // namespace

Scene build_scene(const Mechanism& m, const Eigen::VectorXd& q) {
  Scene s;
  s.size = m.size();

  // Links: ground first, then the moving links in Mechanism order.
  std::vector<int> scene_of_link(m.links.size());
  std::vector<int> order{m.ground()};
  for (size_t l = 0; l < m.links.size(); ++l)
    if (!m.links[l].ground) order.push_back(static_cast<int>(l));
  for (int l : order) {
    SceneLink link;
    link.name = m.links[l].name;
    link.source = l;
    link.ground = m.links[l].ground;
    const MassProperties mp = scene_mass(m, l);
    link.mass = mp.mass;
    link.centre = mp.com;
    link.inertia = mp.inertia;
    for (const Point& p : m.links[l].points) link.points.push_back(p.local);
    const int k = m.moving_index(l);
    if (k >= 0) link.pose = q.segment<3>(3 * k);
    scene_of_link[l] = static_cast<int>(s.links.size());
    s.links.push_back(link);
  }

  // Joints; a pin-in-slot becomes a block sliding on the line plus a hinge at the pin.
  std::vector<int> scene_of_joint(m.joints.size());
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    const int a = scene_of_link[j.link_a], b = scene_of_link[j.link_b];
    SceneJoint sj;
    sj.name = j.name;
    sj.source = static_cast<int>(ji);
    sj.a = a;
    sj.b = b;
    sj.ub = s.links[b].points[j.point_b];
    scene_of_joint[ji] = static_cast<int>(s.joints.size());
    if (j.type == JointType::revolute) {
      sj.ua = s.links[a].points[j.point_a];
      s.joints.push_back(sj);
      continue;
    }
    const Line& line = m.links[j.link_a].lines[j.line];
    sj.kind = SceneJoint::Kind::slide;
    sj.origin = line.origin;
    sj.direction = line.direction;
    sj.relative_angle = j.relative_angle;
    if (j.type == JointType::prismatic) {
      s.joints.push_back(sj);
      continue;
    }
    SceneLink block;
    block.name = j.name + "_block";
    block.pose << world(s.links[b], sj.ub), s.links[a].pose(2);
    block.guide = a;
    block.pin = b;
    block.pin_point = sj.ub;
    block.mass = auxiliary_mass(m);
    block.inertia = block.mass * 1e-4 * s.size * s.size;
    const int k = static_cast<int>(s.links.size());
    s.links.push_back(block);
    SceneJoint pin;
    pin.name = j.name + "_pin";
    pin.source = static_cast<int>(ji);
    pin.a = k;
    pin.b = b;
    pin.ub = sj.ub;
    sj.name = j.name + "_slide";
    sj.b = k;
    sj.ub.setZero();
    sj.relative_angle = 0.0;
    s.joints.push_back(sj);
    s.joints.push_back(pin);
  }

  // The unit of mass: the lightest mass or inertia at kLightest or more, ten times mjMINVAL (a
  // scene that loads as it is keeps its unit).
  constexpr double kLightest = 1e-14;
  double lightest = kLightest;
  for (const SceneLink& link : s.links)
    if (!link.ground) lightest = std::min({lightest, link.mass, link.inertia});
  s.mass_scale = std::exp2(std::ceil(std::log2(kLightest / lightest)));
  for (SceneLink& link : s.links) {
    link.mass *= s.mass_scale;
    link.inertia *= s.mass_scale;
  }

  // Joint values at the given configuration.
  for (SceneJoint& j : s.joints) {
    const SceneLink &a = s.links[j.a], &b = s.links[j.b];
    if (j.kind == SceneJoint::Kind::hinge) {
      j.value = b.pose(2) - a.pose(2);
    } else {
      j.value = (rotation(a.pose(2)) * j.direction).dot(world(b, j.ub) - world(a, j.origin));
    }
  }

  // Spanning tree (Kruskal): the driven joint first, so the driver acts on a MuJoCo joint; then
  // slides, so every cut is a revolute joint that <connect> closes exactly; then hinges.
  s.driven = choose_driven(m, s.joints, scene_of_link, scene_of_joint);
  std::vector<int> priority;
  priority.push_back(s.driven.joint);
  for (int pass = 0; pass < 2; ++pass)
    for (size_t j = 0; j < s.joints.size(); ++j) {
      const bool slide = s.joints[j].kind == SceneJoint::Kind::slide;
      if (static_cast<int>(j) != s.driven.joint && slide == (pass == 0))
        priority.push_back(static_cast<int>(j));
    }
  Components components(s.links.size());
  for (int j : priority) {
    SceneJoint& sj = s.joints[j];
    sj.in_tree = components.join(sj.a, sj.b);
    if (!sj.in_tree) {
      if (sj.kind == SceneJoint::Kind::slide)
        throw std::runtime_error(fmt::format(
            "joint {} closes a loop of slides only; a cut slide has no <connect> equivalent",
            sj.name));
      s.cuts.push_back(j);
    }
  }

  // Root the tree at the ground (breadth first) and place every body from its parent, so tree
  // joints hold to rounding in the scene.
  std::vector<bool> placed(s.links.size(), false);
  placed[0] = true;
  for (size_t done = 0; done < s.links.size();) {
    bool progress = false;
    for (int j : priority) {
      SceneJoint& sj = s.joints[j];
      if (!sj.in_tree || sj.parent >= 0 || placed[sj.a] == placed[sj.b]) continue;
      sj.parent = placed[sj.a] ? sj.a : sj.b;
      sj.child = placed[sj.a] ? sj.b : sj.a;
      place_child(s, sj);
      placed[sj.child] = true;
      s.tree_order.push_back(j);
      progress = true;
    }
    done = static_cast<size_t>(std::count(placed.begin(), placed.end(), true));
    if (!progress && done < s.links.size())
      throw std::runtime_error("some links are not connected to the ground by joints");
  }
  return s;
}

bool realisable(const Mechanism& mechanism, std::string* why) {
  try {
    const Scene s = build_scene(mechanism, Eigen::VectorXd::Zero(mechanism.coordinate_count()));
    (void)driver_tendon(mechanism, s);
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return false;
  }
  return true;
}

std::vector<int> tree_path(const Scene& s, int link) {
  std::vector<int> parent_joint(s.links.size(), -1);
  for (int j : s.tree_order) parent_joint[s.joints[j].child] = j;
  std::vector<int> out;
  for (; parent_joint[link] >= 0; link = s.joints[parent_joint[link]].parent)
    out.push_back(parent_joint[link]);
  return out;
}

std::vector<std::pair<int, double>> driver_tendon(const Mechanism& m, const Scene& s) {
  if (!s.driven.tendon) return {{s.driven.joint, s.driven.sign}};  // sign (driver - offset)
  // A link's absolute angle: the sum of the hinges from the ground, with theta_child =
  // theta_parent + value when the child is the hinge's b, - value when it is a.
  int link = 0;
  while (s.links[link].source != m.driver().link) ++link;
  std::vector<std::pair<int, double>> out;
  for (int j : tree_path(s, link))
    if (s.joints[j].kind == SceneJoint::Kind::hinge)
      out.emplace_back(j, s.joints[j].child == s.joints[j].b ? 1.0 : -1.0);
  if (out.empty())
    throw std::runtime_error(fmt::format(
        "the driver is the angle of link {}, which no revolute joint between it and the ground "
        "turns",
        s.links[link].name));
  return out;
}

namespace {

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string quat_z(double angle) {
  return fmt::format("{:.17g} 0 0 {:.17g}", std::cos(0.5 * angle), std::sin(0.5 * angle));
}

// The outline of a link's points (convex hull, counter-clockwise; Andrew's monotone chain).
std::vector<Eigen::Vector2d> outline(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  const auto turn = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) { return perp(a - o).dot(b - o); };
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {  // lower chain
    while (k >= 2 && turn(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && turn(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

// A geom that is drawn only: no contacts, and no mass (inertiafromgeom is off).
std::string drawn(const std::string& pad, const std::string& shape, const char* rgba) {
  return fmt::format("{}<geom {} contype=\"0\" conaffinity=\"0\" group=\"1\" rgba=\"{}\"/>\n", pad,
                     shape, rgba);
}

std::string bar(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double r) {
  return fmt::format("type=\"capsule\" fromto=\"{:.9g} {:.9g} 0 {:.9g} {:.9g} 0\" size=\"{:.6g}\"",
                     a.x(), a.y(), b.x(), b.y(), r);
}

// A link drawn: a bar along each edge of its outline and a pin at each point (the ground: pins
// only); a block is a box on its guide.
std::string link_geometry(const SceneLink& link, int colour, double r, const std::string& pad) {
  static constexpr std::array<const char*, 6> kColours = {"0.12 0.47 0.71 1", "1 0.5 0.05 1",
                                                          "0.17 0.63 0.17 1", "0.58 0.4 0.74 1",
                                                          "0.55 0.34 0.29 1", "0.09 0.75 0.81 1"};
  const char* rgba = link.ground ? "0.5 0.5 0.5 1" : kColours[static_cast<size_t>(colour) % 6];
  if (link.source < 0)
    return drawn(pad,
                 fmt::format("type=\"box\" size=\"{:.6g} {:.6g} {:.6g}\"", 3 * r, 1.5 * r, 1.5 * r),
                 rgba);
  std::string out;
  const std::vector<Eigen::Vector2d> edge = outline(link.points);
  // Two points have one edge; a polygon as many as its corners.
  const size_t edges = link.ground || edge.size() < 2 ? 0 : edge.size() == 2 ? 1 : edge.size();
  for (size_t i = 0; i < edges; ++i)
    out += drawn(pad, bar(edge[i], edge[(i + 1) % edge.size()], r), rgba);
  for (const Eigen::Vector2d& p : link.points)
    out += drawn(pad,
                 fmt::format("type=\"sphere\" pos=\"{:.9g} {:.9g} 0\" size=\"{:.6g}\"", p.x(),
                             p.y(), 1.6 * r),
                 rgba);
  return out;
}

void write_body(const Scene& s, int link, const std::vector<std::vector<int>>& children, int depth,
                const MjcfOptions& o, std::vector<int>& written, std::string& out) {
  const Standalone* standalone = o.standalone ? &*o.standalone : nullptr;
  const std::string pad(static_cast<size_t>(2 * depth), ' ');
  for (int j : children[link]) {
    const SceneJoint& sj = s.joints[j];
    const SceneLink &parent = s.links[sj.parent], &child = s.links[sj.child];
    const Eigen::Vector2d pos =
        rotation(-parent.pose(2)) * (child.pose.head<2>() - parent.pose.head<2>());
    out +=
        fmt::format("{}<body name=\"{}\" pos=\"{:.17g} {:.17g} 0\" quat=\"{}\">\n", pad,
                    escape(child.name), pos.x(), pos.y(), quat_z(child.pose(2) - parent.pose(2)));
    // Only I_zz acts in planar motion; the other two equal it (a valid inertia, no gyroscopic
    // coupling: diagonal in the body frame).
    out += fmt::format(
        "{}  <inertial pos=\"{:.17g} {:.17g} 0\" mass=\"{:.17g}\" "
        "diaginertia=\"{:.17g} {:.17g} {:.17g}\"/>\n",
        pad, child.centre.x(), child.centre.y(), child.mass, child.inertia, child.inertia,
        child.inertia);
    // The joint lives in the child's frame; its sign makes qpos = value (see SceneJoint).
    const bool child_is_b = sj.child == sj.b;
    const std::string armature =
        o.driver_armature > 0.0 && o.driven && !s.driven.tendon && j == s.driven.joint
            ? fmt::format(" armature=\"{:.17g}\"", o.driver_armature)
            : "";
    if (sj.kind == SceneJoint::Kind::hinge) {
      const Eigen::Vector2d at = child_is_b ? sj.ub : sj.ua;
      out += fmt::format(
          "{}  <joint name=\"{}\" type=\"hinge\" pos=\"{:.17g} {:.17g} 0\" axis=\"0 0 {}\" "
          "ref=\"{:.17g}\"{}/>\n",
          pad, escape(sj.name), at.x(), at.y(), child_is_b ? 1 : -1, sj.value, armature);
    } else {
      const Eigen::Vector2d axis =
          child_is_b ? Eigen::Vector2d(rotation(-sj.relative_angle) * sj.direction)
                     : Eigen::Vector2d(-sj.direction);
      out += fmt::format(
          "{}  <joint name=\"{}\" type=\"slide\" axis=\"{:.17g} {:.17g} 0\" ref=\"{:.17g}\"{}/>\n",
          pad, escape(sj.name), axis.x(), axis.y(), sj.value, armature);
    }
    written.push_back(j);
    if (standalone) out += link_geometry(child, sj.child, standalone->radius, pad + "  ");
    write_body(s, sj.child, children, depth + 1, o, written, out);
    out += pad + "</body>\n";
  }
}

std::string vec(const Eigen::VectorXd& v) {
  std::string text;
  for (Eigen::Index i = 0; i < v.size(); ++i) text += fmt::format("{}{:.17g}", i ? " " : "", v(i));
  return text;
}

}  // namespace

std::string to_mjcf(const Mechanism& m, const Scene& s, const MjcfOptions& o) {
  const Standalone* alone = o.standalone ? &*o.standalone : nullptr;
  std::string out = fmt::format("<mujoco model=\"{}\">\n", escape(m.name));
  const bool gravity = o.gravity != Eigen::Vector2d::Zero();
  if (!alone)
    out += "  <!-- crosslink: planar linkage; contacts off, no geoms -->\n";
  else if (alone->clock)
    out +=
        "  <!-- crosslink: planar linkage for MuJoCo alone (docs/engines.md, \"The exported "
        "scene\"); contacts off, geoms drawn only; the hinge \"clock\" moves the driver -->\n";
  else
    out +=
        "  <!-- crosslink: planar linkage for MuJoCo alone (docs/engines.md, \"The exported "
        "scene\"); contacts off, geoms drawn only; the coordinate moves freely under gravity: "
        "the definition's loads, springs and effort are crosslink's run's, not in this file "
        "-->\n";
  out += "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n";
  // Dense Jacobian: the force reading solves with the equality rows of efc_J.
  out += fmt::format(
      "  <option timestep=\"{:.17g}\" integrator=\"{}\" solver=\"{}\" iterations=\"{}\" "
      "tolerance=\"{:.17g}\" jacobian=\"dense\" gravity=\"{:.17g} {:.17g} 0\">\n"
      "    <flag contact=\"disable\" gravity=\"{}\"/>\n  </option>\n",
      o.dt, o.integrator, o.solver, o.iterations, o.tolerance, o.gravity.x(), o.gravity.y(),
      gravity ? "enable" : "disable");
  Eigen::Vector2d low = Eigen::Vector2d::Constant(INFINITY), high = -low;
  for (const SceneLink& link : s.links)
    for (const Eigen::Vector2d& p : link.points) {
      low = low.cwiseMin(world(link, p));
      high = high.cwiseMax(world(link, p));
    }
  const Eigen::Vector2d centre =
      low.allFinite() ? Eigen::Vector2d(0.5 * (low + high)) : Eigen::Vector2d::Zero();
  if (alone)  // frame the linkage; the camera "plane" looks down on its plane
    out += fmt::format("  <statistic center=\"{:.9g} {:.9g} 0\" extent=\"{:.9g}\"/>\n", centre.x(),
                       centre.y(), s.size);
  out += "  <worldbody>\n";
  std::vector<int> written;  // tree joints in the order MuJoCo numbers them
  if (alone) {
    out += fmt::format(
        "    <camera name=\"plane\" pos=\"{:.9g} {:.9g} {:.9g}\" xyaxes=\"1 0 0 0 1 0\"/>\n"
        "    <light directional=\"true\" pos=\"0 0 {:.9g}\" dir=\"0 0 -1\"/>\n",
        centre.x(), centre.y(), 2.5 * s.size, 3 * s.size);
    out += link_geometry(s.links[0], 0, alone->radius, "    ");
    for (const auto& [a, b] : alone->guides)
      out += drawn("    ", bar(a, b, 0.5 * alone->radius), "0.5 0.5 0.5 0.5");
  }
  std::vector<std::vector<int>> children(s.links.size());
  for (int j : s.tree_order) children[s.joints[j].parent].push_back(j);
  write_body(s, 0, children, 2, o, written, out);
  const Clock* clock = alone && alone->clock ? &*alone->clock : nullptr;
  if (clock)  // its own body, off the linkage's tree; not drawn
    out += fmt::format(
        "    <body name=\"clock\">\n"
        "      <inertial pos=\"0 0 0\" mass=\"1\" diaginertia=\"{0:.17g} {0:.17g} {0:.17g}\"/>\n"
        "      <joint name=\"clock\" type=\"hinge\" axis=\"0 0 1\" damping=\"{1:.17g}\" "
        "stiffness=\"{2:.17g}\" springref=\"{3:.17g}\"/>\n"
        "    </body>\n",
        clock->inertia, clock->damping, clock->stiffness, clock->springref);
  out += "  </worldbody>\n";
  // The driver as a tendon: the clock's, and a floating link's angle in crosslink's runs.
  const bool driver_tendon_written = clock || (o.driven && s.driven.tendon);
  if (driver_tendon_written) {
    out += "  <tendon>\n    <fixed name=\"driver\">\n";
    for (const auto& [joint, coefficient] : driver_tendon(m, s))
      out += fmt::format("      <joint joint=\"{}\" coef=\"{:.17g}\"/>\n",
                         escape(s.joints[joint].name), coefficient);
    out += "    </fixed>\n";
    if (clock)
      out +=
          "    <fixed name=\"clock\">\n      <joint joint=\"clock\" coef=\"1\"/>\n    </fixed>\n";
    out += "  </tendon>\n";
  }
  if (clock && clock->torque != 0.0)  // a constant torque: no gain, the bias alone
    out += fmt::format(
        "  <actuator>\n    <general name=\"clock\" joint=\"clock\" gainprm=\"0\" "
        "biastype=\"affine\" biasprm=\"{:.17g} 0 0\"/>\n  </actuator>\n",
        clock->torque);
  out += "  <equality>\n";
  for (int j : s.cuts) {
    const SceneJoint& sj = s.joints[j];
    out += fmt::format(
        "    <connect name=\"{}\" body1=\"{}\" body2=\"{}\" anchor=\"{:.17g} {:.17g} 0\" "
        "solref=\"{}\" solimp=\"{}\"/>\n",
        escape(sj.name), s.links[sj.a].ground ? "world" : escape(s.links[sj.a].name),
        s.links[sj.b].ground ? "world" : escape(s.links[sj.b].name), sj.ua.x(), sj.ua.y(),
        vec(o.solref), vec(o.solimp));
  }
  // MuJoCo's equalities hold changes from qpos0 (the start): the driver's equals the clock's.
  if (clock)
    out += fmt::format(
        "    <tendon name=\"driver\" tendon1=\"driver\" tendon2=\"clock\" polycoef=\"0 1 0 0 0\" "
        "solref=\"{}\" solimp=\"{}\"/>\n",
        vec(o.driver_solref), vec(o.driver_solimp));
  else if (driver_tendon_written)
    out += fmt::format(
        "    <tendon name=\"driver\" tendon1=\"driver\" polycoef=\"0 0 0 0 0\" solref=\"{}\" "
        "solimp=\"{}\"/>\n",
        vec(o.driver_solref), vec(o.driver_solimp));
  else if (o.driven)
    out += fmt::format(
        "    <joint name=\"driver\" joint1=\"{}\" polycoef=\"0 0 0 0 0\" solref=\"{}\" "
        "solimp=\"{}\"/>\n",
        escape(s.joints[s.driven.joint].name), vec(o.driver_solref), vec(o.driver_solimp));
  out += "  </equality>\n";
  if (alone) {  // "start": the exact start's velocities (MuJoCo's simulate loads it by its Key)
    std::string qvel;
    for (int j : written)
      qvel +=
          fmt::format("{}{:.17g}", qvel.empty() ? "" : " ", alone->rates[static_cast<size_t>(j)]);
    if (clock) qvel += fmt::format("{}{:.17g}", qvel.empty() ? "" : " ", clock->rate);
    out +=
        fmt::format("  <keyframe>\n    <key name=\"start\" qvel=\"{}\"/>\n  </keyframe>\n", qvel);
  }
  out += "</mujoco>\n";
  return out;
}

}  // namespace crosslink::sim::mujoco_scene
