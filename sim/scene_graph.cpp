#include "sim/scene_graph.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "analytic/model/constraints.h"
#include "sim/forces.h"

namespace crosslink::sim {
namespace {

constexpr int kGround = 0;  // the ground's body index

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

int add_planar_joint(SceneGraph& g, int body) {
  SceneJoint planar;
  planar.kind = SceneJoint::Kind::planar;
  planar.name = g.bodies[body].name + "_planar";
  planar.a = kGround;
  planar.b = body;
  g.joints.push_back(planar);
  return static_cast<int>(g.joints.size()) - 1;
}

// The joint that realises driver `d`, and how its value maps to the driver.
DrivenCoordinate drive(const Mechanism& m, const Driver& d, SceneGraph& g,
                       const std::vector<int>& body_of_link, const std::vector<int>& joint_of,
                       const TreePolicy& policy) {
  DrivenCoordinate driven;
  double arm = 0.0;  // angle of the measured direction in its link's frame
  if (d.from >= 0 && d.to >= 0) {
    const Eigen::Vector2d v =
        m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local;
    arm = std::atan2(v.y(), v.x());
  }
  if (d.type == DriverType::slider) {
    driven.joint = joint_of[d.joint];  // the slide (a pin-in-slot's block slide)
    return driven;
  }
  if (d.type == DriverType::joint_angle) {
    driven.joint = joint_of[d.joint];  // value = theta_b - theta_a = driver - arm
    driven.offset = arm;
    return driven;
  }
  // Link angle: direct when the link turns about a ground pivot.
  const int ground = body_of_link[m.ground()], link = body_of_link[d.link];
  for (size_t j = 0; j < g.joints.size(); ++j) {
    const SceneJoint& sj = g.joints[j];
    if (sj.kind != SceneJoint::Kind::hinge) continue;
    if ((sj.a == ground && sj.b == link) || (sj.a == link && sj.b == ground)) {
      driven.joint = static_cast<int>(j);
      driven.offset = arm;
      driven.sign = sj.b == link ? 1.0 : -1.0;
      return driven;
    }
  }
  // A floating link's angle: a planar ground joint's, or the sum of the hinges from the ground to
  // the link (terms, once the tree is known), with one of the link's hinges first into the tree.
  driven.offset = arm;
  driven.floating = true;
  driven.body = link;
  if (policy.planar_joints) {
    driven.joint = add_planar_joint(g, link);
    return driven;
  }
  for (size_t j = 0; j < g.joints.size(); ++j)
    if (g.joints[j].kind == SceneJoint::Kind::hinge &&
        (g.joints[j].a == link || g.joints[j].b == link)) {
      driven.joint = static_cast<int>(j);
      return driven;
    }
  throw std::runtime_error(
      "the driver is the angle of a link that no revolute joint turns: nothing can drive it");
}

// The joints in the order the tree prefers them (SceneGraph::tree_order's comment).
std::vector<int> preference(const SceneGraph& g, const TreePolicy& policy) {
  std::vector<int> order;
  std::vector<bool> taken(g.joints.size(), false);
  const auto take = [&](auto wanted) {
    for (size_t j = 0; j < g.joints.size(); ++j)
      if (!taken[j] && wanted(g.joints[j])) {
        taken[j] = true;
        order.push_back(static_cast<int>(j));
      }
  };
  for (const DrivenCoordinate& d : g.driven)
    if (!taken[static_cast<size_t>(d.joint)]) {
      taken[static_cast<size_t>(d.joint)] = true;
      order.push_back(d.joint);
    }
  take([](const SceneJoint& j) { return j.kind != SceneJoint::Kind::hinge; });
  if (policy.ground_pivots_first)
    take([](const SceneJoint& j) { return j.a == kGround || j.b == kGround; });
  take([](const SceneJoint&) { return true; });
  return order;
}

// The tree grown from the ground in passes over the preference, each pass taking every tree
// joint that reaches a new body: its bodies, parents first. (MuJoCo numbers a body's children in
// this order.)
std::vector<int> grow(SceneGraph& g, const std::vector<int>& preferred) {
  std::vector<bool> placed(g.bodies.size(), false);
  placed[kGround] = true;
  std::vector<int> order;
  for (bool progress = true; progress;) {
    progress = false;
    for (int j : preferred) {
      SceneJoint& sj = g.joints[j];
      if (!sj.in_tree || placed[sj.a] == placed[sj.b]) continue;
      sj.parent = placed[sj.a] ? sj.a : sj.b;
      sj.child = placed[sj.a] ? sj.b : sj.a;
      placed[sj.child] = true;
      order.push_back(sj.child);
      progress = true;
    }
  }
  return order;
}

// Per body: its tree joint to its parent (-1: the ground).
std::vector<int> parent_joints(const SceneGraph& g) {
  std::vector<int> out(g.bodies.size(), -1);
  for (size_t j = 0; j < g.joints.size(); ++j)
    if (g.joints[j].in_tree) out[g.joints[j].child] = static_cast<int>(j);
  return out;
}

void list_cuts(SceneGraph& g) {
  g.cuts.clear();
  for (size_t j = 0; j < g.joints.size(); ++j)
    if (!g.joints[j].in_tree) g.cuts.push_back(static_cast<int>(j));
}

// TreePolicy::split_loops on the tree grown as `order` (bodies, parents first): "" or why not.
std::string split_loops(SceneGraph& g, std::vector<int>& order) {
  std::vector<int> up;  // per body, its tree joint to its parent, as the tree stands
  const auto parent = [&](int body) { return up[body] < 0 ? -1 : g.joints[up[body]].parent; };
  const auto root_of = [&](int body) {
    while (parent(body) != kGround) body = parent(body);
    return body;
  };
  const auto is_ancestor = [&](int a, int body) {
    for (; body != kGround; body = parent(body))
      if (body == a) return true;
    return false;
  };
  for (int guard = 0; guard < 100; ++guard) {
    list_cuts(g);
    up = parent_joints(g);
    bool changed = false;
    for (int c : g.cuts) {
      const SceneJoint& cut = g.joints[c];
      if (cut.kind != SceneJoint::Kind::hinge)
        return "a loop would have to be cut at a slide joint";
      if (cut.a == kGround || cut.b == kGround || root_of(cut.a) != root_of(cut.b)) continue;
      const int x = is_ancestor(cut.a, cut.b) ? cut.b : cut.a;
      SceneJoint& old = g.joints[up[x]];
      if (old.kind != SceneJoint::Kind::hinge)
        return "a loop inside one multibody can only be split at a slide joint";
      old.in_tree = false;
      old.parent = old.child = -1;
      SceneJoint& planar = g.joints[add_planar_joint(g, x)];
      planar.in_tree = true;
      planar.parent = kGround;
      planar.child = x;
      changed = true;
      break;
    }
    if (!changed) {
      // Parents must come first within each multibody: re-sort by depth.
      const auto depth = [&](int body) {
        int k = 0;
        for (; parent(body) != kGround; body = parent(body)) ++k;
        return k;
      };
      std::stable_sort(order.begin(), order.end(),
                       [&](int a, int b) { return depth(a) < depth(b); });
      return "";
    }
  }
  return "could not split the loops into multibodies";
}

// The tree joints from `body` up to the ground, nearest first.
std::vector<int> tree_path(const SceneGraph& g, int body) {
  const std::vector<int> parent_joint = parent_joints(g);
  std::vector<int> out;
  for (; parent_joint[body] >= 0; body = g.joints[parent_joint[body]].parent)
    out.push_back(parent_joint[body]);
  return out;
}

// Adds coefficient x (body's angle) to `terms`, as the tree's hinges (or planar joint) up to the
// ground.
void add_angle(const SceneGraph& g, int body, double coefficient,
               std::vector<std::pair<int, double>>& terms) {
  for (int t : tree_path(g, body)) {
    const SceneJoint& sj = g.joints[static_cast<size_t>(t)];
    if (sj.kind == SceneJoint::Kind::slide) continue;  // the angle is the guide's
    const double sign =
        sj.kind == SceneJoint::Kind::planar || sj.child == sj.b ? coefficient : -coefficient;
    const auto it =
        std::find_if(terms.begin(), terms.end(), [&](const auto& term) { return term.first == t; });
    if (it == terms.end())
      terms.emplace_back(t, sign);
    else
      it->second += sign;
  }
}

// Gearing `joint` over the tree's coordinates (SceneCoupling).
SceneCoupling coupling(const Mechanism& m, int joint, const SceneGraph& g,
                       const std::vector<int>& body_of_link, const std::vector<int>& joint_of) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  SceneCoupling c;
  c.source = joint;
  const auto add_angle = [&](int link, double coefficient) {
    sim::add_angle(g, body_of_link[static_cast<size_t>(link)], coefficient, c.terms);
  };
  if (j.type == JointType::gear) {
    add_angle(j.link_a, 1.0);
    add_angle(j.link_b, j.ratio);
    add_angle(j.carrier, -(1.0 + j.ratio));
    c.on_first = m.moving_index(j.link_a) >= 0 ? 1.0 : j.ratio;
  } else {
    if (m.moving_index(j.link_a) < 0)
      throw std::runtime_error(fmt::format(
          "joint '{}': the pinion of a rack and pinion is the ground; no engine scene takes it",
          j.name));
    c.slide = joint_of[static_cast<size_t>(j.slide)];
    if (!g.joints[static_cast<size_t>(c.slide)].in_tree)
      throw std::runtime_error(fmt::format(
          "joint '{}': the rack's slide '{}' closes a loop, so it is no coordinate of the tree the "
          "rack and pinion couples",
          j.name, m.joints[static_cast<size_t>(j.slide)].name));
    c.terms.emplace_back(c.slide, 1.0);
    add_angle(j.link_a, -j.ratio);
    add_angle(j.carrier, j.ratio);
    c.on_first = -j.ratio;
  }
  std::erase_if(c.terms, [](const auto& term) { return term.second == 0.0; });
  return c;
}

// The cam's centre (the point it turns about), local on the cam (joint j's link_a).
Eigen::Vector2d cam_centre(const Mechanism& m, const Joint& j) {
  return m.links[static_cast<size_t>(j.link_a)].points[static_cast<size_t>(j.centre_a)].local;
}

// The centre of an eccentric cam's disc, local on the cam.
Eigen::Vector2d disc_centre(const Mechanism& m, const Joint& j, const cam::EccentricCam& disc) {
  return cam_centre(m, j) +
         disc.eccentricity * Eigen::Vector2d(std::cos(disc.angle), std::sin(disc.angle));
}

// A cam whose profile is not a disc as a convex polygon of `facets` vertices on its profile, local
// on the cam (SceneContact::cam_polygon), moved in by `inset` (a knife edge's sphere); sets the
// polygon and its prism's half thickness, and returns its largest radius from c.cam_centre.
double cam_polygon(const Mechanism& m, const Joint& j, int facets, double inset, SceneContact& c) {
  const Eigen::Vector2d& centre = c.cam_centre;
  double largest = 0.0;
  for (const CamContact& p : cam_profile(m, j, facets)) {
    c.cam_polygon.push_back(p.point - inset * p.normal);
    largest = std::max(largest, (c.cam_polygon.back() - centre).norm());
  }
  // The engine's mesh is its convex hull: a concave stretch would be bridged, not followed.
  const size_t n = c.cam_polygon.size();
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d& a = c.cam_polygon[k];
    const Eigen::Vector2d& b = c.cam_polygon[(k + 1) % n];
    const Eigen::Vector2d& d = c.cam_polygon[(k + 2) % n];
    if (cross(b - a, d - b) < -1e-12 * (b - a).squaredNorm()) {
      const Eigen::Vector2d u = b - centre;
      throw std::runtime_error(fmt::format(
          "joint '{}': the profile is concave at {:.1f} deg in the cam's frame; an engine's mesh "
          "of it is its convex hull, which would bridge the hollow; the exact methods solve it",
          j.name, std::atan2(u.y(), u.x()) * 180.0 / std::numbers::pi));
    }
  }
  c.cam_half_thickness = 0.25 * largest;
  return largest;
}

