// Bullet 3.24 (float64) scene of a Mechanism: build, step, sample. See docs/engines.md, "Bullet".
//
// The scene is a kinematic projection integrator in disguise: every freedom is fixed by a joint,
// a loop constraint or the driver, so with an exact MLCP solve and ERP 1 each step is one Newton
// step of the constraint equations towards the driver's next value, and masses only condition
// the solve. Positions are therefore accurate to O(dt^2); velocities and accelerations come from
// central differences of positions centred on each sample.
#include "sim/bullet/bullet_engine.h"

#include "analytic/reference/trust.h"
#include "sim/dynamics_run.h"
#include "sim/forces.h"
#include "sim/kinematic_run.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"
#include "sim/scene_graph.h"
#include "sim/settings.h"
#include "sim/shared_settings.h"
#include "sim/statuses.h"

#include <btBulletDynamicsCommon.h>
#include <fmt/format.h>

#include <BulletCollision/CollisionShapes/btEmptyShape.h>
#include <BulletDynamics/ConstraintSolver/btGearConstraint.h>
#include <BulletDynamics/ConstraintSolver/btGeneric6DofSpring2Constraint.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyGearConstraint.h>
#include <BulletDynamics/Featherstone/btMultiBodyJointMotor.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <BulletDynamics/Featherstone/btMultiBodyMLCPConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>
#include <BulletDynamics/MLCPSolvers/btDantzigSolver.h>
#include <BulletDynamics/MLCPSolvers/btMLCPSolver.h>
#include <LinearMath/btQuickprof.h>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "analytic/kinematics/newton.h"
#include "analytic/model/planar.h"

namespace crosslink::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr long kPreroll = 4;  // periodic sweeps: steps run before the first sample (and after
                              // the last), so the start's transient stays out of the stencils
// A cam's contact carries the start's transient longer (as ODE's: its first step's force lacks
// the velocity terms, and the follower then settles on the disc).
constexpr long kContactPreroll = 32;
// The default step's largest turn of the fastest link [rad]: kinematic runs' (each step is a step
// towards the driver, error O(dt^2)); forward dynamics as MuJoCo's (errors accumulate over a run;
// docs/engines.md, "Forward dynamics").
constexpr double kKinematicMaxStepAngle = 0.01;
constexpr double kDynamicsMaxStepAngle = 0.0025;

// ---------------------------------------------------------------------------------------------
// Settings

struct Config {
  std::string formulation = "rigid";    // rigid | multibody
  std::string solver = "mlcp_dantzig";  // mlcp_dantzig | sequential_impulse
  int steps_per_sample = 2;             // used when dt is not given
  StepAngle max_step_angle;             // used when dt is not given: more steps in a sample
                                        // interval where a link turns faster [rad per step]
  double dt = 0.0;                      // 0: sample interval / steps_per_sample
  int iterations = 50;                  // sequential impulse (and MLCP's fallback)
  double erp = 1.0;
  bool split_impulse = false;  // Bullet's split impulse (position correction apart)
  // Forward dynamics only (docs/engines.md, "Forward dynamics").
  bool staggered_start = true;  // start from v0 - h/2 a0 (semi-implicit Euler's half step)
  // Joint friction (docs/engines.md, "Joint friction").
  double friction_cfm = 1e-10;  // the friction rows' compliance, of their diagonal
  SharedSettings shared;        // the watch's thresholds, the test hook, the step budget
};

// Every setting, its default and what it takes, and the values a run reports, in the order a run
// prints them (sim/settings.h; docs/engines.md, "Bullet").
const SettingSchema& bullet_settings() {
  using enum SettingKind;
  using enum AppliesTo;
  static const SettingSchema schema = {
      {.name = "formulation",
       .kind = choice,
       .default_value = "rigid",
       .doc = "rigid bodies with joints, or a Featherstone multibody",
       .words = {"multibody", "rigid"}},
      {.name = "solver",
       .kind = choice,
       .default_value = "mlcp_dantzig",
       .doc = "the joint solver",
       .words = {"mlcp_dantzig", "sequential_impulse"}},
      {.name = "dt",
       .kind = number,
       .default_value = "auto",
       .doc = "the longest time step [s], shortened to divide each sample interval; auto: sample "
              "interval / steps_per_sample",
       .range = kPositive,
       .words = {"auto"}},
      {.name = "steps_per_sample",
       .kind = count,
       .default_value = "2",
       .doc = "auto dt: steps per sample interval (at least)"},
      {.name = "max_step_angle",
       .kind = number,
       .default_value = "auto",
       .doc = "auto dt: the most the fastest link turns in a step [rad] (0: off); auto: 0.01, "
              "forward dynamics 0.0025",
       .range = kNonNegative,
       .words = {"auto"}},
      {.name = "iterations",
       .kind = count,
       .default_value = "50",
       .doc = "sequential impulse's iterations (and the MLCP's fallback)",
       .most = kMostIterations},
      {.name = "erp",
       .kind = number,
       .default_value = "1",
       .doc = "error reduction per step",
       .range = {0.0, 1.0, true}},
      {.name = "precision",
       .kind = choice,
       .default_value = "float64",
       .doc = "the Bullet build linked",
       .words = {"float64"}},
      shared_setting("gap_threshold"),
      shared_setting("divergence_gap"),
      shared_setting("driver_threshold"),
      {.name = "split_impulse",
       .kind = choice,
       .default_value = "0",
       .doc = "Bullet's split impulse",
       .words = {"0", "1"}},
      shared_setting("mass_model"),
      shared_setting("driver"),
      {.name = "start",
       .kind = choice,
       .default_value = "staggered",
       .doc = "forward dynamics: staggered (v0 - h/2 a0) or exact start",
       .words = {"staggered", "exact"},
       .applies_to = dynamics},
      {.name = "forces", .doc = "how the joint forces are read", .reported = true},
      shared_setting("singular_rcond"),
      shared_setting("branch_distance"),
      shared_setting("energy_threshold"),
      shared_setting("divergence_energy"),
      shared_setting("energy_scale"),
      shared_setting("perturb_link"),
      shared_setting("max_steps"),
      shared_setting("friction_load"),
      {.name = "friction_cfm",
       .kind = number,
       .default_value = "1e-10",
       .doc = "the friction motors' constraint force mixing, a fraction of each row's own diagonal "
              "(in a loop the motors' rows are redundant: the Dantzig solve fails on the friction "
              "four-bar at 1e-16)",
       .range = {0.0, 1.0, true},
       .friction = true},
  };
  return schema;
}

Config parse_settings(const Settings& overrides) {
  const SettingValues v(bullet_settings(), "Bullet", overrides);
  Config c;
  c.formulation = v.text("formulation");
  c.solver = v.text("solver");
  c.dt = v.is("dt", "auto") ? 0.0 : v.number("dt");
  c.steps_per_sample = static_cast<int>(v.count("steps_per_sample"));
  c.max_step_angle = StepAngle(v, kKinematicMaxStepAngle, kDynamicsMaxStepAngle);
  c.iterations = static_cast<int>(v.count("iterations"));
  c.erp = v.number("erp");
  c.split_impulse = v.is("split_impulse", "1");
  c.staggered_start = v.is("start", "staggered");
  c.friction_cfm = v.number("friction_cfm");
  c.shared = SharedSettings(v);
  return c;
}

// ---------------------------------------------------------------------------------------------
// The scene graph (sim/scene_graph.h) in Bullet's terms: nodes are its bodies but the ground
// (the moving links, then one sliding block per pin-in-slot joint; node = body - 1), edges its
// joints (-1 is the ground).

struct Edge {
  enum class Kind { revolute, prismatic, planar } kind = Kind::revolute;
  int a = -1, b = -1;  // nodes; -1 is the ground. prismatic: a is the guide, b the slider
  Eigen::Vector2d pa = Eigen::Vector2d::Zero();     // revolute: joint point on a; prismatic: line
                                                    // origin on a
  Eigen::Vector2d pb = Eigen::Vector2d::Zero();     // joint point on b
  Eigen::Vector2d axis = Eigen::Vector2d::UnitX();  // prismatic: line direction in a's frame
  double phi = 0.0;                                 // prismatic: theta_b - theta_a
  int joint = -1;                                   // mechanism joint it realises
};

// Pose of a node's frame: link frame for links, the pin with the guide's angle for blocks.
struct Pose {
  Eigen::Vector2d r;
  double theta;
};

// Motion of a node's frame: its origin's velocity and its angular velocity.
struct NodeRate {
  Eigen::Vector2d v = Eigen::Vector2d::Zero();
  double omega = 0.0;
};

struct Plan {
  std::vector<SceneBody> nodes;  // the graph's bodies but the ground
  std::vector<Edge> edges;
  // Per driver (Mechanism::drivers order): the edge whose coordinate is driven, and whether it is
  // a link angle driven through a planar ground joint.
  std::vector<int> driver_edges;
  std::vector<char> driver_planar;
  // Spanning forest (multibody formulation)
  std::vector<int> order;        // nodes in insertion order (parents first)
  std::vector<int> parent_edge;  // per node; -1 none
  std::vector<int> parent;       // per node; -1 ground
  std::vector<int> cuts;         // edges closed by loop constraints
  // Gear pairs and racks of the multibody formulation, each a btMultiBodyGearConstraint on two
  // tree edges: coefficient_a x coordinate_a + coefficient_b x coordinate_b is held constant
  // (the scene graph's coupling; each coordinate the edge's joint value, edge_coordinate).
  struct Gearing {
    int joint = -1;  // the Mechanism joint
    int edge_a = -1, edge_b = -1;
    double coefficient_a = 1.0, coefficient_b = 1.0;
  };
  std::vector<Gearing> gearings;
  // Gear pairs of the rigid formulation, per gearing joint in joint order: a btGearConstraint
  // omega_a + ratio omega_b = 0 between two bodies (the ground when link_b is), the pair's own
  // row or, on a moving carrier, its row recombined with the train's other pairs
  // (reduce_couplings); each pair's multiplier is sum_e rigid_mix(e, k) times the constraints'.
  struct RigidGear {
    int joint = -1;  // the Mechanism joint
    int link_a = -1, link_b = -1;
    double ratio = 0.0;
  };
  std::vector<RigidGear> rigid_gears;
  Eigen::MatrixXd rigid_mix;
  // Cam joints (rigid formulation): their shapes, bodies as nodes + 1 (the graph's numbering).
  std::vector<SceneContact> contacts;
};

int node_of_link(const Plan& plan, int link) {
  for (size_t i = 0; i < plan.nodes.size(); ++i)
    if (plan.nodes[i].source == link) return static_cast<int>(i);
  return -1;
}

// The rigid formulation's gear pairs (Plan::RigidGear) and their mix: each pair's row over the
// links' absolute angles, theta_a + ratio theta_b - (1 + ratio) theta_c (about the ground: its two
// gears, the ground among them if it is one, as the pair's own constraint), recombined until each
// joins two bodies; std::runtime_error naming a pair that no recombination brings to two.
Eigen::MatrixXd rigid_gear_rows(const Mechanism& m, const SceneGraph& g,
                                std::vector<Plan::RigidGear>& out) {
  std::vector<std::vector<std::pair<int, double>>> rows;
  for (const SceneCoupling& c : g.couplings) {
    const Joint& j = m.joints[static_cast<size_t>(c.source)];
    std::vector<std::pair<int, double>> row{{j.link_a, 1.0}, {j.link_b, j.ratio}};
    if (j.carrier != m.ground()) {
      row.emplace_back(j.carrier, -(1.0 + j.ratio));
      std::erase_if(row, [&](const auto& term) { return term.first == m.ground(); });
    }
    rows.push_back(std::move(row));
  }
  CouplingRows reduced;
  if (const int k = reduce_couplings(rows, 2, reduced); k >= 0)
    throw std::runtime_error(fmt::format(
        "joint '{}' is a gear pair on a moving carrier: Bullet 3.24's btGearConstraint holds a "
        "ratio of two rigid bodies' absolute rotation rates, and no combination with the train's "
        "other pairs ties its gears and carrier to two bodies",
        m.joints[static_cast<size_t>(g.couplings[static_cast<size_t>(k)].source)].name));
  for (size_t e = 0; e < reduced.rows.size(); ++e) {
    const auto& row = reduced.rows[e];
    Plan::RigidGear gear{.joint = g.couplings[e].source};
    gear.link_a = row.at(0).first;
    gear.link_b = row.size() > 1 ? row[1].first : m.ground();
    gear.ratio = row.size() > 1 ? row[1].second / row[0].second : 0.0;
    // The constraint's row is the reduced one over its first coefficient.
    reduced.mix.row(static_cast<Eigen::Index>(e)) /= row[0].second;
    out.push_back(gear);
  }
  return reduced.mix;
}

