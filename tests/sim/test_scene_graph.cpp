// The scene graph's topology decisions, checked as properties on bundled definitions under both
// engines' tree policies: the tree spans every body from the ground, parents first; the driven
// joint is in it; it is the minimum spanning tree of the preference (driven joint, slides,
// ground pivots for Bullet, hinges); every cut is a hinge and there are as many cuts as the
// linkage has independent loops; a floating link's driven angle is the sum of its path's hinges.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <tuple>

#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/forces.h"
#include "sim/scene_graph.h"

namespace crosslink::sim {
namespace {

std::string bundled(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml";
}

TreePolicy mujoco_policy() {
  return {};
}
TreePolicy bullet_policy(bool multibody) {
  TreePolicy p;
  p.ground_pivots_first = true;
  p.planar_joints = true;
  p.split_loops = multibody;
  return p;
}

// Independent loops of the definition's own link graph (Euler: joints - links + 1, connected),
// and its pin-in-slot joints.
int loops(const Mechanism& m) {
  return static_cast<int>(m.joints.size()) - static_cast<int>(m.links.size()) + 1;
}
int pins_in_slots(const Mechanism& m) {
  int n = 0;
  for (const Joint& j : m.joints) n += j.type == JointType::pin_in_slot;
  return n;
}
int planar_joints(const SceneGraph& g) {
  int n = 0;
  for (const SceneJoint& j : g.joints) n += j.kind == SceneJoint::Kind::planar;
  return n;
}

// Per body: its tree joint to its parent (-1 none).
std::vector<int> parent_joints(const SceneGraph& g) {
  std::vector<int> out(g.bodies.size(), -1);
  for (size_t j = 0; j < g.joints.size(); ++j)
    if (g.joints[j].in_tree) {
      EXPECT_EQ(out[g.joints[j].child], -1) << "body with two parents";
      out[g.joints[j].child] = static_cast<int>(j);
    }
  return out;
}

// The preference the policy states, as a sort key (smaller: preferred).
std::tuple<int, int> preference(const SceneGraph& g, const TreePolicy& policy, int j) {
  const SceneJoint& sj = g.joints[j];
  if (j == g.driven.front().joint) return {0, j};
  if (sj.kind != SceneJoint::Kind::hinge) return {1, j};
  if (policy.ground_pivots_first && (g.bodies[sj.a].ground || g.bodies[sj.b].ground)) return {2, j};
  return {3, j};
}

// The tree joints from `body` up to the ground.
std::vector<int> path(const SceneGraph& g, const std::vector<int>& parent_joint, int body) {
  std::vector<int> out;
  for (int guard = 0; !g.bodies[body].ground; ++guard) {
    if (guard > static_cast<int>(g.bodies.size()) || parent_joint[body] < 0) {
      ADD_FAILURE() << "body " << g.bodies[body].name << " does not reach the ground";
      break;
    }
    out.push_back(parent_joint[body]);
    body = g.joints[parent_joint[body]].parent;
  }
  return out;
}

void check_graph(const std::string& name, int expected_loops, const TreePolicy& policy) {
  SCOPED_TRACE(name + (policy.planar_joints ? " (Bullet's policy)" : " (MuJoCo's policy)"));
  const Mechanism m = load_mechanism(bundled(name));
  ASSERT_EQ(loops(m), expected_loops) << "the linkage's loops, by its type";
  const SceneGraph g = scene_graph(m, policy);

  // Bodies: the ground first, every link, one block per pin-in-slot with the same mass model.
  ASSERT_EQ(g.bodies.size(), m.links.size() + static_cast<size_t>(pins_in_slots(m)));
  EXPECT_TRUE(g.bodies[0].ground);
  for (const SceneBody& b : g.bodies) {
    if (b.ground) continue;
    if (b.source >= 0) {
      EXPECT_EQ(b.mass, scene_mass(m, b.source).mass) << b.name;
      continue;
    }
    EXPECT_EQ(m.joints[b.joint].type, JointType::pin_in_slot);
    EXPECT_EQ(b.mass, auxiliary_mass(m)) << b.name;
    EXPECT_GT(b.inertia, 0.0) << b.name;
    EXPECT_EQ(g.bodies[b.guide].source, m.joints[b.joint].link_a);
    EXPECT_EQ(g.bodies[b.pin].source, m.joints[b.joint].link_b);
  }

  // The tree spans every body, parents before children.
  const std::vector<int> parent_joint = parent_joints(g);
  ASSERT_EQ(g.tree_order.size(), g.bodies.size() - 1);
  std::vector<bool> placed(g.bodies.size(), false);
  placed[0] = true;
  for (int j : g.tree_order) {
    const SceneJoint& sj = g.joints[j];
    ASSERT_TRUE(sj.in_tree);
    EXPECT_TRUE(placed[sj.parent]) << sj.name << ": its parent comes later";
    EXPECT_FALSE(placed[sj.child]) << sj.name;
    EXPECT_TRUE((sj.parent == sj.a && sj.child == sj.b) || (sj.parent == sj.b && sj.child == sj.a));
    placed[sj.child] = true;
  }
  for (size_t b = 1; b < g.bodies.size(); ++b) (void)path(g, parent_joint, static_cast<int>(b));

  // The driven joint is in the tree; the cuts are the joints left out, all hinges, one per loop
  // (Bullet: one more per planar joint, each of which closes a loop through the ground).
  ASSERT_EQ(g.driven.size(), 1u);
  EXPECT_TRUE(g.joints[g.driven.front().joint].in_tree);
  EXPECT_EQ(g.cut_slide, -1);
  EXPECT_EQ(static_cast<int>(g.cuts.size()), expected_loops + planar_joints(g));
  for (int c : g.cuts) {
    EXPECT_FALSE(g.joints[c].in_tree);
    EXPECT_EQ(g.joints[c].kind, SceneJoint::Kind::hinge) << g.joints[c].name;
  }

  // Minimum spanning tree of the preference (the cycle property), before any split: every tree
  // joint on the loop a cut closes is preferred to the cut.
  if (!policy.split_loops || planar_joints(g) == (g.driven.front().floating ? 1 : 0)) {
    for (int c : g.cuts) {
      const std::vector<int> pa = path(g, parent_joint, g.joints[c].a);
      const std::vector<int> pb = path(g, parent_joint, g.joints[c].b);
      for (int j : pa) {
        if (std::find(pb.begin(), pb.end(), j) != pb.end()) continue;  // above the loop
        EXPECT_LT(preference(g, policy, j), preference(g, policy, c))
            << g.joints[j].name << " in the tree, " << g.joints[c].name << " cut";
      }
      for (int j : pb) {
        if (std::find(pa.begin(), pa.end(), j) != pa.end()) continue;
        EXPECT_LT(preference(g, policy, j), preference(g, policy, c))
            << g.joints[j].name << " in the tree, " << g.joints[c].name << " cut";
      }
    }
  }
}

TEST(SceneGraph, SpansDrivesAndCutsOnePerLoop) {
  // Loops by the linkage's type: a four-bar and a slider-crank have one, Watt's and Stephenson's
  // six-bars two, IFToMM A02 (two four-bars sharing the crank) two, the pendulum none, Jansen's
  // leg (eight links) three, the shaper's quick return two.
  const std::vector<std::pair<std::string, int>> cases = {{"fourbar_crank_rocker", 1},
                                                          {"slider_crank_offset", 1},
                                                          {"watt_sixbar", 2},
                                                          {"stephenson_sixbar", 2},
                                                          {"iftomm_a02_double_fourbar", 2},
                                                          {"iftomm_a01_pendulum", 0},
                                                          {"jansen_leg", 3},
                                                          {"quick_return", 2},
                                                          {"polycentric_hinge", 2},
                                                          {"sewing_machine", 2},
                                                          {"wanzer_needle_bar", 2},
                                                          {"singular/slider_crank_from_slider", 1}};
  for (const auto& [name, expected] : cases) {
    check_graph(name, expected, mujoco_policy());
    check_graph(name, expected, bullet_policy(false));
    check_graph(name, expected, bullet_policy(true));
  }
}

// A floating link's angle (the polycentric hinge's theta4): under MuJoCo's policy the sum of the
// hinges on its tree path, each +-1, is its absolute angle whatever the bodies' angles (the sum
// telescopes); under Bullet's, its planar ground joint's angle.
TEST(SceneGraph, FloatingLinkAngleIsItsPathsHinges) {
  const Mechanism m = load_mechanism(bundled("polycentric_hinge"));
  ASSERT_EQ(m.drivers[0].type, DriverType::link_angle);
  const SceneGraph g = scene_graph(m, mujoco_policy());
  const DrivenCoordinate& d = g.driven.front();
  ASSERT_TRUE(d.floating);
  EXPECT_EQ(g.bodies[d.body].source, m.drivers[0].link);
  std::mt19937 random(19);
  std::uniform_real_distribution<double> angle(-10.0, 10.0);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> theta(g.bodies.size(), 0.0);
    for (size_t b = 1; b < g.bodies.size(); ++b) theta[b] = angle(random);
    for (size_t b = 1; b < g.bodies.size(); ++b)  // a block turns with its guide
      if (g.bodies[b].source < 0) theta[b] = theta[g.bodies[b].guide];
    double sum = 0.0;
    for (const auto& [j, coefficient] : d.terms) {
      ASSERT_EQ(g.joints[j].kind, SceneJoint::Kind::hinge);
      sum += coefficient * (theta[g.joints[j].b] - theta[g.joints[j].a]);
    }
    EXPECT_NEAR(sum, theta[d.body], 1e-12);
  }