// Cam joint `joint` as contact (SceneContacts, appended to `out`): an eccentric cam's disc, or
// (facets > 0) any other convex profile as a prism, and a roller, knife edge or flat face; a flat
// face in a groove round its disc (a yoke) as two faces about it.
void add_contacts(const Mechanism& m, int joint, const std::vector<int>& body_of_link,
                  const TreePolicy& policy, std::vector<SceneContact>& out) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  const cam::EccentricCam* disc = j.contour->eccentric();
  const cam::Follower& follower = j.contour->follower();
  const int facets = policy.cam_facets;
  if (!disc && facets == 0)
    throw std::runtime_error(fmt::format(
        "joint '{}': this engine holds a follower on a cam by contact with a disc (an eccentric "
        "cam) only; a profile cut from a motion law, a tangent cam or a profile given by points "
        "would be a mesh, {}",
        j.name, policy.no_mesh));
  // A groove holds the follower both ways; a contact only pushes. (A roller or knife edge in a
  // groove round a disc is a point on a circle, arc_geometry's, and no contact; a flat face, two.)
  if (j.form_closed && !disc)
    throw std::runtime_error(fmt::format(
        "joint '{}': a groove round a profile that is not a disc holds the follower both ways, "
        "and its outer wall is concave, which no engine's convex shape is; the exact methods "
        "solve it",
        j.name));
  SceneContact c;
  c.source = joint;
  c.cam = body_of_link[static_cast<size_t>(j.link_a)];
  c.follower = body_of_link[static_cast<size_t>(j.link_b)];
  // A knife edge is a sphere of a quarter of the disc's radius on a disc smaller by as much; on a
  // polygon, of half the profile's least radius of curvature, on the profile moved in by as much.
  const bool knife = follower.kind == cam::FollowerKind::knife_edge;
  const double knife_radius =
      disc ? 0.25 * disc->radius : 0.5 * j.contour->least_radius_of_curvature();
  double size = 0.0;  // the cam's radius
  if (disc) {
    c.cam_centre = disc_centre(m, j, *disc);
    c.cam_radius = disc->radius - (knife ? knife_radius : 0.0);
    size = disc->radius;
  } else {
    c.cam_centre = cam_centre(m, j);
    size = cam_polygon(m, j, facets, knife ? knife_radius : 0.0, c);
  }
  c.margin = 0.1 * size;
  const Link& on = m.links[static_cast<size_t>(j.link_b)];
  if (follower.kind == cam::FollowerKind::flat_faced) {
    const Line& face = on.lines[static_cast<size_t>(j.line)];
    const Eigen::Vector2d away = perp(face.direction);  // +90 deg from the line: from the cam
    const double half = 0.125 * size;
    c.face = true;
    c.follower_centre = face.origin + half * away;
    c.box_angle = std::atan2(face.direction.y(), face.direction.x());
    c.box_half = {2.0 * m.size() + 4.0 * size, half, half};
    out.push_back(c);
    if (j.form_closed) {  // a disc's breadth is its diameter in every direction
      c.far = true;
      c.follower_centre = face.origin - (2.0 * disc->radius + half) * away;
      c.box_angle += std::numbers::pi;
      out.push_back(c);
    }
    return;
  }
  c.follower_centre = on.points[static_cast<size_t>(j.point_b)].local;
  c.follower_radius = knife ? knife_radius : follower.roller_radius;
  out.push_back(c);
}

}  // namespace