// The graph's tree policy for Bullet: a floating link's driven angle is a planar ground joint's
// (rigid: a ground constraint locking only its rotation), ground pivots enter the tree before the
// other hinges, and the multibody formulation splits the loops that would close inside one
// multibody (`split_error` says when it cannot).
Plan make_plan(const Mechanism& m, bool multibody, std::string* split_error) {
  TreePolicy policy;
  policy.ground_pivots_first = true;
  policy.planar_joints = true;
  policy.split_loops = multibody;
  policy.contacts = true;
  policy.no_mesh =
      "which Bullet's hull does not hold: a hull of the profile's prism flagged 257 of 361 "
      "samples of a spring-held cam (docs/cams.md)";
  const SceneGraph g = scene_graph(m, policy);
  for (const SceneContact& c : g.contacts) {
    const std::string& name = m.joints[static_cast<size_t>(c.source)].name;
    if (multibody)
      throw std::runtime_error(fmt::format(
          "joint '{}' is a cam: the multibody formulation keeps no contact between its links "
          "here; formulation=rigid holds the follower on the cam",
          name));
  }
  // Rigid: a gear pair about the ground, btGearConstraint between the two rigid bodies.
  // Multibody: a coupling of two tree joints, btMultiBodyGearConstraint. No other gearing
  // (docs/engines.md, "Gear couplings").
  std::vector<Plan::Gearing> gearings;
  for (const SceneCoupling& c : g.couplings) {
    const Joint& j = m.joints[static_cast<size_t>(c.source)];
    const char* kind = j.type == JointType::gear ? "gear pair" : "rack and pinion";
    if (multibody) {
      // Its row couples the first degree of freedom of two links; a planar joint's first is its
      // rotation, but Bullet 3.24 builds the row's directions from the first link's joint type,
      // revolute or prismatic only. (Recombined as the rigid formulation's, a planetary train's
      // rows join two coordinates each, but the run diverges within 0.08 s of its start, the
      // gear rows' residual growing even without position correction, erp 0: not taken.)
      const auto planar = [&](int term) {
        return g.joints[static_cast<size_t>(c.terms[static_cast<size_t>(term)].first)].kind ==
               SceneJoint::Kind::planar;
      };
      if (c.terms.size() != 2 || (planar(0) && planar(1)))
        throw std::runtime_error(fmt::format(
            "joint '{}' is a {}: its coupling spans {} joints of the multibody tree (a link's "
            "angle is the sum of the hinges on its path), and Bullet 3.24's "
            "btMultiBodyGearConstraint couples two joints' coordinates",
            j.name, kind, c.terms.size()));
      const int first = planar(0) ? 1 : 0;
      const auto& [edge_a, coefficient_a] = c.terms[static_cast<size_t>(first)];
      const auto& [edge_b, coefficient_b] = c.terms[static_cast<size_t>(1 - first)];
      gearings.push_back({c.source, edge_a, edge_b, coefficient_a, coefficient_b});
      continue;
    }
    if (j.type != JointType::gear)
      throw std::runtime_error(fmt::format(
          "joint '{}' is a rack and pinion: Bullet 3.24's btGearConstraint holds a ratio of two "
          "rigid bodies' absolute rotation rates, no travel",
          j.name));
  }
  std::vector<Plan::RigidGear> rigid_gears;
  Eigen::MatrixXd rigid_mix;
  if (!multibody) rigid_mix = rigid_gear_rows(m, g, rigid_gears);
  if (split_error) *split_error = g.split_error;
  const auto node = [](int body) { return body - 1; };
  Plan plan;
  plan.nodes.assign(g.bodies.begin() + 1, g.bodies.end());
  for (const SceneJoint& j : g.joints) {
    Edge e;
    e.kind = j.kind == SceneJoint::Kind::hinge   ? Edge::Kind::revolute
             : j.kind == SceneJoint::Kind::slide ? Edge::Kind::prismatic
                                                 : Edge::Kind::planar;
    e.a = node(j.a);
    e.b = node(j.b);
    e.pa = j.kind == SceneJoint::Kind::slide ? j.origin : j.ua;
    e.pb = j.ub;
    e.axis = j.direction;
    e.phi = j.relative_angle;
    e.joint = j.source;
    plan.edges.push_back(e);
  }
  for (const DrivenCoordinate& d : g.driven) {
    plan.driver_edges.push_back(d.joint);
    plan.driver_planar.push_back(d.floating);
  }
  plan.parent.assign(plan.nodes.size(), -1);
  plan.parent_edge.assign(plan.nodes.size(), -1);
  for (int j : g.tree_order) {
    const int child = node(g.joints[j].child);
    plan.order.push_back(child);
    plan.parent[child] = node(g.joints[j].parent);
    plan.parent_edge[child] = j;
  }
  plan.cuts = g.cuts;
  plan.gearings = std::move(gearings);
  plan.rigid_gears = std::move(rigid_gears);
  plan.rigid_mix = std::move(rigid_mix);
  plan.contacts = g.contacts;
  return plan;
}

int root_of(const Plan& plan, int node) {
  while (plan.parent[node] >= 0) node = plan.parent[node];
  return node;
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers

btVector3 bt(const Eigen::Vector2d& v) {
  return {v.x(), v.y(), 0.0};
}
btQuaternion rot_z(double angle) {
  return btQuaternion(btVector3(0, 0, 1), angle);
}
Eigen::Vector2d turn(double angle, const Eigen::Vector2d& v) {
  return Eigen::Rotation2Dd(angle) * v;
}

// A rigid body of the plane at pose p: node's mass and inertia about its centre, which `shape`
// is placed from; it moves in the plane only, undamped, without gyroscopic terms, never asleep.
btRigidBody* planar_body(const SceneBody& node, const Pose& p, btCollisionShape* shape) {
  btRigidBody::btRigidBodyConstructionInfo ci(node.mass, nullptr, shape,
                                              btVector3(node.inertia, node.inertia, node.inertia));
  auto* body = new btRigidBody(ci);
  body->setWorldTransform(btTransform(rot_z(p.theta), bt(p.r + turn(p.theta, node.centre))));
  body->setLinearFactor(btVector3(1, 1, 0));
  body->setAngularFactor(btVector3(0, 0, 1));
  body->setDamping(0.0, 0.0);
  body->setFlags(0);  // no gyroscopic terms
  body->setSleepingThresholds(0.0, 0.0);
  body->setActivationState(DISABLE_DEACTIVATION);
  return body;
}

// Node frame poses from mechanism coordinates q.
std::vector<Pose> node_poses(const Mechanism& m, const Plan& plan, const Eigen::VectorXd& q) {
  std::vector<Pose> poses(plan.nodes.size());
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    const BodyMotion n = body_motion(m, plan.nodes[i], q);
    poses[i] = {n.r, n.theta};
  }
  return poses;
}

Pose pose_or_ground(const std::vector<Pose>& poses, int node) {
  return node < 0 ? Pose{Eigen::Vector2d::Zero(), 0.0} : poses[node];
}

// Node frame motions from mechanism coordinates and rates (a block: its pin's velocity, its
// guide's angular velocity).
std::vector<NodeRate> node_rates(const Mechanism& m, const Plan& plan, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& qdot) {
  std::vector<NodeRate> rates(plan.nodes.size());
  for (size_t i = 0; i < plan.nodes.size(); ++i) {
    const BodyMotion n = body_motion(m, plan.nodes[i], q, &qdot);
    rates[i] = {n.v, n.omega};
  }
  return rates;
}

NodeRate rate_or_ground(const std::vector<NodeRate>& rates, int node) {
  return node < 0 ? NodeRate{} : rates[node];
}

Eigen::Vector2d perp2(const Eigen::Vector2d& v) {
  return {-v.y(), v.x()};
}

// The rate of the edge's joint coordinate (revolute: omega_b - omega_a, prismatic: sdot).
double edge_rate(const Edge& e, const std::vector<Pose>& poses,
                 const std::vector<NodeRate>& rates) {
  const Pose a = pose_or_ground(poses, e.a), b = pose_or_ground(poses, e.b);
  const NodeRate ra = rate_or_ground(rates, e.a), rb = rate_or_ground(rates, e.b);
  if (e.kind == Edge::Kind::revolute || e.kind == Edge::Kind::planar) return rb.omega - ra.omega;
  const Eigen::Vector2d arm_b = turn(b.theta, e.pb), arm_a = turn(a.theta, e.pa);
  const Eigen::Vector2d pb = b.r + arm_b, o = a.r + arm_a;
  const Eigen::Vector2d vb = rb.v + rb.omega * perp2(arm_b), vo = ra.v + ra.omega * perp2(arm_a);
  const Eigen::Vector2d u = turn(a.theta, e.axis);
  return ra.omega * perp2(u).dot(pb - o) + u.dot(vb - vo);
}

// The edge's joint coordinate at the given poses (revolute: theta_b - theta_a, prismatic: s).
double edge_coordinate(const Edge& e, const std::vector<Pose>& poses) {
  const Pose a = pose_or_ground(poses, e.a), b = pose_or_ground(poses, e.b);
  if (e.kind == Edge::Kind::revolute || e.kind == Edge::Kind::planar) return b.theta - a.theta;
  const Eigen::Vector2d pb = b.r + turn(b.theta, e.pb), o = a.r + turn(a.theta, e.pa);
  return turn(a.theta, e.axis).dot(pb - o);
}

// ---------------------------------------------------------------------------------------------
// Scenes

class Scene {
 public:
  virtual ~Scene() = default;
  // Each driven joint coordinate to reach at the end of the next step (Plan::driver_edges order;
  // none in forward dynamics).
  virtual void drive(const std::vector<double>& targets) = 0;
  virtual void step(double dt) = 0;
  // Centre-of-mass frame (x, y, wrapped theta) of every node.
  virtual void read(std::vector<Pose>& com_frames) const = 0;
  virtual int fallbacks() const = 0;
  // Solves retried with the friction rows softer (UnboundedDantzig::softer).
  virtual int softer_solves() const { return 0; }
  // The definition's loads on the nodes of the mechanism's links (Mechanism order), for the
  // next step only.
  virtual void apply(const std::vector<BodyLoad>& loads) = 0;
  // Joint feedback of the last step (forces on each body in N, torques about each body's
  // centre of mass in N m): per mechanism joint, and of driver d's separate constraint (null
  // when the driver is a joint's own constraint). Null when the scene reads no forces.
  virtual const btJointFeedback* feedback(int /*joint*/) const { return nullptr; }
  // What cam joint `joint` put on its follower in the last step.
  virtual Eigen::Vector2d contact_force(int /*joint*/) const { return Eigen::Vector2d::Zero(); }
  virtual const btJointFeedback* driver_feedback(size_t /*d*/) const { return nullptr; }
  // Forward dynamics: the bodies set moving as the nodes at `poses` with `rates` (each node
  // frame origin's velocity and angular velocity).
  virtual void set_velocities(const std::vector<Pose>& poses,
                              const std::vector<NodeRate>& rates) = 0;
  // Joint friction (docs/engines.md, "Joint friction"), rigid bodies only (plan_scene takes them
  // for a mechanism with it): joint `joint`'s friction limit for the next step [N m or N]; after
  // a step, its friction on the joint's second link (a pin's moment, a slide's force along its
  // line) and the joint's rate (the second link's relative to the first).
  virtual void limit_friction(int /*joint*/, double /*limit*/) { no_friction(); }
  virtual double friction(int /*joint*/) const { no_friction(); }
  virtual double friction_rate(int /*joint*/) const { no_friction(); }
  // The driver whose row joint `joint`'s friction acts through (its effort includes it), or -1.
  virtual int friction_driver(int /*joint*/) const { no_friction(); }

 private:
  [[noreturn]] static void no_friction() {
    throw std::logic_error("joint friction in Bullet's multibody formulation");
  }
};

