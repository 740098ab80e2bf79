#include "sim/mujoco/scene.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "analytic/model/planar.h"
#include "sim/forces.h"

namespace crosslink::sim::mujoco_scene {
namespace {

Eigen::Matrix2d rotation(double theta) {
  return Eigen::Rotation2Dd(theta).toRotationMatrix();
}

Eigen::Vector2d world(const SceneLink& link, const Eigen::Vector2d& local) {
  return link.pose.head<2>() + rotation(link.pose(2)) * local;
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

Scene build_scene(const Mechanism& m, const Eigen::VectorXd& q, int cam_facets) {
  SceneGraph graph =
      scene_graph(m, TreePolicy{.contacts = true, .arc_rows = true, .cam_facets = cam_facets});
  if (graph.cut_slide >= 0)
    throw std::runtime_error(fmt::format(
        "joint {} closes a loop of slides only; a cut slide has no <connect> equivalent",
        graph.joints[graph.cut_slide].name));
  // Joint friction as MuJoCo's frictionloss (docs/engines.md, "Joint friction"): on a tree
  // joint's degree of freedom, or on a fixed tendon over a cut pin's relative rotation.
  std::vector<std::vector<std::pair<int, double>>> friction_terms(graph.joints.size());
  std::vector<int> parent_joint(graph.bodies.size(), -1);
  for (int t : graph.tree_order) parent_joint[static_cast<size_t>(graph.joints[t].child)] = t;
  for (size_t ji = 0; ji < graph.joints.size(); ++ji) {
    const sim::SceneJoint& j = graph.joints[ji];
    if (j.source < 0 || !m.joints[static_cast<size_t>(j.source)].friction || j.in_tree) continue;
    // The tendon's moment reaches a body as generalised forces on its path's hinges; a body on
    // a slide turns with its guide, so the moment on it would act through the slide's couple,
    // which MuJoCo's reading (cfrc_int) does not carry.
    for (const int body : {j.a, j.b}) {
      const int parent = parent_joint[static_cast<size_t>(body)];
      if (parent >= 0 && graph.joints[static_cast<size_t>(parent)].kind == SceneJoint::Kind::slide)
        throw std::runtime_error(fmt::format(
            "joint '{}' has friction and closes a loop at link '{}', which slides: the fixed "
            "tendon that carries a cut pin's friction would put its moment on the slider through "
            "the slide's couple, which MuJoCo does not read",
            m.joints[static_cast<size_t>(j.source)].name,
            graph.bodies[static_cast<size_t>(body)].name));
    }
    friction_terms[ji] = relative_angle_terms(graph, static_cast<int>(ji));
  }
  Scene s;
  s.size = m.size();
  for (SceneBody& body : graph.bodies) {
    SceneLink link;
    static_cast<SceneBody&>(link) = std::move(body);
    if (link.source >= 0)
      for (const Point& p : m.links[link.source].points) link.points.push_back(p.local);
    const BodyMotion at = body_motion(m, link, q);
    link.pose << at.r, at.theta;
    s.links.push_back(std::move(link));
  }
  for (sim::SceneJoint& joint : graph.joints) {
    SceneJoint j;
    static_cast<sim::SceneJoint&>(j) = std::move(joint);
    s.joints.push_back(std::move(j));
  }
  s.tree_order = std::move(graph.tree_order);
  s.cuts = std::move(graph.cuts);
  s.driven = std::move(graph.driven);
  for (const Driver& d : m.drivers)
    s.driver_names.push_back(m.axis().timed() ? "driver:" + d.name : "driver");
  s.couplings = std::move(graph.couplings);
  s.contacts = std::move(graph.contacts);
  s.arcs = std::move(graph.arcs);

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
  for (SceneJoint& j : s.joints)
    if (j.source >= 0 && m.joints[static_cast<size_t>(j.source)].friction) {
      const JointFriction& f = *m.joints[static_cast<size_t>(j.source)].friction;
      j.friction = true;
      j.frictionloss = f.constant * s.mass_scale;
      j.friction_grows = f.load_dependent();
      j.friction_terms = std::move(friction_terms[static_cast<size_t>(&j - s.joints.data())]);
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

  // Place every body from its tree parent, so tree joints hold to rounding in the scene.
  for (int j : s.tree_order) place_child(s, s.joints[j]);
  return s;
}

std::string arc_site(const Mechanism& m, const SceneArc& a, bool centre) {
  return m.joints[static_cast<size_t>(a.source)].name + (centre ? ":centre" : ":pin");
}

std::string contact_geom(const Mechanism& m, const SceneContact& c, bool cam) {
  return (cam ? "cam:" : "follower:") + m.joints[static_cast<size_t>(c.source)].name +
         (c.far ? ":far" : "");
}

bool realisable(const Mechanism& mechanism, std::string* why) {
  try {
    (void)build_scene(mechanism, Eigen::VectorXd::Zero(mechanism.coordinate_count()));
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

// Alone, MuJoCo holds the load-independent part only: crosslink's runs set the rest.
std::string friction_comment(const SceneJoint& j, const std::string& pad) {
  if (!j.friction_grows) return "";
  return fmt::format(
      "{}<!-- {}: friction growing with the joint's reaction, which crosslink sets before each "
      "step; frictionloss here is its constant part only -->\n",
      pad, escape(j.name));
}

// A frictionloss bound and its softness, on a tree joint or a cut pin's tendon.
std::string friction_attributes(const SceneJoint& j, const MjcfOptions& o) {
  return fmt::format(" frictionloss=\"{:.17g}\" solreffriction=\"{:.17g} {:.17g}\"", j.frictionloss,
                     o.friction_solref.x(), o.friction_solref.y());
}

// The contact shapes on body `link` (Scene::contacts, as SceneContact gives them), contype and
// conaffinity 0, so that only their <pair> collides (MuJoCo's sphere-sphere and sphere-box
// contacts are analytic; a profile's mesh, written in <asset>, is collided by MPR).
std::string contact_geoms(const Mechanism& m, const Scene& s, int link, const std::string& pad) {
  std::string out;
  for (const SceneContact& c : s.contacts)
    for (const bool cam : {true, false}) {
      if ((cam ? c.cam : c.follower) != link) continue;
      const Eigen::Vector2d& at = cam ? c.cam_centre : c.follower_centre;
      const std::string shape =
          cam && !c.cam_polygon.empty()
              ? fmt::format("type=\"mesh\" mesh=\"{}\"", escape(contact_geom(m, c, true)))
          : !cam && c.face
              ? fmt::format(
                    "type=\"box\" pos=\"{:.17g} {:.17g} 0\" quat=\"{}\" size=\"{:.17g} "
                    "{:.17g} {:.17g}\"",
                    at.x(), at.y(), quat_z(c.box_angle), c.box_half.x(), c.box_half.y(),
                    c.box_half.z())
              : fmt::format("type=\"sphere\" pos=\"{:.17g} {:.17g} 0\" size=\"{:.17g}\"", at.x(),
                            at.y(), cam ? c.cam_radius : c.follower_radius);
      out += fmt::format(
          "{}<geom name=\"{}\" {} contype=\"0\" conaffinity=\"0\" rgba=\"0.6 0.6 0.6 0.5\"/>\n",
          pad, escape(contact_geom(m, c, cam)), shape);
    }
  return out;
}

std::string arc_sites(const Mechanism& m, const Scene& s, int link, const std::string& pad) {
  std::string out;
  for (const SceneArc& a : s.arcs)
    for (const bool centre : {true, false}) {
      if ((centre ? a.guide : a.pin) != link) continue;
      const Eigen::Vector2d& at = centre ? a.centre : a.point;
      out += fmt::format("{}<site name=\"{}\" pos=\"{:.17g} {:.17g} 0\"/>\n", pad,
                         escape(arc_site(m, a, centre)), at.x(), at.y());
    }
  return out;
}

void write_body(const Mechanism& m, const Scene& s, int link,
                const std::vector<std::vector<int>>& children, int depth, const MjcfOptions& o,
                std::vector<int>& written, std::string& out) {
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
    std::string armature;
    for (size_t d = 0; d < s.driven.size() && d < o.driver_armature.size(); ++d)
      if (o.driver_armature[d] > 0.0 && o.driven && !s.driven[d].floating && j == s.driven[d].joint)
        armature = fmt::format(" armature=\"{:.17g}\"", o.driver_armature[d]);
    // Joint friction on a tree joint: its frictionloss (a cut pin's is its tendon's).
    if (standalone) out += friction_comment(sj, pad + "  ");
    if (sj.friction && sj.friction_terms.empty()) armature += friction_attributes(sj, o);
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
    out += contact_geoms(m, s, sj.child, pad + "  ");
    out += arc_sites(m, s, sj.child, pad + "  ");
    write_body(m, s, sj.child, children, depth + 1, o, written, out);
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
  const bool gravity = o.gravity != Eigen::Vector2d::Zero(), contacts = !s.contacts.empty();
  // A cam's contact pair is the only contact (Scene::contacts).
  const char* const contact_words = contacts ? "contacts only a cam's pair" : "contacts off";
  if (!alone)
    out += fmt::format("  <!-- crosslink: planar linkage; {}, {} -->\n", contact_words,
                       contacts ? "no other geoms" : "no geoms");
  else if (alone->clock)
    out += fmt::format(
        "  <!-- crosslink: planar linkage for MuJoCo alone (docs/engines.md, \"The exported "
        "scene\"); {}, geoms drawn only; the hinge \"clock\" moves the driver -->\n",
        contact_words);
  else
    out += fmt::format(
        "  <!-- crosslink: planar linkage for MuJoCo alone (docs/engines.md, \"The exported "
        "scene\"); {}, geoms drawn only; the coordinate moves freely under gravity: the "
        "definition's loads, springs and effort are crosslink's run's, not in this file -->\n",
        contact_words);
  out += "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n";
  // Dense Jacobian: the force reading solves with the equality rows of efc_J.
  out += fmt::format(
      "  <option timestep=\"{:.17g}\" integrator=\"{}\" solver=\"{}\" iterations=\"{}\" "
      "tolerance=\"{:.17g}\" jacobian=\"dense\" gravity=\"{:.17g} {:.17g} 0\">\n"
      "    <flag contact=\"{}\" gravity=\"{}\"/>\n  </option>\n",
      o.dt, o.integrator, o.solver, o.iterations, o.tolerance, o.gravity.x(), o.gravity.y(),
      contacts ? "enable" : "disable", gravity ? "enable" : "disable");
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
  // A cam whose profile is not a disc: a prism over its polygon, whose convex hull MuJoCo
  // collides (SceneContact::cam_polygon).
  std::string meshes;
  for (const SceneContact& c : s.contacts) {
    if (c.cam_polygon.empty()) continue;
    std::string vertices;
    for (const Eigen::Vector2d& p : c.cam_polygon)
      for (const double z : {-c.cam_half_thickness, c.cam_half_thickness})
        vertices +=
            fmt::format("{}{:.17g} {:.17g} {:.17g}", vertices.empty() ? "" : " ", p.x(), p.y(), z);
    meshes += fmt::format("    <mesh name=\"{}\" vertex=\"{}\"/>\n",
                          escape(contact_geom(m, c, true)), vertices);
  }
  if (!meshes.empty()) out += "  <asset>\n" + meshes + "  </asset>\n";
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
  out += arc_sites(m, s, 0, "    ");
  write_body(m, s, 0, children, 2, o, written, out);
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
  // A driver as a tendon: the clock's (one driver), and a floating link's angle in crosslink's
  // runs.
  const auto tendon_written = [&](size_t d) { return clock || (o.driven && s.driven[d].floating); };
  bool driver_tendon_written = false;
  for (size_t d = 0; d < s.driven.size(); ++d) driver_tendon_written |= tendon_written(d);
  const auto fixed = [&](const std::string& name, const std::vector<std::pair<int, double>>& terms,
                         const std::string& attributes = "") {
    out += fmt::format("    <fixed name=\"{}\"{}>\n", escape(name), attributes);
    for (const auto& [joint, coefficient] : terms)
      out += fmt::format("      <joint joint=\"{}\" coef=\"{:.17g}\"/>\n",
                         escape(s.joints[joint].name), coefficient);
    out += "    </fixed>\n";
  };
  const bool friction_tendons =
      std::any_of(s.joints.begin(), s.joints.end(),
                  [](const SceneJoint& j) { return !j.friction_terms.empty(); });
  if (driver_tendon_written || !s.couplings.empty() || friction_tendons || !s.arcs.empty()) {
    out += "  <tendon>\n";
    for (size_t d = 0; d < s.driven.size(); ++d)
      if (tendon_written(d)) fixed(s.driver_names[d], s.driven[d].terms);
    if (clock)
      out +=
          "    <fixed name=\"clock\">\n      <joint joint=\"clock\" coef=\"1\"/>\n    </fixed>\n";
    for (const SceneCoupling& c : s.couplings) fixed(m.joints[c.source].name, c.terms);
    for (const SceneArc& a : s.arcs)
      out += fmt::format(
          "    <spatial name=\"{}\">\n      <site site=\"{}\"/>\n      <site site=\"{}\"/>\n"
          "    </spatial>\n",
          escape(m.joints[a.source].name), escape(arc_site(m, a, true)),
          escape(arc_site(m, a, false)));
    for (const SceneJoint& j : s.joints)
      if (!j.friction_terms.empty()) {
        if (o.standalone) out += friction_comment(j, "    ");
        fixed(j.friction_tendon(), j.friction_terms, friction_attributes(j, o));
      }
    out += "  </tendon>\n";
  }
  if (clock && clock->torque != 0.0)  // a constant torque: no gain, the bias alone
    out += fmt::format(
        "  <actuator>\n    <general name=\"clock\" joint=\"clock\" gainprm=\"0\" "
        "biastype=\"affine\" biasprm=\"{:.17g} 0 0\"/>\n  </actuator>\n",
        clock->torque);
  // The constraint rows are the equalities' (3 per connect, 1 per tendon or joint equality), one
  // per joint with friction loss and one per cam's contact pair: no limits, no other contacts.
  // <size> holds MuJoCo to them: without it MuJoCo 2.2.2 sizes every mjData for 500 rows and 100
  // contacts (about 13 MB, zeroed at each mj_makeData), and its stack from those by its own rule
  // (user_model.cc: 5 (njmax + neq + nv)^2 + 20 per element, at least 1000), which stays its rule
  // here, from these rows.
  int rows = 3 * static_cast<int>(s.cuts.size());
  for (const SceneJoint& sj : s.joints) rows += sj.friction ? 1 : 0;
  std::string equality = "  <equality>\n";
  for (int j : s.cuts) {
    const SceneJoint& sj = s.joints[j];
    equality += fmt::format(
        "    <connect name=\"{}\" body1=\"{}\" body2=\"{}\" anchor=\"{:.17g} {:.17g} 0\" "
        "solref=\"{}\" solimp=\"{}\"/>\n",
        escape(sj.name), s.links[sj.a].ground ? "world" : escape(s.links[sj.a].name),
        s.links[sj.b].ground ? "world" : escape(s.links[sj.b].name), sj.ua.x(), sj.ua.y(),
        vec(o.solref), vec(o.solimp));
  }
  std::vector<int> held;  // the joints a tendon equality holds: gear pairs, racks, curved slots
  for (const SceneCoupling& c : s.couplings) held.push_back(c.source);
  for (const SceneArc& a : s.arcs) held.push_back(a.source);
  for (const int joint : held) {
    ++rows;
    equality += fmt::format(
        "    <tendon name=\"{0}\" tendon1=\"{0}\" polycoef=\"0 0 0 0 0\" solref=\"{1}\" "
        "solimp=\"{2}\"/>\n",
        escape(m.joints[static_cast<size_t>(joint)].name), vec(o.solref), vec(o.solimp));
  }
  // MuJoCo's equalities hold changes from qpos0 (the start): the driver's equals the clock's.
  for (size_t d = 0; d < s.driven.size(); ++d) {
    if (clock || tendon_written(d) || o.driven) ++rows;
    const std::string name = escape(s.driver_names[d]);
    if (clock)
      equality += fmt::format(
          "    <tendon name=\"{0}\" tendon1=\"{0}\" tendon2=\"clock\" polycoef=\"0 1 0 0 0\" "
          "solref=\"{1}\" solimp=\"{2}\"/>\n",
          name, vec(o.driver_solref), vec(o.driver_solimp));
    else if (tendon_written(d))
      equality += fmt::format(
          "    <tendon name=\"{0}\" tendon1=\"{0}\" polycoef=\"0 0 0 0 0\" solref=\"{1}\" "
          "solimp=\"{2}\"/>\n",
          name, vec(o.driver_solref), vec(o.driver_solimp));
    else if (o.driven)
      equality += fmt::format(
          "    <joint name=\"{}\" joint1=\"{}\" polycoef=\"0 0 0 0 0\" solref=\"{}\" "
          "solimp=\"{}\"/>\n",
          name, escape(s.joints[s.driven[d].joint].name), vec(o.driver_solref),
          vec(o.driver_solimp));
  }
  equality += "  </equality>\n";
  // A frictionless contact (condim 1) is one row.
  const int pairs = static_cast<int>(s.contacts.size());
  out += fmt::format("  <size njmax=\"{}\" nconmax=\"{}\"/>\n", rows + pairs, pairs);
  out += equality;
  if (contacts) {
    out += "  <contact>\n";
    for (const SceneContact& c : s.contacts)
      out += fmt::format(
          "    <pair geom1=\"{}\" geom2=\"{}\" condim=\"1\" solref=\"{}\" solimp=\"{}\"/>\n",
          escape(contact_geom(m, c, true)), escape(contact_geom(m, c, false)),
          vec(o.contact_solref), vec(o.contact_solimp));
    out += "  </contact>\n";
  }
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