int reduce_couplings(const std::vector<std::vector<std::pair<int, double>>>& rows, int most,
                     CouplingRows& out) {
  // Dense over the coordinates the rows name; a greedy elimination: a row with too many terms
  // less the multiple of another that cancels a shared coordinate, when that leaves it fewer
  // terms. Terms below round-off of the row's largest are cancelled.
  std::vector<int> coordinates;
  for (const auto& row : rows)
    for (const auto& [c, value] : row)
      if (std::find(coordinates.begin(), coordinates.end(), c) == coordinates.end())
        coordinates.push_back(c);
  const auto n = static_cast<Eigen::Index>(rows.size());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(coordinates.size()));
  for (Eigen::Index i = 0; i < n; ++i)
    for (const auto& [c, value] : rows[static_cast<size_t>(i)])
      a(i, std::find(coordinates.begin(), coordinates.end(), c) - coordinates.begin()) += value;
  Eigen::MatrixXd mix = Eigen::MatrixXd::Identity(n, n);
  const auto terms = [](const Eigen::VectorXd& row) {
    const double scale = row.cwiseAbs().maxCoeff();
    return static_cast<int>((row.array().abs() > 1e-12 * scale).count());
  };
  for (bool reduced = true; reduced;) {
    reduced = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (terms(a.row(i)) <= most) continue;
      for (Eigen::Index k = 0; k < n && !reduced; ++k)
        for (Eigen::Index c = 0; c < a.cols() && k != i && !reduced; ++c) {
          if (a(i, c) == 0.0 || a(k, c) == 0.0) continue;
          const double factor = a(i, c) / a(k, c);
          Eigen::VectorXd row = a.row(i) - factor * a.row(k);
          row(c) = 0.0;
          if (terms(row) >= terms(a.row(i))) continue;
          const double scale = row.cwiseAbs().maxCoeff();
          for (Eigen::Index e = 0; e < row.size(); ++e)
            if (std::abs(row(e)) <= 1e-12 * scale) row(e) = 0.0;
          a.row(i) = row;
          mix.row(i) -= factor * mix.row(k);
          reduced = true;
        }
    }
  }
  out = {};
  for (Eigen::Index i = 0; i < n; ++i) {
    if (terms(a.row(i)) > most) return static_cast<int>(i);
    // The input row's own coordinates first, in its order, then any another row brought in.
    std::vector<int> order;
    for (const auto& [c, value] : rows[static_cast<size_t>(i)]) order.push_back(c);
    for (int c : coordinates)
      if (std::find(order.begin(), order.end(), c) == order.end()) order.push_back(c);
    std::vector<std::pair<int, double>> row;
    for (int c : order) {
      const double value =
          a(i, std::find(coordinates.begin(), coordinates.end(), c) - coordinates.begin());
      if (value != 0.0) row.emplace_back(c, value);
    }
    out.rows.push_back(std::move(row));
  }
  out.mix = std::move(mix);
  return -1;
}