// A Dantzig solver that accepts any finite impulse: large impulses mean a locked or singular
// chain, which the loop-gap watch reports; the default bound (1000) would silently fall back.
// One solve at a time in the process: Bullet 3.24's btSolveDantzigLCP keeps its failure flag in
// a global (s_error, btDantzigLCP.cpp), reset at each solve's start, so a solve on another thread
// could clear or set the flag this solve returns, and with it whether btMLCPSolver falls back to
// sequential impulse. Everything else a step touches is its world's own (docs/engines.md,
// "Threads").
class UnboundedDantzig : public btDantzigSolver {
 public:
  UnboundedDantzig() { m_acceptableUpperLimitSolution = 1e300; }
  bool solveMLCP(const btMatrixXu& A, const btVectorXu& b, btVectorXu& x, const btVectorXu& lo,
                 const btVectorXu& hi, const btAlignedObjectArray<int>& limitDependency,
                 int numIterations, bool useSparsity = true) override {
    static std::mutex one_solve;
    const std::lock_guard<std::mutex> hold(one_solve);
    if (bounded_cfm_ == 0.0)
      return btDantzigSolver::solveMLCP(A, b, x, lo, hi, limitDependency, numIterations,
                                        useSparsity);
    // Where the solve fails on the redundant rows, again with them 100 times softer, up to
    // kSoftest, before btMLCPSolver falls back to sequential impulse (whose friction on the
    // four-bar, from one failed step, was 95 % of peak off).
    for (double fraction = bounded_cfm_;; fraction *= 100.0) {
      btMatrixXu softened = A;
      for (int i = 0; i < A.rows(); ++i)
        if (lo[i] > -kUnbounded && hi[i] < kUnbounded)
          softened.setElem(i, i, A(i, i) * (1.0 + fraction));
      if (btDantzigSolver::solveMLCP(softened, b, x, lo, hi, limitDependency, numIterations,
                                     useSparsity))
        return true;
      if (fraction * 100.0 > kSoftest) return false;
      ++softer_;
    }
  }
  // The rows with finite bounds (the friction motors') made compliant by this fraction of their
  // own diagonal: a row's constraint force mixing relative to its effective mass, which
  // btMLCPSolver does not take per row (only the world's m_globalCfm, absolute, on every row).
  void soften_bounded_rows(double fraction) { bounded_cfm_ = fraction; }
  // How many solves were retried softer.
  int softer() const { return softer_; }

 private:
  static constexpr double kUnbounded = 1e30;  // an equality row's bounds are +-BT_INFINITY
  // The softest retry: at 1e-6 the four-bar's friction is still 0.14 % of peak off, as at 1e-10.
  static constexpr double kSoftest = 1e-6;
  double bounded_cfm_ = 0.0;
  int softer_ = 0;
};

// Bullet 3.24 as Debian builds it times every step's phases (BT_PROFILE) into one profile tree per
// thread, numbered by an unguarded counter (btQuickprof.cpp: two threads starting together can
// share a tree, and a tree's nodes are allocated as it grows). Nothing here reads the profile:
// its zones are made empty, once per process, before any world exists.
void no_profile_zone(const char*) {}
void no_profile_leave() {}
void silence_profiler() {
  static std::once_flag once;
  std::call_once(once, [] {
    btSetCustomEnterProfileZoneFunc(no_profile_zone);
    btSetCustomLeaveProfileZoneFunc(no_profile_leave);
  });
}

// A cam's contact (RigidScene::add_contact_shapes): the disc is collided larger by its margin
// (SceneContact::margin), kept in its body's user pointer, and each contact point's distance is
// given it back as the point is made: shapes still apart by less than the margin get a contact
// whose gap Bullet's solver lets close within the step and no more (a positive distance's
// speculative row), so the contact holds from step to step instead of flickering at zero depth.
// The point on the grown disc moves back by the margin too: a point kept from step to step (a
// box's, against the disc: its distance is refreshed from its points; a sphere's are remade)
// keeps the margin given back.
bool give_back_margin(btManifoldPoint& point, const btCollisionObjectWrapper* a, int, int,
                      const btCollisionObjectWrapper* b, int, int) {
  for (const bool on_a : {true, false}) {
    const btCollisionObject* body = (on_a ? a : b)->getCollisionObject();
    const auto* margin = static_cast<const double*>(body->getUserPointer());
    if (!margin) continue;
    point.m_distance1 += *margin;
    // The normal points from B to A: A's surface lies back along it, B's forward.
    btVector3& at = on_a ? point.m_positionWorldOnA : point.m_positionWorldOnB;
    at += (on_a ? *margin : -*margin) * point.m_normalWorldOnB;
    (on_a ? point.m_localPointA : point.m_localPointB) = body->getWorldTransform().invXform(at);
  }
  return false;
}
void use_contact_margins() {
  static std::once_flag once;
  std::call_once(once, [] { gContactAddedCallback = give_back_margin; });
}

// Joint-solver settings of both formulations: iterations, ERP (no softening), split impulse
// (off by default).
void apply_solver_settings(btContactSolverInfo& info, const Config& config) {
  info.m_numIterations = config.iterations;
  info.m_erp = info.m_erp2 = config.erp;
  info.m_globalCfm = 0.0;
  info.m_splitImpulse = config.split_impulse;
}

class MultiBodyScene final : public Scene {
 public:
  MultiBodyScene(const Plan& plan, const std::vector<Pose>& poses,
                 const std::vector<double>& driver_targets0, const Config& config,
                 const Eigen::Vector2d& gravity, bool driven = true)
      : plan_(plan) {
    if (config.solver == "mlcp_dantzig") {
      mlcp_ = new btMultiBodyMLCPConstraintSolver(&dantzig_);
      solver_ = mlcp_;
    } else {
      solver_ = new btMultiBodyConstraintSolver();
    }
    world_ = new btMultiBodyDynamicsWorld(&dispatcher_, &broadphase_, solver_, &collision_);
    world_->setGravity(btVector3(gravity.x(), gravity.y(), 0));
    apply_solver_settings(world_->getSolverInfo(), config);

    // One fixed-base multibody per tree root; links in parent-first order.
    const int n = static_cast<int>(plan.nodes.size());
    where_.assign(n, {-1, -1});
    driver_links_.assign(plan.driver_edges.size(), {nullptr, -1});
    std::vector<int> count;
    for (int v : plan.order) {
      const int r = root_of(plan, v);
      if (where_[r].first < 0) {
        where_[r] = {static_cast<int>(count.size()), -1};
        count.push_back(0);
      }
      where_[v] = {where_[r].first, count[where_[r].first]++};
    }
    for (int c : count) {
      auto* mb = new btMultiBody(c, 0.0, btVector3(0, 0, 0), true, false);
      mb->setBaseWorldTransform(btTransform::getIdentity());
      bodies_.push_back(mb);
    }
    for (int v : plan.order) {
      const SceneBody& node = plan.nodes[v];
      btMultiBody* mb = bodies_[where_[v].first];
      const int i = where_[v].second;
      const int p = plan.parent[v];
      const int pi = p < 0 ? -1 : where_[p].second;
      const Eigen::Vector2d pc = p < 0 ? Eigen::Vector2d::Zero() : plan.nodes[p].centre;
      const Edge& e = plan.edges[plan.parent_edge[v]];
      const btVector3 inertia(node.inertia, node.inertia, node.inertia);
      const double q =
          edge_coordinate(e, poses) * (e.kind == Edge::Kind::prismatic || e.a == p ? 1.0 : -1.0);
      if (e.kind == Edge::Kind::planar) {
        // Joint coordinates (theta, y, x) of the centre of mass, in the ground frame.
        mb->setupPlanar(i, node.mass, inertia, pi, btQuaternion::getIdentity(), btVector3(0, 0, 1),
                        btVector3(0, 0, 0), true);
        const Pose& pose = poses[v];
        const Eigen::Vector2d c = pose.r + turn(pose.theta, node.centre);
        const double qp[3] = {pose.theta, c.y(), c.x()};
        mb->setJointPosMultiDof(i, qp);
      } else if (e.kind == Edge::Kind::revolute) {
        const Eigen::Vector2d pp = e.a == p ? e.pa : e.pb, pv = e.a == p ? e.pb : e.pa;
        mb->setupRevolute(i, node.mass, inertia, pi, btQuaternion::getIdentity(),
                          btVector3(0, 0, 1), bt(pp - pc), bt(node.centre - pv), true);
        mb->setJointPos(i, q);
      } else if (e.a == p) {  // prismatic, parent = guide
        mb->setupPrismatic(i, node.mass, inertia, pi, rot_z(-e.phi), bt(turn(-e.phi, e.axis)),
                           bt(e.pa - pc), bt(node.centre - e.pb), true);
        mb->setJointPos(i, q);
      } else {  // prismatic, parent = slider: the guide moves along -axis
        mb->setupPrismatic(i, node.mass, inertia, pi, rot_z(e.phi), bt(-e.axis), bt(e.pb - pc),
                           bt(node.centre - e.pa), true);
        mb->setJointPos(i, q);
      }
      for (size_t d = 0; d < plan.driver_edges.size(); ++d)
        if (plan.parent_edge[v] == plan.driver_edges[d]) driver_links_[d] = {mb, i};
    }
    for (btMultiBody* mb : bodies_) {
      mb->setLinearDamping(0.0);
      mb->setAngularDamping(0.0);
      mb->setMaxCoordinateVelocity(1e300);  // default 100 would clip fast joints
      mb->setUseGyroTerm(false);
      mb->setHasSelfCollision(false);
      mb->finalizeMultiDof();
      world_->addMultiBody(mb);
      btAlignedObjectArray<btQuaternion> rot;
      btAlignedObjectArray<btVector3> org;
      mb->forwardKinematics(rot, org);
      // Without link colliders a multibody silently ignores its constraints and motor.
      for (int i = 0; i < mb->getNumLinks(); ++i) {
        auto* col = new btMultiBodyLinkCollider(mb, i);
        col->setCollisionShape(&empty_);
        col->setWorldTransform(mb->getLink(i).m_cachedWorldTransform);
        world_->addCollisionObject(col, 0, 0);
        mb->getLink(i).m_collider = col;
        colliders_.push_back(col);
      }
    }
    for (int ei : plan.cuts) {
      const Edge& e = plan.edges[ei];
      const Eigen::Vector2d ca = e.a < 0 ? Eigen::Vector2d::Zero() : plan.nodes[e.a].centre;
      const Eigen::Vector2d cb = e.b < 0 ? Eigen::Vector2d::Zero() : plan.nodes[e.b].centre;
      btMultiBodyPoint2Point* c = nullptr;
      if (e.a < 0)
        c = new btMultiBodyPoint2Point(bodies_[where_[e.b].first], where_[e.b].second, nullptr,
                                       bt(e.pb - cb), bt(e.pa));
      else if (e.b < 0)
        c = new btMultiBodyPoint2Point(bodies_[where_[e.a].first], where_[e.a].second, nullptr,
                                       bt(e.pa - ca), bt(e.pb));
      else
        c = new btMultiBodyPoint2Point(bodies_[where_[e.a].first], where_[e.a].second,
                                       bodies_[where_[e.b].first], where_[e.b].second,
                                       bt(e.pa - ca), bt(e.pb - cb));
      c->setMaxAppliedImpulse(1e300);
      world_->addMultiBodyConstraint(c);
      constraints_.push_back(c);
    }
    for (const Plan::Gearing& gearing : plan.gearings) add_gear(gearing, poses, config);
    // One joint motor per driver.
    for (const auto& [body, link] : driver_links_)
      if (body && driven) {
        motors_.push_back(new btMultiBodyJointMotor(body, link, 0, 0.0, 1e300));
        motors_.back()->setErp(1.0);
      }
    drive(driver_targets0);
    for (btMultiBodyJointMotor* motor : motors_) world_->addMultiBodyConstraint(motor);
  }

  ~MultiBodyScene() override {
    for (auto* motor : motors_) world_->removeMultiBodyConstraint(motor);
    for (auto* c : constraints_) world_->removeMultiBodyConstraint(c);
    for (auto* c : gears_) world_->removeMultiBodyConstraint(c);
    for (auto* c : colliders_) world_->removeCollisionObject(c);
    for (auto* mb : bodies_) world_->removeMultiBody(mb);
    for (auto* motor : motors_) delete motor;
    for (auto* c : constraints_) delete c;
    for (auto* c : gears_) delete c;
    for (auto* c : colliders_) delete c;
    for (auto* mb : bodies_) delete mb;
    delete world_;
    delete solver_;
  }

