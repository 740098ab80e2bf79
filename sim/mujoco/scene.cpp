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
                          const std::vector<int>& scene_of_joint, const Trajectory* reference) {
  const Driver& d = m.driver;
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
  // A floating link's angle: drive a hinge with the exact trajectory of its angle instead. A
  // hinge whose rate vanishes somewhere would drive the chain through a dead point there, so
  // the one whose smallest rate over the reference is largest against its peak is chosen.
  double best = -1.0;
  for (size_t j = 0; j < joints.size(); ++j) {
    const SceneJoint& sj = joints[j];
    if (sj.kind != SceneJoint::Kind::hinge) continue;
    int link_a = -1, link_b = -1;
    for (size_t l = 0; l < m.links.size(); ++l) {
      if (m.links[l].ground) continue;
      if (scene_of_link[l] == sj.a) link_a = static_cast<int>(l);
      if (scene_of_link[l] == sj.b) link_b = static_cast<int>(l);
    }
    double score = 0.0;  // without a reference: the first ground pivot
    if (reference) {
      double low = INFINITY, peak = 0.0;
      for (int i = 0; i < reference->samples(); ++i) {
        if (reference->status[static_cast<size_t>(i)] != PoseStatus::ok) continue;
        double rate = 0.0;
        if (link_b >= 0) rate += reference->omega(i, m.moving_index(link_b));
        if (link_a >= 0) rate -= reference->omega(i, m.moving_index(link_a));
        low = std::min(low, std::abs(rate));
        peak = std::max(peak, std::abs(rate));
      }
      score = peak > 0.0 ? low / peak : 0.0;
    } else if (sj.a != ground && sj.b != ground) {
      continue;
    }
    if (score <= best) continue;
    best = score;
    driven.joint = static_cast<int>(j);
    driven.equivalent = true;
    driven.link_a = link_a;
    driven.link_b = link_b;
  }
  if (driven.joint >= 0) return driven;
  throw std::runtime_error(
      "the driver is the angle of a link without a ground pivot, and no revolute joint can "
      "carry an equivalent driver");
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

Scene build_scene(const Mechanism& m, const Eigen::VectorXd& q, const Trajectory* reference) {
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
  s.driven = choose_driven(m, s.joints, scene_of_link, scene_of_joint, reference);
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
    build_scene(mechanism, Eigen::VectorXd::Zero(mechanism.coordinate_count()), nullptr);
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return false;
  }
  return true;
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

void write_body(const Scene& s, int link, const std::vector<std::vector<int>>& children, int depth,
                std::string& out) {
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
    if (sj.kind == SceneJoint::Kind::hinge) {
      const Eigen::Vector2d at = child_is_b ? sj.ub : sj.ua;
      out += fmt::format(
          "{}  <joint name=\"{}\" type=\"hinge\" pos=\"{:.17g} {:.17g} 0\" axis=\"0 0 {}\" "
          "ref=\"{:.17g}\"/>\n",
          pad, escape(sj.name), at.x(), at.y(), child_is_b ? 1 : -1, sj.value);
    } else {
      const Eigen::Vector2d axis =
          child_is_b ? Eigen::Vector2d(rotation(-sj.relative_angle) * sj.direction)
                     : Eigen::Vector2d(-sj.direction);
      out += fmt::format(
          "{}  <joint name=\"{}\" type=\"slide\" axis=\"{:.17g} {:.17g} 0\" ref=\"{:.17g}\"/>\n",
          pad, escape(sj.name), axis.x(), axis.y(), sj.value);
    }
    write_body(s, sj.child, children, depth + 1, out);
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
  std::string out = fmt::format("<mujoco model=\"{}\">\n", escape(m.name));
  const bool gravity = o.gravity != Eigen::Vector2d::Zero();
  out += "  <!-- crosslink: planar linkage; contacts off, no geoms -->\n";
  out += "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n";
  // Dense Jacobian: the force reading solves with the equality rows of efc_J.
  out += fmt::format(
      "  <option timestep=\"{:.17g}\" integrator=\"{}\" solver=\"{}\" iterations=\"{}\" "
      "tolerance=\"{:.17g}\" jacobian=\"dense\" gravity=\"{:.17g} {:.17g} 0\">\n"
      "    <flag contact=\"disable\" gravity=\"{}\"/>\n  </option>\n",
      o.dt, o.integrator, o.solver, o.iterations, o.tolerance, o.gravity.x(), o.gravity.y(),
      gravity ? "enable" : "disable");
  out += "  <worldbody>\n";
  std::vector<std::vector<int>> children(s.links.size());
  for (int j : s.tree_order) children[s.joints[j].parent].push_back(j);
  write_body(s, 0, children, 2, out);
  out += "  </worldbody>\n  <equality>\n";
  for (int j : s.cuts) {
    const SceneJoint& sj = s.joints[j];
    out += fmt::format(
        "    <connect name=\"{}\" body1=\"{}\" body2=\"{}\" anchor=\"{:.17g} {:.17g} 0\" "
        "solref=\"{}\" solimp=\"{}\"/>\n",
        escape(sj.name), s.links[sj.a].ground ? "world" : escape(s.links[sj.a].name),
        s.links[sj.b].ground ? "world" : escape(s.links[sj.b].name), sj.ua.x(), sj.ua.y(),
        vec(o.solref), vec(o.solimp));
  }
  if (o.driven)
    out += fmt::format(
        "    <joint name=\"driver\" joint1=\"{}\" polycoef=\"0 0 0 0 0\" solref=\"{}\" "
        "solimp=\"{}\"/>\n",
        escape(s.joints[s.driven.joint].name), vec(o.driver_solref), vec(o.driver_solimp));
  out += "  </equality>\n</mujoco>\n";
  return out;
}

}  // namespace crosslink::sim::mujoco_scene