std::optional<ArcGeometry> arc_geometry(const Mechanism& m, const Joint& j) {
  if (j.type == JointType::pin_in_arc)
    return ArcGeometry{m.links[j.link_a].points[j.centre_a].local,
                       m.links[j.link_b].points[j.point_b].local, j.radius_a};
  if (j.type != JointType::cam || !j.form_closed || j.contour->flat_faced()) return std::nullopt;
  const cam::EccentricCam* disc = j.contour->eccentric();
  if (!disc) return std::nullopt;
  const cam::Follower& follower = j.contour->follower();
  return ArcGeometry{
      disc_centre(m, j, *disc), m.links[j.link_b].points[j.point_b].local,
      disc->radius + (follower.kind == cam::FollowerKind::roller ? follower.roller_radius : 0.0)};
}

BodyMotion body_motion(const Mechanism& m, const SceneBody& body, const Eigen::VectorXd& q,
                       const Eigen::VectorXd* qdot) {
  if (body.source >= 0) return BodyMotion::of(m.moving_index(body.source), q, qdot, nullptr);
  const Joint& j = m.joints[body.joint];
  BodyMotion block = BodyMotion::of(m.moving_index(j.link_a), q, qdot, nullptr);
  const BodyMotion pin = BodyMotion::of(m.moving_index(j.link_b), q, qdot, nullptr);
  if (const std::optional<ArcGeometry> arc = arc_geometry(m, j)) {
    // The arm's angle is the line CP's, on the turn nearest its guide's.
    const Eigen::Vector2d d = pin.position(body.pin_point) - block.position(arc->centre);
    const double theta = block.theta + std::remainder(std::atan2(d.y(), d.x()) - block.theta,
                                                      2.0 * std::numbers::pi);
    if (qdot)
      block.omega =
          cross(d, pin.velocity(body.pin_point) - block.velocity(arc->centre)) / d.squaredNorm();
    block.theta = theta;
    block.rotation = Eigen::Rotation2Dd(theta).toRotationMatrix();
  }
  block.r = pin.position(body.pin_point);
  block.v = pin.velocity(body.pin_point);
  return block;
}