  // Joint-motor row: rhs = (target - q)/dt + v_desired (kp = kd = 1, erp 1, v_desired 0), so
  // each driven coordinate lands exactly on its target after the step.
  void drive(const std::vector<double>& targets) override {
    for (size_t d = 0; d < motors_.size(); ++d) {
      motors_[d]->setPositionTarget(targets[d], 1.0);
      motors_[d]->setVelocityTarget(0.0, 1.0);
    }
  }

  void step(double dt) override { world_->stepSimulation(dt, 0, dt); }

  void read(std::vector<Pose>& frames) const override {
    frames.resize(plan_.nodes.size());
    for (int v : plan_.order) {
      const btMultiBody* mb = bodies_[where_[v].first];
      const int i = where_[v].second;
      const btVector3 c = mb->localPosToWorld(i, btVector3(0, 0, 0));
      const btVector3 x = mb->localDirToWorld(i, btVector3(1, 0, 0));
      frames[v] = {{c.x(), c.y()}, std::atan2(x.y(), x.x())};
    }
  }

  int fallbacks() const override { return mlcp_ ? mlcp_->getNumFallbacks() : 0; }

  void apply(const std::vector<BodyLoad>& loads) override {
    for (size_t v = 0; v < loads.size(); ++v) {
      btMultiBody* mb = bodies_[where_[v].first];
      mb->addLinkForce(where_[v].second, bt(loads[v].force));
      mb->addLinkTorque(where_[v].second, btVector3(0, 0, loads[v].moment));
    }
  }

  // Joint rates from the node motions, with the signs of the joint positions set above.
  void set_velocities(const std::vector<Pose>& poses, const std::vector<NodeRate>& rates) override {
    for (int v : plan_.order) {
      btMultiBody* mb = bodies_[where_[v].first];
      const int i = where_[v].second;
      const int p = plan_.parent[v];
      const Edge& e = plan_.edges[plan_.parent_edge[v]];
      if (e.kind == Edge::Kind::planar) {
        // (theta, y, x) of the centre of mass, in the ground frame.
        const Eigen::Vector2d c =
            rates[v].v + rates[v].omega * perp2(turn(poses[v].theta, plan_.nodes[v].centre));
        const double qd[3] = {rates[v].omega, c.y(), c.x()};
        mb->setJointVelMultiDof(i, qd);
      } else {
        const double sign = e.kind == Edge::Kind::prismatic || e.a == p ? 1.0 : -1.0;
        mb->setJointVel(i, sign * edge_rate(e, poses, rates));
      }
    }
  }

 private:
  // The link an edge of the tree leads to, and the sign of its multibody coordinate against the
  // edge's (a hinge whose tree runs from b to a turns the other way).
  std::pair<int, double> edge_link(int edge) const {
    for (size_t v = 0; v < plan_.nodes.size(); ++v)
      if (plan_.parent_edge[v] == edge) {
        const Edge& e = plan_.edges[static_cast<size_t>(edge)];
        return {static_cast<int>(v),
                e.kind == Edge::Kind::prismatic || e.a == plan_.parent[v] ? 1.0 : -1.0};
      }
    throw std::logic_error("a gearing's joint is not in the multibody tree");
  }

  // The row q_a + ratio q_b = its start value over the two links' first coordinates (velocity
  // level). Its position correction, when ERP is on, reads both coordinates from the first
  // link's multibody (btMultiBodyGearConstraint::createConstraintRows in 3.24), so it is on only
  // when both links are in one multibody: elsewhere the ratio drifts (docs/engines.md).
  void add_gear(const Plan::Gearing& gearing, const std::vector<Pose>& poses,
                const Config& config) {
    const auto [va, sign_a] = edge_link(gearing.edge_a);
    const auto [vb, sign_b] = edge_link(gearing.edge_b);
    btMultiBody* a = bodies_[where_[va].first];
    btMultiBody* b = bodies_[where_[vb].first];
    const int la = where_[va].second, lb = where_[vb].second;
    const double ratio = gearing.coefficient_b * sign_b / (gearing.coefficient_a * sign_a);
    auto* gear =
        new btMultiBodyGearConstraint(a, la, b, lb, btVector3(0, 0, 0), btVector3(0, 0, 0),
                                      btMatrix3x3::getIdentity(), btMatrix3x3::getIdentity());
    gear->setGearRatio(ratio);
    gear->setMaxAppliedImpulse(1e300);
    if (a == b) {
      const double qa = sign_a * edge_coordinate(plan_.edges[gearing.edge_a], poses);
      const double qb = sign_b * edge_coordinate(plan_.edges[gearing.edge_b], poses);
      gear->setRelativePositionTarget(qa + ratio * qb);
      gear->setErp(config.erp);
    }
    world_->addMultiBodyConstraint(gear);
    gears_.push_back(gear);
  }

  const Plan& plan_;
  btDefaultCollisionConfiguration collision_;
  btCollisionDispatcher dispatcher_{&collision_};
  btDbvtBroadphase broadphase_;
  UnboundedDantzig dantzig_;
  btMultiBodyMLCPConstraintSolver* mlcp_ = nullptr;
  btMultiBodyConstraintSolver* solver_ = nullptr;
  btMultiBodyDynamicsWorld* world_ = nullptr;
  btEmptyShape empty_;
  std::vector<btMultiBody*> bodies_;
  std::vector<btMultiBodyLinkCollider*> colliders_;
  std::vector<btMultiBodyPoint2Point*> constraints_;
  std::vector<btMultiBodyGearConstraint*> gears_;
  std::vector<btMultiBodyJointMotor*> motors_;              // per driver; none in forward dynamics
  std::vector<std::pair<btMultiBody*, int>> driver_links_;  // per driver: (multibody, link)
  std::vector<std::pair<int, int>> where_;                  // node -> (multibody, link)
};

// Maximal coordinates: one rigid body per link, held in the plane by its linear and angular
// factors; each joint a btGeneric6DofSpring2Constraint that locks only the in-plane freedoms it
// removes (revolute: x, y; prismatic: the line normal and the relative angle; pin in slot: the
// line normal), so the MLCP sees no redundant or zero rows.
class RigidScene final : public Scene {
 public:
  RigidScene(const Mechanism& m, const Plan& plan, const std::vector<Pose>& poses,
             const std::vector<double>& driver_targets0, const Config& config, bool driven = true)
      : plan_(plan) {
    if (config.solver == "mlcp_dantzig") {
      mlcp_ = new btMLCPSolver(&dantzig_);
      solver_ = mlcp_;
    } else {
      solver_ = new btSequentialImpulseConstraintSolver();
    }
    world_ = new btDiscreteDynamicsWorld(&dispatcher_, &broadphase_, solver_, &collision_);
    // Before the bodies are added: each takes the world's gravity then.
    world_->setGravity(btVector3(m.gravity.x(), m.gravity.y(), 0));
    apply_solver_settings(world_->getSolverInfo(), config);
    // The friction motors' rows are redundant with the loops' and the drivers' (Config).
    if (m.has_friction()) dantzig_.soften_bounded_rows(config.friction_cfm);
    erp_ = config.erp;

    ground_ = new btRigidBody(0.0, nullptr, &empty_);
    world_->addRigidBody(ground_, 0, 0);
    const int links = m.moving_count();
    add_contact_shapes(links);
    for (int v = 0; v < links; ++v) {
      const SceneBody& node = plan.nodes[v];
      btCollisionShape* shape = shape_[static_cast<size_t>(v)]
                                    ? shape_[static_cast<size_t>(v)].get()
                                    : static_cast<btCollisionShape*>(&empty_);
      auto* body = planar_body(node, poses[v], shape);
      // A cam's or follower's shape collides with the other's only, frictionless and without
      // bounce (the joint slides and rolls free); every other body collides with nothing.
      const int group = group_[static_cast<size_t>(v)];
      body->setFriction(0.0);
      body->setRollingFriction(0.0);
      body->setSpinningFriction(0.0);
      body->setRestitution(0.0);
      const int mask =
          ((group & kCamGroup) ? kFollowerGroup : 0) | ((group & kFollowerGroup) ? kCamGroup : 0);
      if (margin_[static_cast<size_t>(v)] > 0.0) {
        body->setUserPointer(&margin_[static_cast<size_t>(v)]);
        body->setCollisionFlags(body->getCollisionFlags() |
                                btCollisionObject::CF_CUSTOM_MATERIAL_CALLBACK);
      }
      world_->addRigidBody(body, group, mask);
      bodies_.push_back(body);
    }
    // A circle's arm (the scene graph's block: a curved slot, a grooved disc) is a body of its own
    // between two hinges; a straight slot's block is not (its 6-dof constraint locks the line's
    // normal alone).
    for (size_t v = static_cast<size_t>(links); v < plan.nodes.size(); ++v) {
      const SceneBody& node = plan.nodes[v];
      if (!arc_geometry(m, m.joints[static_cast<size_t>(node.joint)])) continue;
      auto* arm = planar_body(node, poses[v], &empty_);
      world_->addRigidBody(arm, 0, 0);
      arms_.emplace_back(static_cast<int>(v), arm);
    }
    gear_.assign(m.joints.size(), nullptr);
    size_t gearing = 0;
    for (size_t ji = 0; ji < m.joints.size(); ++ji) {
      const Joint& j = m.joints[ji];
      const int a = plan_node(m, j.link_a), b = plan_node(m, j.link_b);
      const std::optional<ArcGeometry> arc = arc_geometry(m, j);
      if (j.type == JointType::cam && !arc) {  // contact between shapes: no constraint
        joint_constraint_.push_back(nullptr);
        joint_lock_.emplace_back();
        continue;
      }
      if (j.is_gearing()) {
        // Its row: omega_a + ratio omega_b = 0 about z (Plan::RigidGear: the gear pair's rates
        // about the ground, or recombined with the train's others), at the velocity level only.
        const Plan::RigidGear& gear = plan.rigid_gears[gearing++];
        gear_[ji] =
            new btGearConstraint(body(plan_node(m, gear.link_a)), body(plan_node(m, gear.link_b)),
                                 btVector3(0, 0, 1), btVector3(0, 0, 1), gear.ratio);
        world_->addConstraint(gear_[ji], true);
        joint_constraint_.push_back(nullptr);
        joint_lock_.emplace_back();
        continue;
      }
      const Eigen::Vector2d& pb = m.links[j.link_b].points[j.point_b].local;
      if (arc) {
        // The arm's frame sits at the pin (its centre of mass), its x axis along the radius.
        const int arm = arm_node(static_cast<int>(ji));
        const auto at = [](const Eigen::Vector2d& p) {
          return btTransform(btQuaternion::getIdentity(), bt(p));
        };
        Lock hinge;
        hinge.linear[0] = hinge.linear[1] = true;
        add(new btGeneric6DofSpring2Constraint(body(a), body(arm), at(arc->centre - com(a)),
                                               at({-arc->radius, 0.0})),
            hinge);
        auto* pin = new btGeneric6DofSpring2Constraint(body(arm), body(b), at({0.0, 0.0}),
                                                       at(arc->point - com(b)));
        add(pin, hinge);
        joint_constraint_.push_back(pin);  // its feedback: the pin's force on link_b
        joint_lock_.push_back(hinge);
        continue;
      }
      btTransform fa, fb;
      if (j.type == JointType::revolute) {
        fa = btTransform(btQuaternion::getIdentity(),
                         bt(m.links[j.link_a].points[j.point_a].local - com(a)));
        fb = btTransform(btQuaternion::getIdentity(), bt(pb - com(b)));
      } else {
        // Frame x along the line; the slider's frame turned so its relative angle is zero.
        const Line& line = m.links[j.link_a].lines[j.line];
        const double along = std::atan2(line.direction.y(), line.direction.x());
        fa = btTransform(rot_z(along), bt(line.origin - com(a)));
        fb = btTransform(rot_z(along - j.relative_angle), bt(pb - com(b)));
      }
      auto* c = new btGeneric6DofSpring2Constraint(body(a), body(b), fa, fb);
      if (j.is_slide()) {
        const Line& line = m.links[j.link_a].lines[j.line];
        slides_.push_back({c, bt(line.origin - com(a)), bt(line.direction), fa, fb});
      }
      Lock lock;
      lock.linear[1] = true;
      lock.linear[0] = j.type == JointType::revolute;
      lock.angular = j.type == JointType::prismatic;
      add(c, lock);
      joint_constraint_.push_back(c);
      joint_lock_.push_back(lock);
    }
    joint_feedback_.resize(joint_constraint_.size());
    for (size_t ji = 0; ji < joint_constraint_.size(); ++ji) {
      // setJointFeedback is what fills it (enableFeedback alone does not: bullet3 issue 593).
      btTypedConstraint* c = joint_constraint_[ji];
      if (!c) c = gear_[ji];
      if (!c) continue;  // a cam
      c->setJointFeedback(&joint_feedback_[ji]);
      c->enableFeedback(true);
    }
    rough_.resize(m.joints.size());  // sized once: each motor points at its feedback
    for (size_t ji = 0; ji < m.joints.size(); ++ji) {
      if (!m.joints[ji].friction) continue;
      // The driver whose own row holds this joint (a link angle through a planar ground joint
      // has a separate lock, and the joint its motor).
      int driver = -1;
      for (size_t d = 0; driven && d < plan.driver_edges.size(); ++d)
        if (!plan.driver_planar[d] && plan.edges[plan.driver_edges[d]].joint == int(ji))
          driver = static_cast<int>(d);
      add_friction(m, ji, driver);
    }
    // Each driver: the driven joint's own constraint with one more freedom locked, or for a link
    // angle without a ground pivot a constraint between the ground and the link that locks only
    // its rotation (the absolute angle is realised directly). None in forward dynamics.
    if (!driven) {
      drive(driver_targets0);
      return;
    }
    drivers_.resize(m.drivers.size());  // sized once: each separate constraint points at its
                                        // feedback
    for (size_t di = 0; di < m.drivers.size(); ++di) {
      const Driver& d = m.drivers[di];
      DriverLock& driver = drivers_[di];
      if (d.type == DriverType::link_angle && plan.driver_planar[di]) {
        const int v = plan.edges[plan.driver_edges[di]].b;
        const btTransform fb(btQuaternion::getIdentity(), btVector3(0, 0, 0));
        const btTransform fa(btQuaternion::getIdentity(),
                             bt(poses[v].r + turn(poses[v].theta, com(v))));
        driver.constraint = new btGeneric6DofSpring2Constraint(*ground_, *bodies_[v], fa, fb);
        driver.lock.angular = true;
        add(driver.constraint, driver.lock);
        driver.rotation = true;
        driver.constraint->setJointFeedback(&driver.feedback);
        driver.constraint->enableFeedback(true);
        driver.separate = true;
      } else {
        const int ji = plan.edges[plan.driver_edges[di]].joint;
        driver.constraint = joint_constraint_[ji];
        driver.lock = joint_lock_[ji];
        driver.rotation = m.joints[ji].type == JointType::revolute;
        if (driver.rotation)
          driver.lock.angular = true;
        else
          driver.lock.linear[0] = true;
      }
      driver.fa = driver.constraint->getFrameOffsetA();
      driver.fb = driver.constraint->getFrameOffsetB();
    }
    drive(driver_targets0);
  }