  const SceneGraph bullet = scene_graph(m, bullet_policy(false));
  const DrivenCoordinate& planar = bullet.driven.front();
  ASSERT_TRUE(planar.floating);
  EXPECT_EQ(bullet.joints[planar.joint].kind, SceneJoint::Kind::planar);
  EXPECT_TRUE(bullet.bodies[bullet.joints[planar.joint].a].ground);
  EXPECT_EQ(bullet.joints[planar.joint].b, planar.body);
}

// Bullet's multibody: no loop closes inside one multibody (a subtree hanging from the ground):
// each cut joins two multibodies, or one and the ground. The Wanzer needle bar's loops close
// through its slides, so they cannot be split at a hinge.
TEST(SceneGraph, SplitLoopsCloseBetweenMultibodies) {
  for (const std::string name :
       {"fourbar_crank_rocker", "watt_sixbar", "stephenson_sixbar", "sewing_machine", "jansen_leg",
        "polycentric_hinge", "quick_return", "iftomm_a02_double_fourbar"}) {
    SCOPED_TRACE(name);
    const SceneGraph g = scene_graph(load_mechanism(bundled(name)), bullet_policy(true));
    ASSERT_EQ(g.split_error, "");
    const std::vector<int> parent_joint = parent_joints(g);
    const auto root = [&](int body) {
      const std::vector<int> up = path(g, parent_joint, body);
      return up.empty() ? 0 : g.joints[up.back()].child;
    };
    for (int c : g.cuts) {
      const SceneJoint& cut = g.joints[c];
      if (g.bodies[cut.a].ground || g.bodies[cut.b].ground) continue;
      EXPECT_NE(root(cut.a), root(cut.b)) << cut.name << " closes inside one multibody";
    }
    // Parents first holds with depth: each multibody's bodies in order of depth.
    int depth = 0;
    for (int j : g.tree_order) {
      const int d = static_cast<int>(path(g, parent_joint, g.joints[j].child).size());
      EXPECT_GE(d, depth);
      depth = d;
    }
  }
  EXPECT_NE(
      scene_graph(load_mechanism(bundled("wanzer_needle_bar")), bullet_policy(true)).split_error,
      "");
}

// A planetary train with its ring fixed (sun 24 teeth, planet 12, ring 48): the sun-planet pair
// on the moving carrier, (theta_s - theta_c) + 12/24 (theta_p - theta_c) = 0, spans three bodies;
// the planet-ring pair, (theta_p - theta_c) - 48/12 (0 - theta_c) = 0, two. Recombined, the first
// ties the sun to the carrier alone by Willis' formula, omega_s = (1 + 48/24) omega_c, and each
// output row is its mix of the input rows.
TEST(SceneGraph, APlanetaryTrainRecombinesByWillis) {
  constexpr int kSun = 1, kPlanet = 2, kCarrier = 3;
  const double sun_planet = 12.0 / 24.0, planet_ring = -48.0 / 12.0;
  const std::vector<std::vector<std::pair<int, double>>> rows{
      {{kSun, 1.0}, {kPlanet, sun_planet}, {kCarrier, -(1.0 + sun_planet)}},
      {{kPlanet, 1.0}, {kCarrier, -(1.0 + planet_ring)}}};
  CouplingRows out;
  ASSERT_EQ(reduce_couplings(rows, 2, out), -1);
  ASSERT_EQ(out.rows.size(), 2u);
  ASSERT_EQ(out.rows[0].size(), 2u);
  EXPECT_EQ(out.rows[0][0].first, kSun);
  EXPECT_EQ(out.rows[0][1].first, kCarrier);
  EXPECT_NEAR(-out.rows[0][1].second / out.rows[0][0].second, 1.0 + 48.0 / 24.0, 1e-15);
  EXPECT_EQ(out.rows[1], rows[1]);  // already two terms: left as it is
  // Every output row is its mix of the input rows, coordinate by coordinate.
  for (size_t i = 0; i < out.rows.size(); ++i)
    for (int c : {kSun, kPlanet, kCarrier}) {
      const auto value = [c](const std::vector<std::pair<int, double>>& row) {
        const auto it = std::find_if(row.begin(), row.end(), [c](auto t) { return t.first == c; });
        return it == row.end() ? 0.0 : it->second;
      };
      double mixed = 0.0;
      for (size_t k = 0; k < rows.size(); ++k)
        mixed +=
            out.mix(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) * value(rows[k]);
      EXPECT_NEAR(value(out.rows[i]), mixed, 1e-15) << "row " << i << " coordinate " << c;
    }
  // The sun-planet pair alone (a ring that is a moving body of its own) joins three bodies
  // whatever is done: it is named.
  EXPECT_EQ(reduce_couplings({rows[0]}, 2, out), 0);
}

// A pin in a curved slot (mechanisms/cams/curved_slot_rocker.toml, its slot an arc of radius 0.12
// about the rocker's C): an arm hinged at the arc's centre on the guide and at the pin, its frame
// at the pin with its x axis from the centre, so the arm turns with the line CP (its angle and
// rate against that line's from the exact motion, and its rate against a central difference of
// the angle over the exact sweep); or, under arc_rows, a row of the engine's own and no body.
TEST(SceneGraph, ACurvedSlotIsAnArmHingedAtItsCentreOrARow) {
  const Mechanism m = load_mechanism(bundled("cams/curved_slot_rocker"));
  const SceneGraph g = scene_graph(m);
  ASSERT_EQ(g.bodies.size(), 4u);  // ground, crank, rocker, the slot's arm
  const SceneBody& arm = g.bodies[3];
  EXPECT_EQ(arm.source, -1);
  EXPECT_EQ(arm.joint, 2);
  const auto named = [&](const std::string& name) {
    return std::find_if(g.joints.begin(), g.joints.end(),
                        [&](const SceneJoint& j) { return j.name == name; });
  };
  const auto centre = named("slot_centre"), pin = named("slot_pin");
  ASSERT_NE(centre, g.joints.end());
  ASSERT_NE(pin, g.joints.end());
  EXPECT_EQ(centre->kind, SceneJoint::Kind::hinge);
  EXPECT_TRUE(centre->block_guide);
  EXPECT_FALSE(pin->block_guide);
  EXPECT_EQ(centre->b, 3);
  EXPECT_EQ(pin->a, 3);
  EXPECT_DOUBLE_EQ(centre->ub.x(), -0.12);
  const Trajectory exact = sweep(m);
  const double h = exact.time(1) - exact.time(0);
  double worst_angle = 0.0, worst_rate = 0.0, worst_difference = 0.0;
  for (int i = 1; i + 1 < exact.samples(); ++i) {
    const Eigen::VectorXd q = coordinates_at(m, exact, i), qdot = rates_at(m, exact, i);
    const BodyMotion motion = body_motion(m, arm, q, &qdot);
    const auto point = [&](const char* axis, const char* name) {
      return Eigen::Vector2d(*exact.sample(fmt::format("{}x.{}", axis, name), i),
                             *exact.sample(fmt::format("{}y.{}", axis, name), i));
    };
    const Eigen::Vector2d c = point("", "C"), p = point("", "B");
    const Eigen::Vector2d vc = point("v", "C"), vp = point("v", "B");
    const Eigen::Vector2d d = p - c;
    worst_angle = std::max(
        worst_angle,
        std::abs(std::remainder(motion.theta - std::atan2(d.y(), d.x()), 2 * std::numbers::pi)));
    worst_rate = std::max(worst_rate, std::abs(motion.omega - cross(d, vp - vc) / d.squaredNorm()));
    const auto angle = [&](int k) {
      return body_motion(m, arm, coordinates_at(m, exact, k)).theta;
    };
    const double difference =
        std::remainder(angle(i + 1) - angle(i - 1), 2 * std::numbers::pi) / (2 * h);
    worst_difference = std::max(worst_difference, std::abs(motion.omega - difference));
    EXPECT_NEAR((motion.r - p).norm(), 0.0, 1e-15);
  }
  std::printf("arm: angle %.3g rad, rate %.3g rad/s from CP's; rate %.3g rad/s from differences\n",
              worst_angle, worst_rate, worst_difference);
  EXPECT_LT(worst_angle, 1e-12);
  EXPECT_LT(worst_rate, 1e-9);
  EXPECT_LT(worst_difference, 1e-3 * 8 * std::numbers::pi);  // O(h^2) of the crank's 8 pi rad/s

  const SceneGraph rows = scene_graph(m, TreePolicy{.arc_rows = true});
  EXPECT_EQ(rows.bodies.size(), 3u);
  ASSERT_EQ(rows.arcs.size(), 1u);
  EXPECT_EQ(rows.arcs[0].source, 2);
  EXPECT_EQ(rows.arcs[0].guide, 2);  // the rocker
  EXPECT_EQ(rows.arcs[0].pin, 1);    // the crank
  EXPECT_DOUBLE_EQ(rows.arcs[0].radius, 0.12);
  EXPECT_EQ(rows.joints.size(), 2u);  // the two ground pivots
}

}  // namespace
}  // namespace crosslink::sim