std::vector<std::pair<int, double>> relative_angle_terms(const SceneGraph& g, int joint) {
  const SceneJoint& j = g.joints[static_cast<size_t>(joint)];
  std::vector<std::pair<int, double>> terms;
  add_angle(g, j.b, 1.0, terms);
  add_angle(g, j.a, -1.0, terms);
  std::erase_if(terms, [](const auto& term) { return term.second == 0.0; });
  return terms;
}

SceneGraph scene_graph(const Mechanism& m, const TreePolicy& policy) {
  SceneGraph g;

  // Bodies: ground first, then the moving links in Mechanism order.
  std::vector<int> body_of_link(m.links.size());
  std::vector<int> order{m.ground()};
  for (size_t l = 0; l < m.links.size(); ++l)
    if (!m.links[l].ground) order.push_back(static_cast<int>(l));
  for (int l : order) {
    SceneBody body;
    body.name = m.links[l].name;
    body.source = l;
    body.ground = m.links[l].ground;
    const MassProperties mp = scene_mass(m, l);
    body.mass = mp.mass;
    body.centre = mp.com;
    body.inertia = mp.inertia;
    body_of_link[l] = static_cast<int>(g.bodies.size());
    g.bodies.push_back(body);
  }

  // Joints; a pin-in-slot becomes a block sliding on the line plus a hinge at the pin, a point on
  // a circle (a pin-in-arc, a grooved disc's roller) an arm hinged at the centre and at the pin.
  std::vector<int> joint_of(m.joints.size(), -1);
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (j.is_gearing()) continue;  // a SceneCoupling, once the tree is known
    if (j.type == JointType::pin_in_spline)
      throw std::runtime_error(fmt::format(
          "joint '{}': a pin in a spline slot is not built in the engines: none has a point-on-"
          "curve row for a curve other than a line or a circle (a groove's walls as contact "
          "shapes, or a custom constraint, would be the engine's own model); the exact methods "
          "solve it (docs/cams.md, \"Spline slots\")",
          j.name));
    // A point held on a circle: the engine's own row, or an arm between two hinges (below).
    const std::optional<ArcGeometry> arc = arc_geometry(m, j);
    if (arc && policy.arc_rows) {
      g.arcs.push_back(
          {*arc, static_cast<int>(ji), body_of_link[j.link_a], body_of_link[j.link_b]});
      continue;
    }
    if (j.type == JointType::cam && !arc) {
      if (!policy.contacts)
        throw std::runtime_error(fmt::format(
            "joint '{}': a cam is in this engine's scene only as contact, which it does not "
            "model yet (docs/cams.md, \"The engines' contact\"); the exact methods solve it",
            j.name));
      add_contacts(m, static_cast<int>(ji), body_of_link, policy, g.contacts);
      continue;
    }
    SceneJoint sj;
    sj.name = j.name;
    sj.source = static_cast<int>(ji);
    sj.a = body_of_link[j.link_a];
    sj.b = body_of_link[j.link_b];
    sj.ub = arc ? arc->point : m.links[j.link_b].points[j.point_b].local;
    joint_of[ji] = static_cast<int>(g.joints.size());
    if (j.type == JointType::revolute) {
      sj.ua = m.links[j.link_a].points[j.point_a].local;
      g.joints.push_back(sj);
      continue;
    }
    if (arc) {
      sj.ua = arc->centre;
    } else {
      const Line& line = m.links[j.link_a].lines[j.line];
      sj.kind = SceneJoint::Kind::slide;
      sj.origin = line.origin;
      sj.direction = line.direction;
      sj.relative_angle = j.relative_angle;
    }
    if (j.type == JointType::prismatic) {
      g.joints.push_back(sj);
      continue;
    }
    SceneBody block;
    block.name = j.name + "_block";
    block.joint = static_cast<int>(ji);
    block.guide = sj.a;
    block.pin = sj.b;
    block.pin_point = sj.ub;
    block.mass = auxiliary_mass(m);
    block.inertia = block.mass * 1e-4 * m.size() * m.size();
    const int k = static_cast<int>(g.bodies.size());
    g.bodies.push_back(block);
    SceneJoint pin;
    pin.name = j.name + "_pin";
    pin.source = static_cast<int>(ji);
    pin.a = k;
    pin.b = sj.b;
    pin.ub = sj.ub;
    sj.name = j.name;
    sj.name += sj.kind == SceneJoint::Kind::slide ? "_slide" : "_centre";
    sj.b = k;
    // The arm's frame sits at the pin, its x axis along the radius.
    sj.ub = arc ? Eigen::Vector2d(-arc->radius, 0.0) : Eigen::Vector2d::Zero();
    sj.relative_angle = 0.0;
    sj.block_guide = true;
    g.joints.push_back(sj);
    g.joints.push_back(pin);
  }

  // One driven coordinate per driver (Mechanism::drivers order).
  for (const Driver& d : m.drivers)
    g.driven.push_back(drive(m, d, g, body_of_link, joint_of, policy));

  // The spanning tree (Kruskal over the preference), the cuts, and the tree grown from the ground.
  const std::vector<int> preferred = preference(g, policy);
  Components components(g.bodies.size());
  size_t joined = 0;
  for (int j : preferred) {
    SceneJoint& sj = g.joints[j];
    sj.in_tree = components.join(sj.a, sj.b);
    if (sj.in_tree) ++joined;
  }
  if (joined + 1 != g.bodies.size())
    throw std::runtime_error(
        g.arcs.empty() ? "some links are not connected to the ground by joints"
                       : "some links are not connected to the ground by joints but curved "
                         "slots, which this engine holds as rows outside its tree");
  list_cuts(g);
  for (int c : g.cuts)
    if (g.joints[c].kind != SceneJoint::Kind::hinge) {
      g.cut_slide = c;
      break;
    }
  std::vector<int> bodies = grow(g, preferred);
  if (policy.split_loops) {
    SceneGraph split = g;
    std::vector<int> split_order = bodies;
    g.split_error = split_loops(split, split_order);
    if (g.split_error.empty()) {
      g = std::move(split);
      bodies = std::move(split_order);
    }
  }
  const std::vector<int> parent_joint = parent_joints(g);
  for (int body : bodies) g.tree_order.push_back(parent_joint[body]);

  // A floating link's angle: its planar joint's, or the hinges on its path from the ground, each
  // +1 when the child is the hinge's b (theta_child = theta_parent + value), -1 when it is a.
  for (DrivenCoordinate& d : g.driven) {
    if (!d.floating) {
      d.terms = {{d.joint, d.sign}};
      continue;
    }
    d.path = tree_path(g, d.body);
    if (policy.planar_joints) {
      d.terms = {{d.joint, 1.0}};
      continue;
    }
    for (int j : d.path)
      if (g.joints[j].kind == SceneJoint::Kind::hinge)
        d.terms.emplace_back(j, g.joints[j].child == g.joints[j].b ? 1.0 : -1.0);
    if (d.terms.empty())
      throw std::runtime_error(fmt::format(
          "the driver is the angle of link {}, which no revolute joint between it and the ground "
          "turns",
          g.bodies[d.body].name));
  }

  for (size_t ji = 0; ji < m.joints.size(); ++ji)
    if (m.joints[ji].is_gearing())
      g.couplings.push_back(coupling(m, static_cast<int>(ji), g, body_of_link, joint_of));
  return g;
}

}  // namespace crosslink::sim