  ~RigidScene() override {
    for (auto* c : gear_)
      if (c) world_->removeConstraint(c);
    for (auto* c : gear_) delete c;
    for (auto* c : constraints_) world_->removeConstraint(c);
    for (auto* b : bodies_) world_->removeRigidBody(b);
    for (auto& [node, arm] : arms_) world_->removeRigidBody(arm);
    world_->removeRigidBody(ground_);
    for (auto* c : constraints_) delete c;
    for (auto* b : bodies_) delete b;
    for (auto& [node, arm] : arms_) delete arm;
    delete ground_;
    delete world_;
    delete solver_;
  }

  // Rotation: the slider frame is turned back by the target so the lock sits at zero (a lock
  // at the target itself would jump by 2 pi where the relative angle wraps). Slide: the
  // linear lock moves to the target.
  void drive(const std::vector<double>& targets) override {
    // Slides: frame A's origin follows the slider point along the line, so that the 6-dof
    // constraint's lever arms are taken at the contact point (with the frames apart its
    // Jacobian is not that of the point-on-line equation and a moving guide locks up).
    for (const Slide& sl : slides_) {
      const auto driving = std::find_if(drivers_.begin(), drivers_.end(), [&](const auto& d) {
        return d.constraint == sl.constraint;
      });
      const bool driven = driving != drivers_.end();
      if (driven && !driving->rotation) continue;  // x measured from the origin
      btRigidBody& a = sl.constraint->getRigidBodyA();
      btRigidBody& b = sl.constraint->getRigidBodyB();
      const btVector3 p = b.getWorldTransform() * sl.fb.getOrigin();
      const btVector3 local = a.getWorldTransform().inverse() * p;
      btTransform fa = sl.fa;
      fa.setOrigin(sl.origin + sl.axis * (local - sl.origin).dot(sl.axis));
      btTransform fb = sl.fb;
      if (driven) fb = sl.constraint->getFrameOffsetB();
      sl.constraint->setFrames(fa, fb);
    }
    for (size_t d = 0; d < drivers_.size(); ++d) {
      DriverLock& driver = drivers_[d];
      if (driver.rotation) {
        btTransform fb = driver.fb;
        fb.setRotation(driver.fb.getRotation() * rot_z(-targets[d]));
        driver.constraint->setFrames(driver.fa, fb);
        set_limits(driver.constraint, driver.lock, 0.0);
      } else {
        set_limits(driver.constraint, driver.lock, targets[d]);
      }
    }
  }

  void step(double dt) override {
    world_->stepSimulation(dt, 0, dt);
    last_dt_ = dt;
  }

  // The contact manifold's points between the cam's and the follower's shapes: each point's
  // impulse along its normal (on body B, pointing to A) over the step, on the follower. A yoke's
  // two faces are on the same two bodies: their points are in the same manifolds, read once.
  Eigen::Vector2d contact_force(int joint) const override {
    Eigen::Vector2d on_follower = Eigen::Vector2d::Zero();
    for (const SceneContact& c : plan_.contacts) {
      if (c.source != joint || c.far) continue;
      const btCollisionObject* cam = bodies_[static_cast<size_t>(c.cam - 1)];
      const btCollisionObject* follower = bodies_[static_cast<size_t>(c.follower - 1)];
      for (int k = 0; k < dispatcher_.getNumManifolds(); ++k) {
        const btPersistentManifold* manifold = dispatcher_.getManifoldByIndexInternal(k);
        const bool follower_a = manifold->getBody0() == follower && manifold->getBody1() == cam;
        if (!follower_a && !(manifold->getBody0() == cam && manifold->getBody1() == follower))
          continue;
        for (int i = 0; i < manifold->getNumContacts(); ++i) {
          const btManifoldPoint& point = manifold->getContactPoint(i);
          const btVector3 f = point.m_normalWorldOnB * (point.getAppliedImpulse() / last_dt_);
          on_follower += (follower_a ? 1.0 : -1.0) * Eigen::Vector2d(f.x(), f.y());
        }
      }
    }
    return on_follower;
  }

  void read(std::vector<Pose>& frames) const override {
    frames.resize(plan_.nodes.size());
    for (size_t v = 0; v < bodies_.size(); ++v) {
      const btTransform& t = bodies_[v]->getWorldTransform();
      const btVector3 x = t.getBasis().getColumn(0);
      frames[v] = {{t.getOrigin().x(), t.getOrigin().y()}, std::atan2(x.y(), x.x())};
    }
  }

  int fallbacks() const override { return mlcp_ ? mlcp_->getNumFallbacks() : 0; }
  int softer_solves() const override { return dantzig_.softer(); }

  void apply(const std::vector<BodyLoad>& loads) override {
    for (size_t v = 0; v < loads.size(); ++v) {
      bodies_[v]->applyCentralForce(bt(loads[v].force));
      bodies_[v]->applyTorque(btVector3(0, 0, loads[v].moment));
    }
  }

  const btJointFeedback* feedback(int joint) const override {
    return &joint_feedback_[static_cast<size_t>(joint)];
  }

  // Each body's centre-of-mass velocity and angular velocity.
  void set_velocities(const std::vector<Pose>& poses, const std::vector<NodeRate>& rates) override {
    for (size_t v = 0; v < bodies_.size(); ++v) {
      const Eigen::Vector2d c =
          rates[v].v + rates[v].omega * perp2(turn(poses[v].theta, plan_.nodes[v].centre));
      bodies_[v]->setLinearVelocity(bt(c));
      bodies_[v]->setAngularVelocity(btVector3(0, 0, rates[v].omega));
    }
    for (auto& [node, arm] : arms_) {  // each centred at its frame
      arm->setLinearVelocity(bt(rates[static_cast<size_t>(node)].v));
      arm->setAngularVelocity(btVector3(0, 0, rates[static_cast<size_t>(node)].omega));
    }
  }
  const btJointFeedback* driver_feedback(size_t d) const override {
    return d < drivers_.size() && drivers_[d].separate ? &drivers_[d].feedback : nullptr;
  }

  void limit_friction(int joint, double limit) override {
    Rough& r = rough_[static_cast<size_t>(joint)];
    r.limit = limit;
    if (r.motor) r.motor->setMaxMotorForce(r.axis, limit);
  }
  double friction(int joint) const override {
    const Rough& r = rough_[static_cast<size_t>(joint)];
    if (!r.motor) {  // a driven joint: the limit against its rate
      const double rate = friction_rate(joint);
      return rate > 0.0 ? -r.limit : rate < 0.0 ? r.limit : 0.0;
    }
    const bool on_b = !r.b->isStaticObject();
    const btJointFeedback& f = r.feedback;
    if (r.axis == kAboutZ) return on_b ? f.m_appliedTorqueBodyB.z() : -f.m_appliedTorqueBodyA.z();
    return (on_b ? f.m_appliedForceBodyB : -f.m_appliedForceBodyA).dot(line_axis(r));
  }
  int friction_driver(int joint) const override {
    return rough_[static_cast<size_t>(joint)].driver;
  }
  double friction_rate(int joint) const override {
    const Rough& r = rough_[static_cast<size_t>(joint)];
    if (r.axis == kAboutZ) return r.b->getAngularVelocity().z() - r.a->getAngularVelocity().z();
    // The slider point's velocity relative to the guide's point under it, along the line.
    const btVector3 p = slider_point(r);
    return (r.b->getVelocityInLocalPoint(p - r.b->getCenterOfMassPosition()) -
            r.a->getVelocityInLocalPoint(p - r.a->getCenterOfMassPosition()))
        .dot(line_axis(r));
  }

 private:
  // A friction joint (docs/engines.md, "Joint friction"): a motor at rest, a
  // btGeneric6DofSpring2Constraint of its own between the joint's bodies, with the joint's frames,
  // free in every freedom but for the motor about z (a pin) or along the line (a slide, frame A's
  // x). Its force is bounded by the friction's limit (6Dof2's motors take a force, bounded per
  // step at force x dt) and its feedback is the friction alone. A slide's motor keeps its start
  // frames: its row's lever arms are taken at points of the line, whose moments about any point
  // are those at the slider's. A driven joint (a kinematic run's) has no motor: its friction is
  // the limit against the driver's rate, and acts on the two bodies the driver's row acts on,
  // along that row, so that it changes nothing but the driver's effort (BulletSteps takes it out
  // of the effort read). A motor there would be a second row on the driver's freedom: on the
  // friction four-bar's near-massless crank the Dantzig solve failed on the pair and the friction
  // read 1 % of its limit; applied as a couple, it swamped the solve with the crank's 1e9 rad/s2.
  struct Rough {
    btRigidBody* a = nullptr;
    btRigidBody* b = nullptr;
    btTransform fa, fb;  // the joint's frames on a and b
    int axis = 0;
    btGeneric6DofSpring2Constraint* motor = nullptr;  // null at a driven joint
    int driver = -1;                                  // a driven joint's driver
    btJointFeedback feedback;
    double limit = 0.0;  // of the step
  };
  static constexpr int kAlongLine = 0, kAboutZ = 5;

  void add_friction(const Mechanism& m, size_t ji, int driver) {
    btGeneric6DofSpring2Constraint* joint = joint_constraint_[ji];
    Rough& r = rough_[ji];
    r.a = &joint->getRigidBodyA();
    r.b = &joint->getRigidBodyB();
    r.fa = joint->getFrameOffsetA();
    r.fb = joint->getFrameOffsetB();
    r.axis = m.joints[ji].is_slide() ? kAlongLine : kAboutZ;
    r.driver = driver;
    if (driver >= 0) return;
    r.motor = new btGeneric6DofSpring2Constraint(*r.a, *r.b, r.fa, r.fb);
    add(r.motor, Lock{});
    r.motor->enableMotor(r.axis, true);
    r.motor->setTargetVelocity(r.axis, 0.0);
    r.motor->setMaxMotorForce(r.axis, 0.0);
    r.motor->setJointFeedback(&r.feedback);
    r.motor->enableFeedback(true);
  }
  static btVector3 line_axis(const Rough& r) {
    return (r.a->getWorldTransform().getBasis() * r.fa.getBasis()).getColumn(0);
  }
  static btVector3 slider_point(const Rough& r) {
    return r.b->getWorldTransform() * r.fb.getOrigin();
  }

  struct Lock {
    bool linear[2] = {false, false};
    bool angular = false;
  };
  struct Slide {
    btGeneric6DofSpring2Constraint* constraint;
    btVector3 origin, axis;  // the line in body A's centre-of-mass frame
    btTransform fa, fb;
  };
  std::vector<Slide> slides_;
  // A driver's lock: the constraint that holds it (the driven joint's own, or a separate one),
  // the freedoms it locks, and its frames at the start.
  struct DriverLock {
    btGeneric6DofSpring2Constraint* constraint = nullptr;
    Lock lock;
    bool rotation = true;
    btTransform fa, fb;
    bool separate = false;     // a link angle's rotation lock between the ground and the link
    btJointFeedback feedback;  // a separate constraint's
  };

  int plan_node(const Mechanism& m, int link) const {
    return link == m.ground() ? -1 : node_of_link(plan_, link);
  }
  Eigen::Vector2d com(int node) const {
    return node < 0 ? Eigen::Vector2d::Zero() : plan_.nodes[node].centre;
  }
  btRigidBody& body(int node) const {
    if (node < 0) return *ground_;
    if (static_cast<size_t>(node) < bodies_.size()) return *bodies_[static_cast<size_t>(node)];
    for (const auto& [v, arm] : arms_)
      if (v == node) return *arm;
    throw std::logic_error("Bullet: a node without a rigid body");
  }
  // The node of the arm that realises joint `joint`, a point on a circle (arc_geometry).
  int arm_node(int joint) const {
    for (const auto& [v, arm] : arms_)
      if (plan_.nodes[static_cast<size_t>(v)].joint == joint) return v;
    throw std::logic_error("Bullet: a curved slot without its arm");
  }

  // The cams' shapes (SceneContact) on the first `links` nodes: the disc's sphere, the follower's
  // sphere or box (its margin 0: the box's own faces), each placed from its body's centre of mass.
  void add_contact_shapes(int links) {
    shape_.resize(static_cast<size_t>(links));
    group_.assign(static_cast<size_t>(links), 0);
    margin_.assign(static_cast<size_t>(links), 0.0);
    if (!plan_.contacts.empty()) use_contact_margins();
    for (const SceneContact& c : plan_.contacts)
      for (const bool cam : {true, false}) {
        const auto v = static_cast<size_t>((cam ? c.cam : c.follower) - 1);  // graph body to node
        if (!shape_[v]) shape_[v] = std::make_unique<btCompoundShape>();
        group_[v] |= cam ? kCamGroup : kFollowerGroup;
        btTransform at(btQuaternion::getIdentity(),
                       bt((cam ? c.cam_centre : c.follower_centre) - plan_.nodes[v].centre));
        std::unique_ptr<btCollisionShape> child;
        if (!cam && c.face) {
          child = std::make_unique<btBoxShape>(
              btVector3(c.box_half.x(), c.box_half.y(), c.box_half.z()));
          child->setMargin(0.0);
          at.setRotation(rot_z(c.box_angle));
        } else if (cam) {
          margin_[v] = c.margin;
          child = std::make_unique<btSphereShape>(c.cam_radius + margin_[v]);
        } else {
          child = std::make_unique<btSphereShape>(c.follower_radius);
        }
        shape_[v]->addChildShape(at, child.get());
        children_.push_back(std::move(child));
      }
  }

  // Locked axes get lower = upper (the linear x lock at `x_value`); free axes lower > upper.
  static void set_limits(btGeneric6DofSpring2Constraint* c, const Lock& lock, double x_value) {
    c->setLinearLowerLimit(
        btVector3(lock.linear[0] ? x_value : 1.0, lock.linear[1] ? 0.0 : 1.0, 1.0));
    c->setLinearUpperLimit(
        btVector3(lock.linear[0] ? x_value : -1.0, lock.linear[1] ? 0.0 : -1.0, -1.0));
    c->setAngularLowerLimit(btVector3(1.0, 1.0, lock.angular ? 0.0 : 1.0));
    c->setAngularUpperLimit(btVector3(-1.0, -1.0, lock.angular ? 0.0 : -1.0));
  }

  void add(btGeneric6DofSpring2Constraint* c, const Lock& lock) {
    set_limits(c, lock, 0.0);
    for (int axis = 0; axis < 6; ++axis) {
      c->setParam(BT_CONSTRAINT_STOP_ERP, erp_, axis);
      c->setParam(BT_CONSTRAINT_STOP_CFM, 0.0, axis);
    }
    world_->addConstraint(c, true);
    constraints_.push_back(c);
  }

  const Plan& plan_;
  double erp_ = 1.0;
  btDefaultCollisionConfiguration collision_;
  btCollisionDispatcher dispatcher_{&collision_};
  btDbvtBroadphase broadphase_;
  UnboundedDantzig dantzig_;
  btMLCPSolver* mlcp_ = nullptr;
  btConstraintSolver* solver_ = nullptr;
  btDiscreteDynamicsWorld* world_ = nullptr;
  btEmptyShape empty_;
  // Cams (Plan::contacts): per link node, its compound of contact shapes (null: none) and its
  // collision group; the shapes in them; the last step's length (a contact impulse's).
  static constexpr int kCamGroup = 1 << 6, kFollowerGroup = 1 << 7;
  std::vector<std::unique_ptr<btCompoundShape>> shape_;
  std::vector<std::unique_ptr<btCollisionShape>> children_;
  std::vector<int> group_;
  std::vector<double> margin_;  // per link node: its disc's margin (add_contact_shapes)
  double last_dt_ = 1.0;
  btRigidBody* ground_ = nullptr;
  std::vector<btRigidBody*> bodies_;                // per moving link (its node)
  std::vector<std::pair<int, btRigidBody*>> arms_;  // (node, body) per point on a circle
  std::vector<btGeneric6DofSpring2Constraint*> constraints_, joint_constraint_;  // per joint;
                                                                                 // null: a gear
  std::vector<btGearConstraint*> gear_;  // per joint: a gear pair's, or null
  std::vector<Lock> joint_lock_;
  std::vector<btJointFeedback> joint_feedback_;
  std::vector<DriverLock> drivers_;  // per driver; none in forward dynamics
  std::vector<Rough> rough_;         // per joint; a motor for a friction joint
};

// ---------------------------------------------------------------------------------------------
// Run

// Forces of the rigid scene at pose q (the pose the last step left), in the mechanism's terms.
// btJointFeedback holds each constraint's impulse / dt on its bodies, the torques about each
// body's centre of mass: a joint's couple is taken about its point, and a driven joint's own
// constraint carries the driver's row too (its torque about the point, or its force along the
// line, is the effort). `driven_joints`: per driver, the Mechanism joint the scene graph drives.
// The gear pairs' multipliers (Plan::RigidGear): each constraint's, the torque on its first
// body (its coefficient 1) or, the ground first, on its second over its ratio; each pair's the
// mix of them.
Eigen::VectorXd gear_multipliers(const Mechanism& m, const Plan& plan, const Scene& scene) {
  Eigen::VectorXd constraint(static_cast<Eigen::Index>(plan.rigid_gears.size()));
  for (size_t e = 0; e < plan.rigid_gears.size(); ++e) {
    const Plan::RigidGear& gear = plan.rigid_gears[e];
    const btJointFeedback& fb = *scene.feedback(gear.joint);
    constraint(static_cast<Eigen::Index>(e)) = gear.link_a != m.ground()
                                                   ? fb.m_appliedTorqueBodyA.z()
                                                   : fb.m_appliedTorqueBodyB.z() / gear.ratio;
  }
  return plan.rigid_mix.transpose() * constraint;
}

void read_rigid_forces(const Mechanism& m, const Plan& plan, const Scene& scene,
                       const std::vector<int>& driven_joints, const Eigen::VectorXd& q,
                       ForceReading& out) {
  out.set_zero();
  const Eigen::VectorXd gears =
      plan.rigid_gears.empty() ? Eigen::VectorXd() : gear_multipliers(m, plan, scene);
  Eigen::Index gearing = 0;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (j.type == JointType::cam && !arc_geometry(m, j)) {
      out.joint_force[ji] = scene.contact_force(static_cast<int>(ji));
      continue;
    }
    const btJointFeedback& fb = *scene.feedback(static_cast<int>(ji));
    if (j.is_gearing()) {  // the couple on the first moving gear (write_forces: the teeth)
      const double lambda = gears(gearing++);
      out.gear_couple[ji] = m.moving_index(j.link_a) >= 0 ? lambda : lambda * j.ratio;
      continue;
    }
    const BodyMotion a = BodyMotion::of(m.moving_index(j.link_a), q, nullptr, nullptr);
    const BodyMotion b = BodyMotion::of(m.moving_index(j.link_b), q, nullptr, nullptr);
    const Eigen::Vector2d point = b.position(m.links[j.link_b].points[j.point_b].local);
    // On the second link, through the first when the second is the ground.
    Eigen::Vector2d on_b;
    double couple_b = 0.0;
    if (j.link_b != m.ground()) {
      on_b = {fb.m_appliedForceBodyB.x(), fb.m_appliedForceBodyB.y()};
      const Eigen::Vector2d com = b.position(m.links[j.link_b].mass.com);
      couple_b = fb.m_appliedTorqueBodyB.z() - cross(point - com, on_b);
    } else {
      const Eigen::Vector2d on_a(fb.m_appliedForceBodyA.x(), fb.m_appliedForceBodyA.y());
      const Eigen::Vector2d com = a.position(m.links[j.link_a].mass.com);
      on_b = -on_a;
      couple_b = -(fb.m_appliedTorqueBodyA.z() - cross(point - com, on_a));
    }
    if (j.type == JointType::prismatic) out.couple[ji] = couple_b;
    for (size_t di = 0; di < m.drivers.size(); ++di) {
      const Driver& d = m.drivers[di];
      if (d.joint != static_cast<int>(ji) || scene.driver_feedback(di)) continue;
      double& effort = out.effort_of(static_cast<int>(di));
      if (d.type == DriverType::slider) {
        const Eigen::Vector2d u = a.turn(m.links[j.link_a].lines[j.line].direction);
        effort = on_b.dot(u);
        on_b -= effort * u;
      } else {
        effort = couple_b;  // on the second link, the driven one
      }
    }
    out.joint_force[ji] = on_b;
  }
  for (size_t di = 0; di < m.drivers.size(); ++di) {
    const Driver& d = m.drivers[di];
    double& effort = out.effort_of(static_cast<int>(di));
    if (d.type == DriverType::link_angle && !scene.driver_feedback(di)) {
      // Realised at the link's ground pivot: the effort is that joint's couple.
      const int driven_joint = driven_joints[di];
      const Joint& j = m.joints[static_cast<size_t>(driven_joint)];
      const btJointFeedback& fb = *scene.feedback(driven_joint);
      const BodyMotion a = BodyMotion::of(m.moving_index(j.link_a), q, nullptr, nullptr);
      const BodyMotion b = BodyMotion::of(m.moving_index(j.link_b), q, nullptr, nullptr);
      const Eigen::Vector2d point = b.position(m.links[j.link_b].points[j.point_b].local);
      const bool link_is_b = j.link_b == d.link;
      const BodyMotion& l = link_is_b ? b : a;
      const btVector3& f = link_is_b ? fb.m_appliedForceBodyB : fb.m_appliedForceBodyA;
      const btVector3& t = link_is_b ? fb.m_appliedTorqueBodyB : fb.m_appliedTorqueBodyA;
      const Eigen::Vector2d com = l.position(m.links[d.link].mass.com);
      effort = t.z() - cross(point - com, Eigen::Vector2d(f.x(), f.y()));
    } else if (const btJointFeedback* fb = scene.driver_feedback(di)) {
      // A rotation lock between the ground and the link, frames at its centre of mass.
      effort = fb->m_appliedTorqueBodyB.z();
    }
  }
}

// The scene's bodies as the mechanism's coordinates q (frame origins from the centres of mass),
// each angle taken on the turn of the one q holds, so that angles stay continuous.
void read_coordinates(const Scene& scene, const Plan& plan, const Mechanism& m,
                      std::vector<Pose>& frames, Eigen::VectorXd& q) {
  scene.read(frames);
  for (size_t v = 0; v < plan.nodes.size(); ++v) {
    const SceneBody& node = plan.nodes[v];
    if (node.source < 0) continue;
    const int k = m.moving_index(node.source);
    double theta = frames[v].theta;
    theta += 2.0 * kPi * std::round((q(3 * k + 2) - theta) / (2.0 * kPi));
    q(3 * k + 2) = theta;
    q.segment<2>(3 * k) = frames[v].r - turn(theta, node.centre);
  }
}

// ---------------------------------------------------------------------------------------------
// Stages both runs share

// Prepare stage: what a run needs before its time grid, refused (std::exception with the reason)
// before anything is built. The settings, the mechanism the scene is built from (perturb_link),
// and the usable span the run covers, over sample times that increase.
struct Prepared {
  Config config;
  Mechanism m;  // the definition, or the perturbed one
  Span span;
};

Prepared prepare(const Mechanism& original, const Trajectory& reference,
                 const Settings& overrides) {
  if (!btIsDoublePrecision()) throw std::runtime_error("Bullet is not the float64 build");
  Prepared p;
  p.config = parse_settings(overrides);
  p.m = perturbed(original, p.config.shared.perturb_link);
  p.config.shared.resolve(p.m);  // of the scene's
  // The run starts at the reference's first usable (ok) sample and stops at its last; outside
  // them the reference is at or past an assembly limit.
  p.span = usable_span(reference);
  for (int i = 1; i < reference.samples(); ++i)
    if (!(reference.time(i) > reference.time(i - 1)))
      throw std::runtime_error("the reference's sample times do not increase");
  return p;
}

// The values in force both runs print (`steps_per_sample`: each run's own account of it;
// `friction`: of a mechanism with joint friction).
// The step is the grid's longest (an explicit dt divides each sample interval).
Settings common_settings(const Config& config, const TimeGrid& grid, double step_angle,
                         bool friction) {
  Settings values = {
      {"formulation", config.formulation},
      {"solver", config.solver},
      {"dt", format_number(grid.dt)},
      {"steps_per_sample",
       config.dt == 0.0 ? std::to_string(grid.steps_per_sample) : "unused (dt given)"},
      {"max_step_angle", config.dt == 0.0 ? format_number(step_angle) : "unused (dt given)"},
      {"iterations", std::to_string(config.iterations)},
      {"erp", format_number(config.erp)},
      {"precision", btIsDoublePrecision() ? "float64" : "float32"},
      {"split_impulse", config.split_impulse ? "1" : "0"}};
  if (friction) values.emplace_back("friction_cfm", format_number(config.friction_cfm));
  return values;
}

// Scene-plan stage: the scene graph and its spanning tree; the multibody formulation falls back
// to rigid bodies (config.formulation follows) when its tree cannot be cut at revolute joints,
// and a gearing one formulation cannot realise is built by the other when it can (rigid bodies:
// a gear pair about the ground; a multibody: a coupling of two tree joints). A kinematic run
// (`driven`) says how a link angle is realised. False with `why` when there is no scene.
bool plan_scene(const Mechanism& m, bool driven, Config& config, Plan& plan,
                std::vector<std::string>& notes, std::string& why) {
  if (m.has_friction() && config.formulation == "multibody") {
    notes.push_back(
        "joint friction is modelled with rigid bodies only (a multibody's cut pins have no motor, "
        "and its joint feedback, the friction's load, is wrong in 3.24): rigid bodies used");
    config.formulation = "rigid";
  }
  std::string split_error;
  const bool multibody = config.formulation == "multibody";
  try {
    plan = make_plan(m, multibody, &split_error);
  } catch (const std::exception& e) {
    why = e.what();
    try {
      plan = make_plan(m, !multibody, &split_error);
    } catch (const std::exception& other) {
      if (why != other.what()) why += std::string("; ") + other.what();
      return false;
    }
    if (!multibody && !split_error.empty()) return false;
    const std::string other = multibody ? "rigid" : "multibody";
    notes.push_back(fmt::format("the {} formulation cannot realise it ({}): {} used",
                                config.formulation, why, other));
    config.formulation = other;
    why.clear();
  }
  if (!split_error.empty() && config.formulation == "multibody") {
    notes.push_back("multibody formulation impossible (" + split_error + "): rigid bodies used");
    config.formulation = "rigid";
    if (!plan.gearings.empty()) {  // rigid bodies realise fewer gearings
      try {
        plan = make_plan(m, false, nullptr);
      } catch (const std::exception& e) {
        why = e.what();
        return false;
      }
    }
  }
  // Forces from btJointFeedback in the rigid formulation only: btMultiBodyJointFeedback is
  // wrong in 3.24 (bullet3 issues 2966, 4604): it reads the velocity terms twice
  // (tests/sim/bullet/test_bullet_joint_feedback.cpp).
  if (config.formulation != "rigid")
    notes.push_back(
        "forces not read: the multibody formulation's joint feedback is wrong in Bullet 3.24 "
        "(bullet3 issues 2966, 4604)");
  if (!driven) return true;
  for (size_t d = 0; d < plan.driver_edges.size(); ++d) {
    const std::string which =
        m.axis().timed() ? fmt::format(" ('{}')", m.drivers[d].name) : std::string();
    if (plan.driver_planar[d])
      notes.push_back(fmt::format(
          "link-angle driver{} realised directly: the driven link's absolute angle is a joint "
          "coordinate (multibody: rotation of a planar ground joint; rigid: a ground constraint "
          "locking only its rotation)",
          which));
    const int e = plan.driver_edges[d];
    if (e >= 0 && plan.edges[e].kind == Edge::Kind::revolute &&
        m.drivers[d].type == DriverType::link_angle)
      notes.push_back(
          fmt::format("link-angle driver{} realised as the angle of its ground pivot", which));
  }
  return true;
}

// Build stage: the scene at configuration q, its driven coordinates at `coordinate0` (per driver;
// a dynamics run's scene is not `driven`), moving with the mechanism's rates `velocity` when
// given. "" or why it could not be built.
std::string build_scene(const Mechanism& m, const Plan& plan, const Config& config,
                        const Eigen::VectorXd& q, const std::vector<double>& coordinate0,
                        const Eigen::VectorXd* velocity, bool driven,
                        std::unique_ptr<Scene>& scene) {
  const std::vector<Pose> poses = node_poses(m, plan, q);
  silence_profiler();
  // btRigidBody numbers its bodies from a global counter (btRigidBody.cpp's uniqueId, a debug id
  // no solve reads): one scene is built at a time, so that no two threads count at once.
  static std::mutex one_build;
  const std::lock_guard<std::mutex> hold(one_build);
  try {
    if (config.formulation == "multibody")
      scene = std::make_unique<MultiBodyScene>(plan, poses, coordinate0, config, m.gravity, driven);
    else
      scene = std::make_unique<RigidScene>(m, plan, poses, coordinate0, config, driven);
    if (velocity) scene->set_velocities(poses, node_rates(m, plan, q, *velocity));
  } catch (const std::exception& e) {
    return std::string("scene build failed: ") + e.what();
  }
  return "";
}

// The note a run ends with when the MLCP solve was retried with the friction rows softer, or fell
// back ("" when neither).
std::string fallback_note(const Scene& scene) {
  std::string note;
  if (const int softer = scene.softer_solves(); softer > 0)
    note = fmt::format(
        "the MLCP solve failed on the friction rows {} times and was retried softer (friction_cfm "
        "up to 1e-6)",
        softer);
  if (const int fb = scene.fallbacks(); fb > 0)
    note += fmt::format("{}the MLCP solve fell back to sequential impulse {} times",
                        note.empty() ? "" : "; ", fb);
  return note;
}

// ---------------------------------------------------------------------------------------------
// A kinematic run: prepare() and step_length() plan it (plan_kinematic(): span, grid, start);
// plan_scene() and drive_map() place the scene, build_scene() builds it; BulletKinematicScene is
// its backend to the shared run loop (sim/kinematic_run.h), which steps, samples, reads forces and
// judges the statuses.

Settings kinematic_settings(const Config& config, const TimeGrid& grid, bool friction) {
  Settings values = common_settings(config, grid, config.max_step_angle.of(false), friction);
  const Settings shared = config.shared.kinematic_printed(friction);
  values.insert(values.end(), shared.begin(), shared.end());
  values.emplace_back("forces", config.formulation == "rigid"
                                    ? "btJointFeedback of the step leaving each sampled pose"
                                    : "not read (multibody joint feedback is wrong in 3.24)");
  return printed_settings(bullet_settings(), RunKind::kinematic, values, friction);
}

// Driver `di`'s (Mechanism::drivers order) map to its driven edge's coordinate (DriveTarget).
DriveTarget drive_map(const Mechanism& m, const Plan& plan, const Config& config,
                      const KinematicPlan& start, size_t di) {
  const Driver& d = m.drivers[di];
  const std::vector<Pose> poses = node_poses(m, plan, start.q);
  const Edge& de = plan.edges[plan.driver_edges[di]];
  // Whether the tree runs the driven joint from a to b (a pivot written [link, ground] runs from
  // its b, the ground).
  const bool driver_forward =
      de.kind != Edge::Kind::revolute || (de.b >= 0 && de.a == plan.parent[de.b]);
  // Rigid: the driver constraint measures theta_b - theta_a of the joint's own links.
  const double edge_sign = (config.formulation == "multibody" && !driver_forward) ? -1.0 : 1.0;
  // d(edge coordinate)/d(driver value): -1 only for a link angle read off a ground pivot
  // written as [link, ground].
  const double driver_sign =
      (d.type == DriverType::link_angle && de.kind == Edge::Kind::revolute && de.b < 0) ? -1.0
                                                                                        : 1.0;
  return DriveTarget::of(m, start, di, edge_sign * edge_coordinate(de, poses),
                         edge_sign * driver_sign);
}

// The scene stepped and read back as the mechanism's coordinates after each step (angles on the
// turn of the pose before), with the forces of the pose a step leaves: what both runs' scenes
// share. Joint friction is bounded per step by FrictionBounds; the first two steps' readings are
// transients of the start (BulletDynamicsScene), for which the start's trend stands.
class BulletSteps {
 public:
  static constexpr int kTransients = 2;
  BulletSteps(const Mechanism& m, const Plan& plan, Scene& scene, const Eigen::VectorXd& q_start,
              ReadingTrend start, bool extrapolated)
      : m_(m),
        plan_(plan),
        scene_(scene),
        q_(q_start),
        rough_(m.friction_joints()),
        friction_(m, rough_, std::move(start), extrapolated, kTransients),
        reading_(m.joints.size(), m.drivers.size()) {
    for (int e : plan.driver_edges) driven_joints_.push_back(plan.edges[e].joint);
    read_coordinates(scene_, plan_, m_, frames_, q_);
  }
  // "" or why the scene read back is not the start it was built at.
  std::string check_start(const Eigen::VectorXd& q_start) const {
    return start_mismatch(m_, q_, q_start);
  }
  void step(double h, ForceReading* forces) {
    if (friction_.any())
      friction_.bound(h, q_,
                      [&](size_t i, double limit) { scene_.limit_friction(rough_[i], limit); });
    scene_.step(h);
    ++evaluations_;  // stepSimulation(dt, 0, dt): one internal step, one solve of the model
    const bool keep = friction_.reads();
    ForceReading* into = forces ? forces : keep ? &reading_ : nullptr;
    if (into) read_rigid_forces(m_, plan_, scene_, driven_joints_, q_, *into);
    if (friction_.any())
      friction_work_ = friction_.settle(h, keep ? into : nullptr, [&](size_t i) {
        return FrictionBounds::Step{read_friction(rough_[i], into),
                                    scene_.friction_rate(rough_[i]) * h};
      });
    read_coordinates(scene_, plan_, m_, frames_, q_);
  }
  Scene& scene() { return scene_; }
  const Eigen::VectorXd& pose() const { return q_; }  // the pose the last step reached
  long evaluations() const { return evaluations_; }
  std::string note() const { return fallback_note(scene_); }
  double friction_work() const { return friction_work_; }  // over the last step [J]

 private:
  // After a step from pose q_: joint ji's friction on its second link (semi-implicit Euler: the
  // step moves at its end's rates), also into `out` when given (a slide's also into its joint's
  // force, as the exact method's).
  double read_friction(int joint, ForceReading* out) const {
    const double friction = scene_.friction(joint);
    if (!out) return friction;
    const size_t ji = static_cast<size_t>(joint);
    out->friction[ji] = friction;
    // A driven joint's friction is in its driver's row (RigidScene::Rough).
    if (const int d = scene_.friction_driver(joint); d >= 0) {
      const Driver& driver = m_.drivers[static_cast<size_t>(d)];
      const bool on_first =
          driver.type == DriverType::link_angle && m_.joints[ji].link_a == driver.link;
      out->effort_of(d) -= on_first ? -friction : friction;
    }
    if (const Joint& j = m_.joints[ji]; j.is_slide()) {
      const BodyMotion a = BodyMotion::of(m_.moving_index(j.link_a), q_, nullptr, nullptr);
      out->joint_force[ji] += friction * a.turn(m_.links[j.link_a].lines[j.line].direction);
    }
    return friction;
  }

  const Mechanism& m_;
  const Plan& plan_;
  Scene& scene_;
  std::vector<int> driven_joints_;  // per driver: the Mechanism joint the scene graph drives
  std::vector<Pose> frames_;
  Eigen::VectorXd q_;
  std::vector<int> rough_;  // the joints with friction
  FrictionBounds friction_;
  ForceReading reading_;  // scratch: a step's reading for the friction's load
  double friction_work_ = 0.0;
  long evaluations_ = 0;
};

// What a Bullet scene answers the same in both run loops (KinematicScene and DynamicsScene).
template <class Loop>
class BulletLoopScene : public Loop {
 public:
  explicit BulletLoopScene(BulletSteps& steps) : steps_(steps) {}
  void apply(const std::vector<BodyLoad>& loads) override { steps_.scene().apply(loads); }
  void read_pose(Eigen::VectorXd& q) override { q = steps_.pose(); }
  long evaluations() const override { return steps_.evaluations(); }
  std::string note() const override { return steps_.note(); }

 protected:
  BulletSteps& steps_;
};

// A kinematic run's scene for the shared run loop (sim/kinematic_run.h): driven to its target.
class BulletKinematicScene final : public BulletLoopScene<KinematicScene> {
 public:
  BulletKinematicScene(BulletSteps& steps, const std::vector<DriveTarget>& drive)
      : BulletLoopScene(steps), drive_(drive), targets_(drive.size()) {}
  void drive(const std::vector<double>& driver_values) override {
    for (size_t d = 0; d < drive_.size(); ++d) targets_[d] = drive_[d].target(driver_values[d]);
    steps_.scene().drive(targets_);
  }
  std::string step(double h, ForceReading* forces) override {
    steps_.step(h, forces);
    return "";
  }

 private:
  const std::vector<DriveTarget>& drive_;  // per driver
  std::vector<double> targets_;            // scratch: per driver
};

// ---------------------------------------------------------------------------------------------
// Forward dynamics (a [dynamics] case; docs/engines.md, "Forward dynamics"): the same scene with
// no driver, started from the exact state of the reference's first usable sample, the loads and
// the applied effort on the bodies every step, sampled at the reference's times (which fall on
// step boundaries). prepare() and step_length() plan it (plan_dynamics()); plan_scene() and
// build_scene() build it; BulletDynamicsScene is its backend to the shared run loop
// (sim/dynamics_run.h).

Settings dynamics_settings(const Config& config, const TimeGrid& grid, double energy_scale,
                           bool with_forces, bool friction) {
  Settings values = common_settings(config, grid, config.max_step_angle.of(true), friction);
  const Settings shared = config.shared.dynamics_printed(energy_scale, friction);
  values.insert(values.end(), shared.begin(), shared.end());
  values.emplace_back("start", config.staggered_start ? "staggered (v0 - h/2 a0)" : "exact (v0)");
  values.emplace_back("forces", with_forces
                                    ? "btJointFeedback of the step leaving each sample"
                                    : "not read (multibody joint feedback is wrong in 3.24)");
  return printed_settings(bullet_settings(), RunKind::dynamics, values, friction);
}

// A dynamics run's scene for the shared run loop (sim/dynamics_run.h): no driver (slides' frames
// follow their sliders), the loads at the pose a step leaves, read back as the mechanism's
// coordinates after each step, the forces of the pose a step leaves. Semi-implicit Euler keeps
// the velocity half a step behind the positions (x_k+1 = x_k + h v_k+1), so a staggered start is
// v0 - h/2 a0 (a0 the exact acceleration). The start is a transient in Bullet: its first step's
// constraint solve has no position error of a previous step to correct, while every later one
// does (each step's velocity constraint is taken at the step's start, and the position error
// this leaves is closed by the next step's ERP), so the first step's impulses, and a stencil
// through pose 0, are off by up to 5 % of the peak reaction (A02; measured): there is no pose
// before the start, and the loop reads the first sample one-sided and its forces from pose 2 on.
class BulletDynamicsScene final : public BulletLoopScene<DynamicsScene> {
 public:
  BulletDynamicsScene(BulletSteps& steps, Eigen::VectorXd start_velocity)
      : BulletLoopScene(steps), start_velocity_(std::move(start_velocity)) {}
  Eigen::VectorXd start_velocity() const override { return start_velocity_; }
  std::string step(double /*t0*/, double h, ForceReading* forces) override {
    steps_.scene().drive({});  // no driver: the slides' frames follow
    steps_.step(h, forces);
    return "";
  }
  double friction_work() const override { return steps_.friction_work(); }

 private:
  Eigen::VectorXd start_velocity_;
};

EngineRun run_dynamics(const Mechanism& original, const Trajectory& reference,
                       const Settings& overrides) {
  const auto begin = Clock::now();
  EngineRun out;
  out.trajectory.method = "bullet";
  out.trajectory.resize_as(original, reference, false, true);
  Prepared p;
  DynamicsPlan start;
  try {
    p = prepare(original, reference, overrides);
    start = plan_dynamics(original, p.m, reference,
                          step_length(reference, p.span, p.config.dt,
                                      p.config.max_step_angle.of(true), p.config.steps_per_sample),
                          InnerTimes::interval_fractions, p.config.shared.max_steps,
                          !p.config.shared.perturb_link.empty());
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  Config& config = p.config;
  const Mechanism& m = p.m;

  Plan plan;
  std::vector<std::string> notes;
  std::string why;
  if (!plan_scene(m, false, config, plan, notes, why)) return failed_run(std::move(out), why);
  const bool with_forces = config.formulation == "rigid";
  const std::vector<double>& time = start.grid.time;
  const Eigen::VectorXd velocity =
      config.staggered_start
          ? Eigen::VectorXd(start.start.qdot - 0.5 * (time[1] - time[0]) * start.start.qddot)
          : start.start.qdot;
  std::unique_ptr<Scene> scene;
  if (why = build_scene(m, plan, config, start.start.q, {}, &velocity, false, scene); !why.empty())
    return failed_run(std::move(out), why);
  const double energy_scale = std::max(reference_energy_scale(original, reference), 1e-12);
  out.settings = dynamics_settings(config, start.grid, energy_scale, with_forces, m.has_friction());
  BulletSteps steps(m, plan, *scene, start.start.q,
                    reference_trend(m, reference, start.span.first, time.front()),
                    config.shared.extrapolated_load);
  if (why = steps.check_start(start.start.q); !why.empty()) return failed_run(std::move(out), why);
  BulletDynamicsScene stepped(steps, velocity);
  const DynamicsWatch watch = config.shared.dynamics_watch(m, energy_scale);
  run_dynamics(original, m, reference, start, watch, with_forces, stepped, begin, out);
  for (const std::string& note : notes) add_note(out.message, note);
  return out;
}

class BulletEngine final : public Engine {
 public:
  std::string name() const override { return "bullet"; }

  bool supports(const Mechanism& mechanism, std::string* why) const override {
    // Joint friction: rigid bodies only (plan_scene).
    if (mechanism.has_friction()) {
      try {
        (void)make_plan(mechanism, false, nullptr);
      } catch (const std::exception& e) {
        if (why)
          *why = fmt::format("{} (joint friction is modelled with rigid bodies only)", e.what());
        return false;
      }
      return true;
    }
    // Either formulation (plan_scene takes the other when the one asked for cannot).
    try {
      (void)make_plan(mechanism, false, nullptr);
    } catch (const std::exception& e) {
      std::string split_error;
      try {
        (void)make_plan(mechanism, true, &split_error);
      } catch (const std::exception& other) {
        split_error = other.what();
      }
      if (!split_error.empty()) {
        if (why) *why = e.what() + (split_error != e.what() ? "; " + split_error : "");
        return false;
      }
    }
    return true;
  }

  const SettingSchema& settings_schema() const override { return bullet_settings(); }

  // Every name and every value, perturb_link's link among the mechanism's.
  void check_settings(const Mechanism& m, const Settings& overrides) const override {
    (void)perturbed(m, parse_settings(overrides).shared.perturb_link);
  }

  EngineRun run(const Mechanism& original, const Trajectory& reference,
                const Settings& overrides) const override;
};

// A kinematic run: plan, build, step, then sample, read forces and judge each sample, and the
// notes (the stages above).
EngineRun BulletEngine::run(const Mechanism& original, const Trajectory& reference,
                            const Settings& overrides) const {
  if (original.dynamics) return run_dynamics(original, reference, overrides);
  const auto begin = Clock::now();
  EngineRun out;
  out.trajectory.method = "bullet";
  out.trajectory.resize_as(original, reference, false);
  Prepared p;
  try {
    p = prepare(original, reference, overrides);
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  Config& config = p.config;
  const Mechanism& m = p.m;
  const KinematicWatch watch = config.shared.kinematic_watch(m);
  KinematicPlan start;
  try {
    start = plan_kinematic(m, reference,
                           step_length(reference, p.span, config.dt,
                                       config.max_step_angle.of(false), config.steps_per_sample),
                           InnerTimes::interval_fractions, m.has_cam() ? kContactPreroll : kPreroll,
                           config.shared.max_steps, config.shared.singular_rcond,
                           !config.shared.perturb_link.empty());
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  out.settings = kinematic_settings(config, start.grid, m.has_friction());

  Plan plan;
  std::vector<std::string> notes;
  std::string why;
  if (!plan_scene(m, true, config, plan, notes, why)) return failed_run(std::move(out), why);
  // The formulation may have fallen back.
  out.settings = kinematic_settings(config, start.grid, m.has_friction());
  const bool with_forces = config.formulation == "rigid";
  std::vector<DriveTarget> drive;
  std::vector<double> coordinate0;
  for (size_t d = 0; d < m.drivers.size(); ++d) {
    drive.push_back(drive_map(m, plan, config, start, d));
    coordinate0.push_back(drive.back().coordinate0);
  }
  std::unique_ptr<Scene> scene;
  if (why = build_scene(m, plan, config, start.q, coordinate0, &start.qdot, true, scene);
      !why.empty())
    return failed_run(std::move(out), why);
  BulletSteps steps(m, plan, *scene, start.q,
                    reference_trend(m, reference, start.span.first, start.grid.time.front()),
                    config.shared.extrapolated_load);
  if (why = steps.check_start(start.q); !why.empty()) return failed_run(std::move(out), why);
  BulletKinematicScene stepped(steps, drive);
  for (const std::string& note : notes) add_note(start.note, note);
  run_kinematic(original, m, reference, start, watch, with_forces, stepped, begin, out);
  return out;
}

}  // namespace

std::unique_ptr<Engine> make_bullet_engine() {
  return std::make_unique<BulletEngine>();
}

}  // namespace crosslink::sim
