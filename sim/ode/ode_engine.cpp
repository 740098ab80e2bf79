// ODE 0.16 (double precision) scene of a Mechanism: build, step, sample. See docs/engines.md,
// "ODE".
//
// Maximal coordinates, as Bullet's rigid formulation: one ODE body per body of the scene graph
// (the moving links, one block per pin-in-slot), its origin at its centre of mass (ODE requires
// it), one ODE joint per scene joint (a hinge about z per revolute, a slider per slide), the loop
// closed by the joints themselves (no tree). The hinges' out-of-plane rows (z and the two tilts)
// are redundant around a loop; a CFM above 0 regularises them. The driven joint's motor takes the
// velocity that lands the driven coordinate on the driver's law at the end of the step (ERP 1:
// each step is a Newton step of the constraints towards the next driver value).
#include "sim/ode/ode_engine.h"

#include <fmt/format.h>
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>

#include "analytic/kinematics/newton.h"
#include "analytic/model/planar.h"
#include "analytic/physics/kinetostatics.h"
#include "sim/dynamics_run.h"
#include "sim/forces.h"
#include "sim/kinematic_run.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"
#include "sim/scene_graph.h"
#include "sim/settings.h"
#include "sim/shared_settings.h"
#include "sim/statuses.h"

namespace crosslink::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr long kPreroll = 4;  // periodic sweeps: steps run before the first sample (and after
                              // the last), so the start's transient stays out of the stencils
// A cam's contact joint carries the start's transient longer (its first step's force lacks the
// velocity terms as every joint's, and the follower then settles on the disc).
constexpr long kContactPreroll = 32;
// The default step's largest turn of the fastest link [rad]: kinematic runs as Bullet's (each step
// is a Newton step towards the driver, error O(dt^2)); forward dynamics as MuJoCo's and Bullet's
// (errors accumulate over a run).
constexpr double kKinematicMaxStepAngle = 0.01;
constexpr double kDynamicsMaxStepAngle = 0.0025;

// ---------------------------------------------------------------------------------------------
// ODE's process-wide state: initialised once; errors become exceptions.

// The last dMessage of this thread (ODE's warnings, e.g. an LCP that failed): the step that made
// it is flagged.
thread_local std::string ode_message;

std::string format_ode(int errnum, const char* msg, va_list ap) {
  char text[1024];
  std::vsnprintf(text, sizeof text, msg, ap);
  return fmt::format("ODE {}: {}", errnum, text);
}

// ODE aborts (dDebug) or exits (dError) after these return: they throw instead.
[[noreturn]] void ode_error(int errnum, const char* msg, va_list ap) {
  throw std::runtime_error(format_ode(errnum, msg, ap));
}
void ode_warning(int errnum, const char* msg, va_list ap) {
  ode_message = format_ode(errnum, msg, ap);
}

}  // namespace

void ode_start() {
  static std::once_flag once;
  static bool double_precision = false;
  std::call_once(once, [] {
    dSetErrorHandler(ode_error);
    dSetDebugHandler(ode_error);
    dSetMessageHandler(ode_warning);
    dInitODE2(0);
    double_precision = dCheckConfiguration("ODE_double_precision") == 1;
  });
  if (!double_precision)
    throw std::runtime_error(
        "the ODE library linked is not the double-precision build (dCheckConfiguration("
        "\"ODE_double_precision\") is 0): install Debian's libode-dev");
  // Idempotent per thread; ODE's per-thread data (needed when built with its OU extension).
  if (!dAllocateODEDataForThread(dAllocateMaskAll))
    throw std::runtime_error("ODE could not allocate its data for this thread");
}

namespace {

// ---------------------------------------------------------------------------------------------
// Settings

struct Config {
  std::string stepper = "world";  // world (dWorldStep) | quick (dWorldQuickStep)
  int iterations = 20;            // quick's
  double dt = 0.0;                // 0: auto
  int steps_per_sample = 2;
  StepAngle max_step_angle;
  double erp = 1.0;
  double cfm = 1e-10;
  double friction_cfm = 1e-8;
  double contact_erp = 1.0, contact_cfm = 1e-10;  // a cam's contact joint's (ODE's soft_erp, cfm)
  bool finite_rotation = true;
  bool staggered_start = true;
  SharedSettings shared;  // the watch's thresholds, the test hook, the step budget
};

const SettingSchema& ode_settings() {
  using enum SettingKind;
  using enum AppliesTo;
  static const SettingSchema schema = {
      {.name = "stepper",
       .kind = choice,
       .default_value = "world",
       .doc = "world: dWorldStep (exact LCP); quick: dWorldQuickStep (iterative)",
       .words = {"quick", "world"}},
      {.name = "iterations",
       .kind = count,
       .default_value = "20",
       .doc = "dWorldQuickStep's iterations",
       .most = kMostIterations},
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
      {.name = "erp",
       .kind = number,
       .default_value = "1",
       .doc = "the world's error reduction per step",
       .range = {0.0, 1.0}},
      {.name = "cfm",
       .kind = number,
       .default_value = "1e-10",
       .doc = "the world's constraint force mixing (above 0: the loops' out-of-plane rows are "
              "redundant and ODE aborts at 0)",
       .range = {0.0, 1.0, true}},
      {.name = "finite_rotation",
       .kind = choice,
       .default_value = "1",
       .doc = "dBodySetFiniteRotationMode: 1 the exact rotation update, 0 ODE's default "
              "(loses (w dt)^3/12 a step)",
       .words = {"0", "1"}},
      shared_setting("friction_load"),
      {.name = "friction_cfm",
       .kind = number,
       .default_value = "1e-8",
       .doc = "the friction motors' constraint force mixing (at the world's 1e-10 the LCP of a "
              "loop with friction at every pin fails)",
       .range = {0.0, 1.0, true},
       .friction = true},
      {.name = "contact_erp",
       .kind = number,
       .default_value = "1",
       .doc = "a cam's contact joint's error reduction per step (its soft_erp)",
       .range = {0.0, 1.0},
       .contact = true},
      {.name = "contact_cfm",
       .kind = number,
       .default_value = "1e-10",
       .doc = "a cam's contact joint's constraint force mixing (its soft_cfm)",
       .range = {0.0, 1.0, true},
       .contact = true},
      {.name = "precision", .doc = "the ODE build linked", .reported = true},
      shared_setting("gap_threshold"),
      shared_setting("divergence_gap"),
      shared_setting("driver_threshold"),
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
  };
  return schema;
}

Config parse_settings(const Settings& overrides) {
  const SettingValues v(ode_settings(), "ODE", overrides);
  Config c;
  c.stepper = v.text("stepper");
  c.iterations = static_cast<int>(v.count("iterations"));
  c.dt = v.is("dt", "auto") ? 0.0 : v.number("dt");
  c.steps_per_sample = static_cast<int>(v.count("steps_per_sample"));
  c.max_step_angle = StepAngle(v, kKinematicMaxStepAngle, kDynamicsMaxStepAngle);
  c.erp = v.number("erp");
  c.cfm = v.number("cfm");
  c.friction_cfm = v.number("friction_cfm");
  c.contact_erp = v.number("contact_erp");
  c.contact_cfm = v.number("contact_cfm");
  c.finite_rotation = v.is("finite_rotation", "1");
  c.staggered_start = v.is("start", "staggered");
  c.shared = SharedSettings(v);
  return c;
}

// ---------------------------------------------------------------------------------------------
// Geometry

Eigen::Vector2d turn(double angle, const Eigen::Vector2d& v) {
  return Eigen::Rotation2Dd(angle) * v;
}

// A scene body's frame (the ground's is the world's) at mechanism coordinates q.
BodyMotion frame_of(const Mechanism& m, const SceneBody& body, const Eigen::VectorXd& q,
                    const Eigen::VectorXd* qdot = nullptr) {
  if (body.ground) return BodyMotion{};
  return body_motion(m, body, q, qdot);
}

// The value of scene joint `j` at q: a hinge's theta_b - theta_a, a slide's s, a planar joint's
// theta_b (angles continuous: q's are).
double joint_value(const Mechanism& m, const SceneGraph& g, const SceneJoint& j,
                   const Eigen::VectorXd& q) {
  const BodyMotion a = frame_of(m, g.bodies[static_cast<size_t>(j.a)], q);
  const BodyMotion b = frame_of(m, g.bodies[static_cast<size_t>(j.b)], q);
  if (j.kind != SceneJoint::Kind::slide) return b.theta - a.theta;
  const Eigen::Vector2d point = b.r + turn(b.theta, j.ub), origin = a.r + turn(a.theta, j.origin);
  return turn(a.theta, j.direction).dot(point - origin);
}

// ---------------------------------------------------------------------------------------------
// Scene

// Every body's mass, inertia and start pose must be finite and the masses and inertias positive:
// ODE aborts the process on an invalid mass (dBodySetMass), so these are refused first.
void check_bodies(const Mechanism& m, const SceneGraph& g, const Eigen::VectorXd& q) {
  for (const SceneBody& b : g.bodies) {
    if (b.ground) continue;
    if (!(std::isfinite(b.mass) && b.mass > 0.0) || !(std::isfinite(b.inertia) && b.inertia > 0.0))
      throw std::runtime_error(fmt::format(
          "body {}: mass {} kg and inertia {} kg m^2 must be positive and finite for ODE", b.name,
          b.mass, b.inertia));
    if (!b.centre.allFinite())
      throw std::runtime_error(fmt::format("body {}: its centre of mass is not finite", b.name));
  }
  if (!q.allFinite()) throw std::runtime_error("the start configuration is not finite");
  if (!m.gravity.allFinite()) throw std::runtime_error("gravity is not finite");
}

// What a failed step may owe to the scene, in the mechanism's words: links whose masses are 1e6
// or more apart. A massless link gets auxiliary_mass() (1e-6 of the lightest link); the
// crank-rocker with a massless crank (1.5e6 apart) stopped in ODE's assertion
// "!bSafeNormalize4Fault" (a rotation gone NaN) at cfm 1e-10, and ran at cfm 1e-6: the solve's
// regularisation is too small against the light link's inverse mass. "" otherwise.
std::string mass_span(const Mechanism& m, const SceneGraph& g, double cfm) {
  const SceneBody* light = nullptr;
  const SceneBody* heavy = nullptr;
  for (const SceneBody& b : g.bodies) {
    if (b.ground || b.source < 0) continue;
    if (!light || b.mass < light->mass) light = &b;
    if (!heavy || b.mass > heavy->mass) heavy = &b;
  }
  if (!light || !(heavy->mass >= 1e6 * light->mass)) return "";
  const Link& l = m.links[static_cast<size_t>(light->source)];
  const Link& h = m.links[static_cast<size_t>(heavy->source)];
  const std::string lightest =
      l.mass.mass > 0.0
          ? fmt::format("link '{}' {:.3g} kg", l.name, l.mass.mass)
          : fmt::format("link '{}', massless (in the scene {:.3g} kg, 1e-6 of the lightest link)",
                        l.name, light->mass);
  return fmt::format(
      "; the links' masses are {:.2g} apart ({} against link '{}' {:.3g} kg), more than ODE's "
      "constraint solve resolves at cfm = {:g}: a larger cfm (--set ode:cfm=...) or closer masses",
      heavy->mass / light->mass, lightest, h.name, heavy->mass, cfm);
}

// The worlds whose step an ODE error interrupted, with their threading implementations (~OdeScene).
// Never destroyed: a vector with static storage is freed before LeakSanitizer looks at exit, and
// the worlds it held were then reported as leaked.
std::mutex interrupted_mutex;
auto* const interrupted_worlds = new std::vector<std::pair<dWorldID, dThreadingImplementationID>>;

// dWorldQuickStep reorders its rows at random by ODE's one process-wide generator (dRandInt), so
// a quick-step run's numbers depended on the runs before it and, over threads, beside it. A
// quick-step scene holds the generator for its run and starts it from ODE's initial seed (0):
// every run gives the numbers of a lone run, serial or over `--jobs` threads.
std::mutex quick_step_mutex;
constexpr unsigned long kQuickStepSeed = 0;

// ODE's own record of one joint's last step: forces [N] on its bodies and torques [N m] about
// their centres of mass, per scene body (body1 or body2 of the ODE joint).
struct JointSide {
  Eigen::Vector2d force = Eigen::Vector2d::Zero();
  double torque = 0.0;
};

class OdeScene {
 public:
  // The scene at q (moving at qdot when given); `driven`: each driver's motor on its joint.
  OdeScene(const Mechanism& m, const SceneGraph& g, const Config& config, const Eigen::VectorXd& q,
           const Eigen::VectorXd* qdot, bool driven)
      : m_(m),
        g_(g),
        quick_(config.stepper == "quick"),
        cfm_(config.cfm),
        friction_cfm_(config.friction_cfm) {
    check_bodies(m, g, q);
    if (quick_) {
      random_order_ = std::unique_lock<std::mutex>(quick_step_mutex);
      dRandSetSeed(kQuickStepSeed);
    }
    world_ = dWorldCreate();
    threading_ = dThreadingAllocateSelfThreadedImplementation();
    dWorldSetStepThreadingImplementation(world_, dThreadingImplementationGetFunctions(threading_),
                                         threading_);
    dWorldSetGravity(world_, m.gravity.x(), m.gravity.y(), 0.0);
    dWorldSetERP(world_, config.erp);
    dWorldSetCFM(world_, config.cfm);  // before the joints: their motors take it then
    dWorldSetQuickStepNumIterations(world_, config.iterations);
    dWorldSetAutoDisableFlag(world_, 0);
    bodies_.assign(g.bodies.size(), nullptr);
    for (size_t i = 0; i < g.bodies.size(); ++i) {
      const SceneBody& sb = g.bodies[i];
      if (sb.ground) continue;
      dBodyID b = dBodyCreate(world_);
      dMass mass;
      dMassSetParameters(&mass, sb.mass, 0.0, 0.0, 0.0, sb.inertia, sb.inertia, sb.inertia, 0.0,
                         0.0, 0.0);
      dBodySetMass(b, &mass);
      const BodyMotion f = frame_of(m, sb, q, qdot);
      const Eigen::Vector2d arm = turn(f.theta, sb.centre), c = f.r + arm;
      dBodySetPosition(b, c.x(), c.y(), 0.0);
      const dQuaternion turn_z = {std::cos(0.5 * f.theta), 0.0, 0.0, std::sin(0.5 * f.theta)};
      dBodySetQuaternion(b, turn_z);
      if (qdot) {
        const Eigen::Vector2d v = f.v + f.omega * perp(arm);
        dBodySetLinearVel(b, v.x(), v.y(), 0.0);
        dBodySetAngularVel(b, 0.0, 0.0, f.omega);
      }
      dBodySetFiniteRotationMode(b, config.finite_rotation ? 1 : 0);
      dBodySetDamping(b, 0.0, 0.0);
      bodies_[i] = b;
    }
    joints_.assign(g.joints.size(), nullptr);
    body1_.assign(g.joints.size(), -1);
    feedback_.resize(g.joints.size());
    for (size_t ji = 0; ji < g.joints.size(); ++ji) {
      const SceneJoint& j = g.joints[ji];
      const bool motor =
          driven && std::any_of(g.driven.begin(), g.driven.end(), [&](const DrivenCoordinate& d) {
            return d.joint == static_cast<int>(ji);
          });
      // ODE's body1 is always a moving body (the ground is body2, 0).
      const int first = bodies_[static_cast<size_t>(j.a)] ? j.a : j.b;
      const int second = first == j.a ? j.b : j.a;
      const BodyMotion a = frame_of(m, g.bodies[static_cast<size_t>(j.a)], q);
      dJointID joint = nullptr;
      if (j.kind == SceneJoint::Kind::hinge) {
        joint = dJointCreateHinge(world_, nullptr);
        dJointAttach(joint, bodies_[static_cast<size_t>(first)],
                     bodies_[static_cast<size_t>(second)]);
        const Eigen::Vector2d p = a.r + turn(a.theta, j.ua);
        dJointSetHingeAnchor(joint, p.x(), p.y(), 0.0);
        dJointSetHingeAxis(joint, 0.0, 0.0, 1.0);
        if (motor) dJointSetHingeParam(joint, dParamFMax, dInfinity);
      } else if (j.kind == SceneJoint::Kind::slide) {
        joint = dJointCreateSlider(world_, nullptr);
        dJointAttach(joint, bodies_[static_cast<size_t>(first)],
                     bodies_[static_cast<size_t>(second)]);
        const Eigen::Vector2d u = turn(a.theta, j.direction);
        dJointSetSliderAxis(joint, u.x(), u.y(), 0.0);
        if (motor) dJointSetSliderParam(joint, dParamFMax, dInfinity);
      } else if (motor) {
        // A floating link's driven angle: an angular motor about z between it and the ground.
        joint = dJointCreateAMotor(world_, nullptr);
        dJointAttach(joint, bodies_[static_cast<size_t>(first)], nullptr);
        dJointSetAMotorMode(joint, dAMotorUser);
        dJointSetAMotorNumAxes(joint, 1);
        dJointSetAMotorAxis(joint, 0, 0, 0.0, 0.0, 1.0);
        dJointSetAMotorParam(joint, dParamFMax, dInfinity);
      } else {
        continue;  // a planar joint is no constraint: the body is free in the plane
      }
      dJointSetFeedback(joint, &feedback_[ji]);
      joints_[ji] = joint;
      body1_[ji] = first;
    }
    transmission_feedback_.resize(g.couplings.size());
    for (const SceneCoupling& c : g.couplings) add_transmission(c.source, q);
    friction_feedback_.resize(g.joints.size());
    for (size_t ji = 0; ji < g.joints.size(); ++ji) add_friction(ji, driven, q);
    contact_erp_ = config.contact_erp;
    contact_cfm_ = config.contact_cfm;
    contacts_.resize(g.contacts.size());  // sized before any joint points into a feedback
    for (size_t c = 0; c < g.contacts.size(); ++c) add_contact(c);
    arc_feedback_.resize(g.arcs.size());
    for (size_t k = 0; k < g.arcs.size(); ++k) add_arc(k, q);
    if (driven)
      for (const DrivenCoordinate& dc : g.driven) {
        Motor motor;
        motor.joint = joints_[static_cast<size_t>(dc.joint)];
        // The motor's rate is body1's less body2's: the driven joint's value runs from a to b.
        motor.sign = body1_[static_cast<size_t>(dc.joint)] == g.joints[dc.joint].b ? 1.0 : -1.0;
        motor.kind = g.joints[dc.joint].kind;
        motors_.push_back(motor);
      }
  }

  ~OdeScene() {
    if (interrupted_) {
      // A step an ODE error interrupted leaves its jobs in the threading implementation's list,
      // and freeing it then asserts (an error in a destructor: std::terminate). Kept, unused,
      // until the process ends (reachable: no leak).
      const std::lock_guard<std::mutex> lock(interrupted_mutex);
      interrupted_worlds->emplace_back(world_, threading_);
      return;
    }
    dWorldSetStepThreadingImplementation(world_, nullptr, nullptr);
    dThreadingFreeImplementation(threading_);
    for (const Contact& c : contacts_) {  // no space holds them: each destroyed alone
      dGeomDestroy(c.cam);
      dGeomDestroy(c.follower);
    }
    if (contact_group_) dJointGroupDestroy(contact_group_);
    dWorldDestroy(world_);  // its bodies and joints with it
  }
  OdeScene(const OdeScene&) = delete;
  OdeScene& operator=(const OdeScene&) = delete;

  // Driver d's motor rate for the next step of h: its joint from `value` to `target`.
  void drive(size_t d, double value, double target, double h) {
    const Motor& motor = motors_[d];
    const double rate = motor.sign * (target - value) / h;
    if (motor.kind == SceneJoint::Kind::hinge)
      dJointSetHingeParam(motor.joint, dParamVel, rate);
    else if (motor.kind == SceneJoint::Kind::slide)
      dJointSetSliderParam(motor.joint, dParamVel, rate);
    else
      dJointSetAMotorParam(motor.joint, dParamVel, rate);
  }

  // The definition's loads on the links' bodies (Mechanism order), for the next step.
  void apply(const std::vector<BodyLoad>& loads) {
    for (size_t k = 0; k < loads.size(); ++k) {
      dBodyID b = bodies_[k + 1];  // the moving links follow the ground
      dBodyAddForce(b, loads[k].force.x(), loads[k].force.y(), 0.0);
      dBodyAddTorque(b, 0.0, 0.0, loads[k].moment);
    }
  }

  // One step; "" or ODE's warning of it.
  std::string step(double h) {
    ode_message.clear();
    touch(h);
    try {
      if (quick_)
        dWorldQuickStep(world_, h);
      else
        dWorldStep(world_, h);
    } catch (const std::exception& e) {
      interrupted_ = true;
      throw std::runtime_error(
          fmt::format("a step failed inside ODE ({}){}", e.what(), mass_span(m_, g_, cfm_)));
    }
    std::string message;
    message.swap(ode_message);
    return message;
  }

  // The mechanism's coordinates, each angle on the turn of the one q holds.
  void read(Eigen::VectorXd& q) const {
    for (size_t i = 0; i < g_.bodies.size(); ++i) {
      const SceneBody& sb = g_.bodies[i];
      if (sb.source < 0 || sb.ground) continue;
      const int k = m_.moving_index(sb.source);
      const dReal* c = dBodyGetPosition(bodies_[i]);
      const dReal* r = dBodyGetRotation(bodies_[i]);  // 3x4, row-major
      double theta = std::atan2(r[4], r[0]);
      theta += 2.0 * kPi * std::round((q(3 * k + 2) - theta) / (2.0 * kPi));
      q(3 * k + 2) = theta;
      q.segment<2>(3 * k) = Eigen::Vector2d(c[0], c[1]) - turn(theta, sb.centre);
    }
  }

  // The force gear pair `joint` (Mechanism index) put on its first gear in the last step, at the
  // pitch point (ODE's contact point).
  Eigen::Vector2d tooth_force(int joint) const {
    for (size_t t = 0; t < transmissions_.size(); ++t)
      if (transmissions_[t].first == joint) {
        const dReal* f = transmission_feedback_[t].f1;
        return {f[0], f[1]};
      }
    throw std::logic_error("no transmission for this gear pair");
  }

  // What joint `j` exerted on scene body `body` in the last step (about its centre of mass);
  // nothing on the ground.
  JointSide on(size_t j, int body) const {
    JointSide s;
    if (!joints_[j] || !bodies_[static_cast<size_t>(body)]) return s;
    const dJointFeedback& f = feedback_[j];
    const bool first = body1_[j] == body;
    const dReal* force = first ? f.f1 : f.f2;
    s.force = {force[0], force[1]};
    s.torque = first ? f.t1[2] : f.t2[2];
    return s;
  }

  // What curved slot k (SceneGraph::arcs) put on its pin's link in the last step (through its
  // guide when the pin's is the ground).
  Eigen::Vector2d arc_force(size_t k) const {
    const dJointFeedback& f = arc_feedback_[k];
    const dReal* on = bodies_[static_cast<size_t>(g_.arcs[k].pin)] ? f.f1 : f.f2;
    const Eigen::Vector2d force(on[0], on[1]);
    return bodies_[static_cast<size_t>(g_.arcs[k].pin)] ? force : Eigen::Vector2d(-force);
  }

  // What cam contact c (SceneGraph::contacts) put on its follower in the last step: nothing while
  // its shapes were apart.
  Eigen::Vector2d contact_force(size_t c) const {
    const Contact& contact = contacts_[c];
    if (!contact.touching) return Eigen::Vector2d::Zero();
    const dReal* f = contact.follower_first ? contact.feedback.f1 : contact.feedback.f2;
    return {f[0], f[1]};
  }

  // Whether motors drive the drivers' joints (a kinematic run).
  bool driving() const { return !motors_.empty(); }

  // Joint friction (docs/engines.md, "Joint friction"): each friction joint's motor at rest, its
  // largest force the friction's limit, bounded per step by FrictionBounds. The Mechanism joints
  // with friction, in the order limit_friction and friction_step take them.
  std::vector<int> friction_joints() const {
    std::vector<int> out;
    for (const Rough& r : rough_) out.push_back(g_.joints[r.joint].source);
    return out;
  }
  // Friction joint i's limit for the next step [N m or N].
  void limit_friction(size_t i, double limit) {
    const Rough& r = rough_[i];
    if (r.kind == Rough::Kind::angular)
      dJointSetAMotorParam(r.motor, dParamFMax, limit);
    else if (r.kind == Rough::Kind::own)
      dJointSetSliderParam(r.motor, dParamFMax, limit);
    else
      dJointSetLMotorParam(r.motor, dParamFMax, limit);
  }
  // After a step of h: friction joint i's friction on its joint's second link, also into `out`
  // when given (per Mechanism joint; a driven slide's linear motor's also into its joint's
  // force), and the second link's displacement relative to the first.
  FrictionBounds::Step friction_step(size_t i, double h, ForceReading* out) const {
    const Rough& r = rough_[i];
    const SceneJoint& j = g_.joints[r.joint];
    // The friction on body1 of its motor (the joint's own body1 for a slider), and its rate.
    double on_first = 0.0, rate = 0.0;
    if (r.kind == Rough::Kind::angular) {
      on_first = friction_feedback_[r.joint].t1[2];
      rate = dJointGetHingeAngleRate(joints_[r.joint]);  // body1's about z less body2's
    } else {
      const dJointFeedback& f =
          r.kind == Rough::Kind::own ? feedback_[r.joint] : friction_feedback_[r.joint];
      const Eigen::Vector2d u = axis(r.joint);
      on_first = Eigen::Vector2d(f.f1[0], f.f1[1]).dot(u);
      rate = dJointGetSliderPositionRate(joints_[r.joint]);  // body1's along u less body2's
    }
    // On the joint's second link b, b's rate relative to a.
    const double sign = body1_[r.joint] == j.b ? 1.0 : -1.0;
    const double friction = sign * on_first;
    if (out) {
      const size_t source = static_cast<size_t>(j.source);
      out->friction[source] = friction;
      if (r.kind == Rough::Kind::linear) out->joint_force[source] += friction * axis(r.joint);
    }
    return {friction, sign * rate * h};
  }

 private:
  // A friction joint `ji`'s motor at rest (dParamVel 0): a hinge's an angular motor about z
  // between its bodies, whose feedback is the friction alone; an undriven slide's its own motor,
  // whose feedback along the line is the friction (the slider's other rows are normal to it); a
  // driven slide's (its own motor drives it) a linear motor along the line, fixed in the world:
  // its guide is the ground (OdeEngine::supports).
  void add_friction(size_t ji, bool driven, const Eigen::VectorXd& q) {
    const SceneJoint& j = g_.joints[ji];
    if (j.source < 0 || !joints_[ji] || j.kind == SceneJoint::Kind::planar) return;
    const Joint& mj = m_.joints[static_cast<size_t>(j.source)];
    if (!mj.friction) return;
    Rough r;
    r.joint = ji;
    dBodyID first = bodies_[static_cast<size_t>(body1_[ji])];
    dBodyID second = bodies_[static_cast<size_t>(body1_[ji] == j.a ? j.b : j.a)];
    if (j.kind == SceneJoint::Kind::hinge) {
      r.kind = Rough::Kind::angular;
      r.motor = dJointCreateAMotor(world_, nullptr);
      dJointAttach(r.motor, first, second);
      dJointSetAMotorMode(r.motor, dAMotorUser);
      dJointSetAMotorNumAxes(r.motor, 1);
      dJointSetAMotorAxis(r.motor, 0, 0, 0.0, 0.0, 1.0);
      dJointSetAMotorParam(r.motor, dParamVel, 0.0);
      dJointSetAMotorParam(r.motor, dParamCFM, friction_cfm_);
      dJointSetFeedback(r.motor, &friction_feedback_[ji]);
    } else if (!driven ||
               std::none_of(g_.driven.begin(), g_.driven.end(), [&](const DrivenCoordinate& d) {
                 return d.joint == static_cast<int>(ji);
               })) {
      r.kind = Rough::Kind::own;
      r.motor = joints_[ji];
      dJointSetSliderParam(r.motor, dParamVel, 0.0);
      dJointSetSliderParam(r.motor, dParamCFM, friction_cfm_);
    } else {
      r.kind = Rough::Kind::linear;
      r.motor = dJointCreateLMotor(world_, nullptr);
      dJointAttach(r.motor, first, second);
      dJointSetLMotorNumAxes(r.motor, 1);
      const BodyMotion a = frame_of(m_, g_.bodies[static_cast<size_t>(j.a)], q);
      const Eigen::Vector2d u = turn(a.theta, j.direction);
      dJointSetLMotorAxis(r.motor, 0, 0, u.x(), u.y(), 0.0);
      dJointSetLMotorParam(r.motor, dParamVel, 0.0);
      dJointSetLMotorParam(r.motor, dParamCFM, friction_cfm_);
      dJointSetFeedback(r.motor, &friction_feedback_[ji]);
    }
    rough_.push_back(r);
  }

  // Slide `joint`'s line in the world, as its slider holds it.
  Eigen::Vector2d axis(size_t joint) const {
    dVector3 u;
    dJointGetSliderAxis(joints_[joint], u);
    return {u[0], u[1]};
  }

  // A gear pair as ODE's transmission joint between its two gears (body1 the first): the contact
  // point on the line of centres at ratio r_a / r_b, both wheels about z, no backlash; it holds
  // the pitch point's tangential velocity equal on both gears and its phase (each wheel's turn
  // against the line of centres, from the start) with the world's ERP and CFM.
  void add_transmission(int joint, const Eigen::VectorXd& q) {
    const Joint& j = m_.joints[static_cast<size_t>(joint)];
    // The scene's bodies: the ground, then the moving links in Mechanism order (as apply()).
    const auto body = [&](int link) {
      return bodies_[static_cast<size_t>(m_.moving_index(link) + 1)];
    };
    const Link& carrier = m_.links[static_cast<size_t>(j.carrier)];
    const BodyMotion c = BodyMotion::of(m_.moving_index(j.carrier), q, nullptr, nullptr);
    const Eigen::Vector2d centre_a =
        c.position(carrier.points[static_cast<size_t>(j.centre_a)].local);
    const Eigen::Vector2d centre_b =
        c.position(carrier.points[static_cast<size_t>(j.centre_b)].local);
    dJointID t = dJointCreateTransmission(world_, nullptr);
    dJointAttach(t, body(j.link_a), body(j.link_b));
    dJointSetTransmissionMode(t, dTransmissionParallelAxes);
    dJointSetTransmissionRatio(t, j.radius_a / j.radius_b);
    dJointSetTransmissionAnchor1(t, centre_a.x(), centre_a.y(), 0.0);
    dJointSetTransmissionAnchor2(t, centre_b.x(), centre_b.y(), 0.0);
    dJointSetTransmissionAxis(t, 0.0, 0.0, 1.0);
    dJointSetTransmissionBacklash(t, 0.0);
    dJointSetFeedback(t, &transmission_feedback_[transmissions_.size()]);
    transmissions_.push_back({joint, t});
  }

  // Curved slot k: ODE's double ball (dJointCreateDBall), which holds the distance between its
  // anchors, the arc's centre and the pin, at the radius: one row, and no body between.
  void add_arc(size_t k, const Eigen::VectorXd& q) {
    const SceneArc& a = g_.arcs[k];
    const auto at = [&](int body, const Eigen::Vector2d& local) {
      return frame_of(m_, g_.bodies[static_cast<size_t>(body)], q).position(local);
    };
    const bool pin_moves = bodies_[static_cast<size_t>(a.pin)] != nullptr;
    const Eigen::Vector2d first = pin_moves ? at(a.pin, a.point) : at(a.guide, a.centre);
    const Eigen::Vector2d second = pin_moves ? at(a.guide, a.centre) : at(a.pin, a.point);
    dJointID joint = dJointCreateDBall(world_, nullptr);
    dJointAttach(joint, bodies_[static_cast<size_t>(pin_moves ? a.pin : a.guide)],
                 bodies_[static_cast<size_t>(pin_moves ? a.guide : a.pin)]);
    dJointSetDBallAnchor1(joint, first.x(), first.y(), 0.0);
    dJointSetDBallAnchor2(joint, second.x(), second.y(), 0.0);
    dJointSetDBallDistance(joint, a.radius);
    dJointSetFeedback(joint, &arc_feedback_[k]);
  }

  // Cam contact c's shapes (SceneContact), each placed from its body's centre of mass; the disc
  // collided larger by the contact's margin (touch()).
  void add_contact(size_t c) {
    const SceneContact& sc = g_.contacts[c];
    if (!contact_group_) contact_group_ = dJointGroupCreate(0);
    const auto place = [&](dGeomID geom, int body, const Eigen::Vector2d& at, double angle) {
      dGeomSetBody(geom, bodies_[static_cast<size_t>(body)]);
      const Eigen::Vector2d offset = at - g_.bodies[static_cast<size_t>(body)].centre;
      dGeomSetOffsetPosition(geom, offset.x(), offset.y(), 0.0);
      dMatrix3 r;
      dRFromAxisAndAngle(r, 0.0, 0.0, 1.0, angle);
      dGeomSetOffsetRotation(geom, r);
    };
    Contact& contact = contacts_[c];
    contact.margin = sc.margin;
    contact.cam = dCreateSphere(nullptr, sc.cam_radius + contact.margin);
    place(contact.cam, sc.cam, sc.cam_centre, 0.0);
    contact.follower = sc.face ? dCreateBox(nullptr, 2.0 * sc.box_half.x(), 2.0 * sc.box_half.y(),
                                            2.0 * sc.box_half.z())
                               : dCreateSphere(nullptr, sc.follower_radius);
    place(contact.follower, sc.follower, sc.follower_centre, sc.face ? sc.box_angle : 0.0);
  }

  // Before a step of h: each cam's contact joint where its shapes come within the margin,
  // frictionless (mu 0), its softness the contact's own ERP and CFM. The disc is collided enlarged
  // by the margin and the depth taken back; shapes still apart get a joint that lets them close
  // that gap in the step and no more (a speculative contact: ODE clamps a negative depth to 0, so
  // the gap is its normal velocity, dContactMotionN, gap / h), and the contact holds from step to
  // step instead of flickering at zero depth.
  void touch(double h) {
    if (!contact_group_) return;
    dJointGroupEmpty(contact_group_);
    for (size_t c = 0; c < contacts_.size(); ++c) {
      Contact& contact = contacts_[c];
      dContact touching{};
      contact.touching =
          dCollide(contact.cam, contact.follower, 1, &touching.geom, sizeof(dContact)) > 0;
      if (!contact.touching) continue;
      touching.geom.depth -= contact.margin;
      touching.surface.mode = dContactSoftERP | dContactSoftCFM;
      if (touching.geom.depth < 0.0) {
        touching.surface.mode |= dContactMotionN;
        touching.surface.motionN = touching.geom.depth / h;
        touching.geom.depth = 0.0;
      }
      touching.surface.mu = 0.0;
      touching.surface.soft_erp = contact_erp_;
      touching.surface.soft_cfm = contact_cfm_;
      dJointID joint = dJointCreateContact(world_, contact_group_, &touching);
      dBodyID first = dGeomGetBody(touching.geom.g1), second = dGeomGetBody(touching.geom.g2);
      dJointAttach(joint, first, second);
      dJointSetFeedback(joint, &contact.feedback);
      contact.follower_first = first == bodies_[static_cast<size_t>(g_.contacts[c].follower)];
    }
  }

  const Mechanism& m_;
  const SceneGraph& g_;
  bool quick_;
  double cfm_, friction_cfm_;
  dWorldID world_ = nullptr;
  dThreadingImplementationID threading_ = nullptr;
  std::vector<dBodyID> bodies_;  // per scene body; null for the ground
  std::vector<dJointID> joints_;
  std::vector<int> body1_;  // per joint: the scene body that is ODE's body1
  std::vector<dJointFeedback> feedback_;
  std::vector<dJointFeedback> arc_feedback_;  // per SceneArc: its body1 is the pin's, if moving
  // A driver's motor: its driven joint (or a floating link's angular motor), and how its rate
  // runs against the driven coordinate.
  struct Motor {
    dJointID joint = nullptr;
    double sign = 1.0;
    SceneJoint::Kind kind = SceneJoint::Kind::hinge;
  };
  std::vector<Motor> motors_;  // per driver; none in forward dynamics
  // Per gear pair: its Mechanism joint and transmission, and its feedback (sized before any
  // joint points into it).
  std::vector<std::pair<int, dJointID>> transmissions_;
  std::vector<dJointFeedback> transmission_feedback_;
  // Per friction joint: its scene joint and its motor.
  struct Rough {
    enum class Kind { angular, own, linear };
    size_t joint = 0;
    Kind kind = Kind::angular;
    dJointID motor = nullptr;
  };
  std::vector<Rough> rough_;
  std::vector<dJointFeedback> friction_feedback_;  // per scene joint (sized before any points in)
  // Per cam contact (SceneGraph::contacts): its two geoms, on no space, collided by dCollide
  // before each step; while they touch, a frictionless contact joint in contact_group_, emptied
  // at the next step.
  struct Contact {
    dGeomID cam = nullptr, follower = nullptr;
    double margin = 0.0;  // the disc collided larger by it [m]
    dJointFeedback feedback{};
    bool touching = false, follower_first = false;  // whether the follower is the joint's body1
  };
  std::vector<Contact> contacts_;
  dJointGroupID contact_group_ = nullptr;
  double contact_erp_ = 1.0, contact_cfm_ = 1e-10;
  bool interrupted_ = false;                   // a step threw (an ODE error inside it)
  std::unique_lock<std::mutex> random_order_;  // a quick-step run's hold on dRandInt's seed
};

// A gear pair's reading in the terms every engine's takes (ForceReading::gear_couple): ODE's
// transmission pushes at the pitch point along the tangent, so its couple about the first gear's
// centre is the gear couple, and the bearings from each gear to the carrier read that push
// beside their own reactions; it is taken out of them, as write_forces passes the whole tooth
// force (its pressure-angle part too) through them.
void read_tooth_force(const Mechanism& m, const OdeScene& scene, int joint,
                      const Eigen::VectorXd& q, ForceReading& out) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  const Eigen::Vector2d on_a = scene.tooth_force(joint);
  const BodyMotion carrier = BodyMotion::of(m.moving_index(j.carrier), q, nullptr, nullptr);
  const Link& c = m.links[static_cast<size_t>(j.carrier)];
  const Eigen::Vector2d centre = c.points[static_cast<size_t>(j.centre_a)].local;
  const Eigen::Vector2d toward_b = c.points[static_cast<size_t>(j.centre_b)].local - centre;
  const Eigen::Vector2d arm = carrier.turn(toward_b * (j.radius_a / toward_b.norm()));
  out.gear_couple[static_cast<size_t>(joint)] = cross(arm, on_a);
  const GearPaths paths = gear_paths(m, joint);
  for (const auto& [k, sign] : paths.path_a) out.joint_force[static_cast<size_t>(k)] -= sign * on_a;
  for (const auto& [k, sign] : paths.path_b) out.joint_force[static_cast<size_t>(k)] += sign * on_a;
}

// Forces of the last step at pose q (the pose it left), in the mechanism's terms, converted as
// Bullet's (read_rigid_forces): each joint's force on its second link (through the first when the
// second is the ground; a pin-in-slot's through its pin), a prismatic couple about its point, and
// the driver's effort: the driven joint's couple about its point (its force along the line for a
// slider), or a floating link's angular motor torque.
void read_forces(const Mechanism& m, const SceneGraph& g, const OdeScene& scene,
                 const Eigen::VectorXd& q, ForceReading& out) {
  out.set_zero();
  // Per driver: the Mechanism joint its scene joint realises (-1: a floating link's angle).
  const auto driven_joint = [&](size_t di) {
    const DrivenCoordinate& dc = g.driven[di];
    return dc.floating ? -1 : g.joints[static_cast<size_t>(dc.joint)].source;
  };
  // The couple scene joint `sj` exerts on `body` about the world point `point`, and its force.
  const auto couple = [&](size_t sj, int body, const Eigen::Vector2d& point, Eigen::Vector2d& f) {
    const JointSide s = scene.on(sj, body);
    const SceneBody& sb = g.bodies[static_cast<size_t>(body)];
    const BodyMotion frame = frame_of(m, sb, q);
    f = s.force;
    return s.torque - cross(point - frame.position(sb.centre), s.force);
  };
  for (size_t sj = 0; sj < g.joints.size(); ++sj) {
    const SceneJoint& j = g.joints[sj];
    if (j.kind == SceneJoint::Kind::planar || j.block_guide) continue;  // a slot's: its pin's
    const size_t ji = static_cast<size_t>(j.source);
    const Joint& mj = m.joints[ji];
    const BodyMotion b = frame_of(m, g.bodies[static_cast<size_t>(j.b)], q);
    const Eigen::Vector2d point = b.position(j.ub);
    Eigen::Vector2d on_b;
    double couple_b = 0.0;
    if (!g.bodies[static_cast<size_t>(j.b)].ground) {
      couple_b = couple(sj, j.b, point, on_b);
    } else {
      Eigen::Vector2d on_a;
      couple_b = -couple(sj, j.a, point, on_a);
      on_b = -on_a;
    }
    if (mj.type == JointType::prismatic) out.couple[ji] = couple_b;
    for (size_t di = 0; di < m.drivers.size(); ++di) {
      const Driver& d = m.drivers[di];
      if (static_cast<int>(ji) != driven_joint(di) || d.type == DriverType::link_angle) continue;
      double& effort = out.effort_of(static_cast<int>(di));
      if (d.type != DriverType::slider) {
        effort = couple_b;  // on the second link, the driven one
        continue;
      }
      // Undriven (forward dynamics, whose sampler writes the applied effort), a slide's force
      // along its line is its own (its friction).
      if (!scene.driving()) continue;
      const BodyMotion a = frame_of(m, g.bodies[static_cast<size_t>(j.a)], q);
      const Eigen::Vector2d u = a.turn(m.links[mj.link_a].lines[mj.line].direction);
      effort = on_b.dot(u);
      on_b -= effort * u;
    }
    out.joint_force[ji] = on_b;
  }
  for (const SceneCoupling& c : g.couplings) read_tooth_force(m, scene, c.source, q, out);
  for (size_t c = 0; c < g.contacts.size(); ++c)  // a yoke's two faces are one joint's
    out.joint_force[static_cast<size_t>(g.contacts[c].source)] += scene.contact_force(c);
  for (size_t k = 0; k < g.arcs.size(); ++k)
    out.joint_force[static_cast<size_t>(g.arcs[k].source)] = scene.arc_force(k);
  for (size_t di = 0; di < m.drivers.size(); ++di) {
    if (m.drivers[di].type != DriverType::link_angle) continue;
    const DrivenCoordinate& dc = g.driven[di];
    double& effort = out.effort_of(static_cast<int>(di));
    if (dc.floating) {
      effort = scene.on(static_cast<size_t>(dc.joint), dc.body).torque;
      continue;
    }
    // Realised at the link's ground pivot: its couple on the link about the pivot.
    const SceneJoint& j = g.joints[static_cast<size_t>(dc.joint)];
    const int link = g.bodies[static_cast<size_t>(j.b)].ground ? j.a : j.b;
    const BodyMotion b = frame_of(m, g.bodies[static_cast<size_t>(j.b)], q);
    Eigen::Vector2d f;
    effort = couple(static_cast<size_t>(dc.joint), link, b.position(j.ub), f);
  }
}

// ---------------------------------------------------------------------------------------------
// Runs

// What a run needs before its time grid: the settings with their auto thresholds, the mechanism
// the scene is built from (perturb_link), its scene graph and the usable span.
struct Prepared {
  Config config;
  Mechanism m;
  SceneGraph graph;
  Span span;
};

// The scene graph's policy: a floating link's driven angle is a planar ground joint's (an angular
// motor realises it directly); ODE needs no tree, so nothing else is chosen.
TreePolicy ode_policy() {
  TreePolicy policy;
  policy.planar_joints = true;
  policy.contacts = true;
  // An arm of auxiliary_mass() between two hinges stopped forward dynamics in ODE's
  // "!bSafeNormalize4Fault" (curved_slot_rocker.toml falling from rest): the double ball instead.
  policy.arc_rows = true;
  policy.no_mesh =
      "which ODE's convex collider does not hold: its sphere-convex test takes the first face the "
      "sphere crosses, not the nearest (measured: a face's depth 5 to 14 % short; docs/cams.md)";
  return policy;
}

// ODE's graph. Its one meshing joint, the transmission (dJointCreateTransmission, parallel axes),
// joins two moving wheels at a contact point between their centres: an external gear pair whose
// gears both move; an internal pair, a gear fixed to the ground or a rack is refused
// (docs/engines.md, "Gear couplings").
SceneGraph ode_graph(const Mechanism& m) {
  SceneGraph g = scene_graph(m, ode_policy());
  for (const SceneCoupling& c : g.couplings) {
    const Joint& j = m.joints[static_cast<size_t>(c.source)];
    std::string why;
    if (j.type == JointType::rack_pinion)
      why = "rack and pinion: ODE 0.16's transmission joint joins two wheels, no rack";
    else if (j.ratio < 0.0)
      why =
          "gear pair meshing internally: ODE 0.16's transmission joint puts the contact point "
          "between the two centres (external mesh only)";
    else if (j.link_a == m.ground() || j.link_b == m.ground())
      why =
          "gear pair with a gear fixed to the ground: ODE 0.16's transmission joint joins two "
          "moving bodies";
    if (!why.empty()) throw std::runtime_error(fmt::format("joint '{}' is a {}", j.name, why));
  }
  return g;
}

Prepared prepare(const Mechanism& original, const Trajectory& reference,
                 const Settings& overrides) {
  ode_start();
  Prepared p;
  p.config = parse_settings(overrides);
  p.m = perturbed(original, p.config.shared.perturb_link);
  p.config.shared.resolve(p.m);
  p.graph = ode_graph(p.m);
  p.span = usable_span(reference);
  return p;
}

Settings common_settings(const Config& config, const TimeGrid& grid, double step_angle,
                         bool friction, bool contact) {
  Settings values = {
      {"stepper", config.stepper},
      {"iterations",
       config.stepper == "quick" ? std::to_string(config.iterations) : "unused (dWorldStep)"},
      {"dt", format_number(grid.dt)},
      {"steps_per_sample",
       config.dt == 0.0 ? std::to_string(grid.steps_per_sample) : "unused (dt given)"},
      {"max_step_angle", config.dt == 0.0 ? format_number(step_angle) : "unused (dt given)"},
      {"erp", format_number(config.erp)},
      {"cfm", format_number(config.cfm)},
      {"finite_rotation", config.finite_rotation ? "1" : "0"},
      {"precision", "float64 (ODE_double_precision)"},
  };
  if (friction) values.emplace_back("friction_cfm", format_number(config.friction_cfm));
  if (contact) {
    values.emplace_back("contact_erp", format_number(config.contact_erp));
    values.emplace_back("contact_cfm", format_number(config.contact_cfm));
  }
  return values;
}

// The scene stepped and read back as the mechanism's coordinates after each step, with the
// forces of the pose a step leaves: what both runs' scenes share.
// Joint friction's limits follow the reactions of the steps before (FrictionLoads): ODE's first
// two readings are transients of its velocity-level start (the first lacks the centripetal part
// of the constraint forces, the second makes it up; 55 % off on the friction four-bar's pins),
// so the start's trend stands for them.
class OdeSteps {
 public:
  static constexpr int kTransients = 2;
  OdeSteps(const Mechanism& m, const SceneGraph& g, OdeScene& scene, const Eigen::VectorXd& q,
           ReadingTrend start, bool extrapolated)
      : m_(m),
        g_(g),
        scene_(scene),
        q_(q),
        friction_(m, scene.friction_joints(), std::move(start), extrapolated, kTransients),
        reading_(m.joints.size(), m.drivers.size()) {
    scene_.read(q_);
  }
  std::string step(double h, ForceReading* forces) {
    if (friction_.any())
      friction_.bound(h, q_, [&](size_t i, double limit) { scene_.limit_friction(i, limit); });
    const std::string why = scene_.step(h);
    ++evaluations_;  // one LCP solve of the model a step
    const bool keep = friction_.reads();
    ForceReading* into = forces ? forces : keep ? &reading_ : nullptr;
    if (into) read_forces(m_, g_, scene_, q_, *into);
    if (friction_.any())
      friction_work_ = friction_.settle(h, keep ? into : nullptr,
                                        [&](size_t i) { return scene_.friction_step(i, h, into); });
    scene_.read(q_);
    return why;
  }
  OdeScene& scene() { return scene_; }
  const Eigen::VectorXd& pose() const { return q_; }
  long evaluations() const { return evaluations_; }
  double friction_work() const { return friction_work_; }

 private:
  const Mechanism& m_;
  const SceneGraph& g_;
  OdeScene& scene_;
  Eigen::VectorXd q_;
  FrictionBounds friction_;
  ForceReading reading_;  // scratch: a step's reading
  double friction_work_ = 0.0;
  long evaluations_ = 0;
};

template <class Loop>
class OdeLoopScene : public Loop {
 public:
  explicit OdeLoopScene(OdeSteps& steps) : steps_(steps) {}
  void apply(const std::vector<BodyLoad>& loads) override { steps_.scene().apply(loads); }
  void read_pose(Eigen::VectorXd& q) override { q = steps_.pose(); }
  long evaluations() const override { return steps_.evaluations(); }

 protected:
  OdeSteps& steps_;
};

// A kinematic run's scene: each motor lands its driven joint on its driver's law at the step's
// end.
class OdeKinematicScene final : public OdeLoopScene<KinematicScene> {
 public:
  OdeKinematicScene(OdeSteps& steps, const Mechanism& m, const SceneGraph& g,
                    const KinematicPlan& plan)
      : OdeLoopScene(steps), m_(m), g_(g) {
    for (size_t di = 0; di < m.drivers.size(); ++di) {
      const SceneJoint* joint = &g.joints[static_cast<size_t>(g.driven[di].joint)];
      driven_.push_back({joint, DriveTarget::of(m, plan, di, joint_value(m, g, *joint, plan.q),
                                                g.driven[di].sign)});
    }
  }
  void drive(const std::vector<double>& driver_values) override {
    for (size_t di = 0; di < driven_.size(); ++di)
      driven_[di].target = driven_[di].map.target(driver_values[di]);
  }
  std::string step(double h, ForceReading* forces) override {
    for (size_t di = 0; di < driven_.size(); ++di)
      steps_.scene().drive(di, joint_value(m_, g_, *driven_[di].joint, steps_.pose()),
                           driven_[di].target, h);
    return steps_.step(h, forces);
  }

 private:
  // A driver's joint and how its value maps to the joint's coordinate.
  struct Driven {
    const SceneJoint* joint;
    DriveTarget map;
    double target = 0.0;
  };
  const Mechanism& m_;
  const SceneGraph& g_;
  std::vector<Driven> driven_;  // per driver
};

// A dynamics run's scene: no driver. dWorldStep is semi-implicit Euler (x_k+1 = x_k + h v_k+1), so
// a staggered start is v0 - h/2 a0, as Bullet's. Its first step is a transient as Bullet's (a
// velocity-level step: the centripetal part of the constraint force comes one step late, the
// driver torque of the first step 104 % off; engine notes), and there is no pose before the
// start: the loop reads the first sample one-sided and its forces from pose 2 on.
class OdeDynamicsScene final : public OdeLoopScene<DynamicsScene> {
 public:
  OdeDynamicsScene(OdeSteps& steps, Eigen::VectorXd start_velocity)
      : OdeLoopScene(steps), start_velocity_(std::move(start_velocity)) {}
  Eigen::VectorXd start_velocity() const override { return start_velocity_; }
  std::string step(double /*t0*/, double h, ForceReading* forces) override {
    return steps_.step(h, forces);
  }
  double friction_work() const override { return steps_.friction_work(); }

 private:
  Eigen::VectorXd start_velocity_;
};

EngineRun run_ode_dynamics(const Mechanism& original, const Trajectory& reference,
                           const Settings& overrides) {
  const auto begin = Clock::now();
  EngineRun out;
  out.trajectory.method = "ode";
  out.trajectory.resize_as(original, reference, true, true);
  try {
    Prepared p = prepare(original, reference, overrides);
    const Config& config = p.config;
    const double step_angle = config.max_step_angle.of(true);
    const DynamicsPlan start = plan_dynamics(
        original, p.m, reference,
        step_length(reference, p.span, config.dt, step_angle, config.steps_per_sample),
        InnerTimes::interval_fractions, config.shared.max_steps,
        !config.shared.perturb_link.empty());
    const std::vector<double>& time = start.grid.time;
    const Eigen::VectorXd velocity =
        config.staggered_start
            ? Eigen::VectorXd(start.start.qdot - 0.5 * (time[1] - time[0]) * start.start.qddot)
            : start.start.qdot;
    const double energy_scale = std::max(reference_energy_scale(original, reference), 1e-12);
    Settings values = common_settings(config, start.grid, step_angle, p.m.has_friction(),
                                      !p.graph.contacts.empty());
    const Settings more = {
        {"start", config.staggered_start ? "staggered (v0 - h/2 a0)" : "exact (v0)"},
        {"forces", "dJointFeedback of the step leaving each sample"}};
    const Settings shared = config.shared.dynamics_printed(energy_scale, p.m.has_friction());
    values.insert(values.end(), shared.begin(), shared.end());
    values.insert(values.end(), more.begin(), more.end());
    out.settings = printed_settings(ode_settings(), RunKind::dynamics, values, p.m.has_friction(),
                                    !p.graph.contacts.empty());
    OdeScene scene(p.m, p.graph, config, start.start.q, &velocity, false);
    OdeSteps steps(p.m, p.graph, scene, start.start.q,
                   reference_trend(p.m, reference, start.span.first, time.front()),
                   config.shared.extrapolated_load);
    if (const std::string why = start_mismatch(p.m, steps.pose(), start.start.q); !why.empty())
      return failed_run(std::move(out), why);
    OdeDynamicsScene stepped(steps, velocity);
    const DynamicsWatch watch = config.shared.dynamics_watch(p.m, energy_scale);
    run_dynamics(original, p.m, reference, start, watch, true, stepped, begin, out);
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  return out;
}

EngineRun run_ode_kinematic(const Mechanism& original, const Trajectory& reference,
                            const Settings& overrides) {
  const auto begin = Clock::now();
  EngineRun out;
  out.trajectory.method = "ode";
  out.trajectory.resize_as(original, reference, false);
  try {
    Prepared p = prepare(original, reference, overrides);
    const Config& config = p.config;
    const double step_angle = config.max_step_angle.of(false);
    KinematicPlan start = plan_kinematic(
        p.m, reference,
        step_length(reference, p.span, config.dt, step_angle, config.steps_per_sample),
        InnerTimes::interval_fractions, p.graph.contacts.empty() ? kPreroll : kContactPreroll,
        config.shared.max_steps, config.shared.singular_rcond, !config.shared.perturb_link.empty());
    Settings values = common_settings(config, start.grid, step_angle, p.m.has_friction(),
                                      !p.graph.contacts.empty());
    const Settings shared = config.shared.kinematic_printed(p.m.has_friction());
    values.insert(values.end(), shared.begin(), shared.end());
    values.emplace_back("forces", "dJointFeedback of the step leaving each sampled pose");
    out.settings = printed_settings(ode_settings(), RunKind::kinematic, values, p.m.has_friction(),
                                    !p.graph.contacts.empty());
    const KinematicWatch watch = config.shared.kinematic_watch(p.m);
    OdeScene scene(p.m, p.graph, config, start.q, &start.qdot, true);
    OdeSteps steps(p.m, p.graph, scene, start.q,
                   reference_trend(p.m, reference, start.span.first, start.grid.time.front()),
                   config.shared.extrapolated_load);
    if (const std::string why = start_mismatch(p.m, steps.pose(), start.q); !why.empty())
      return failed_run(std::move(out), why);
    for (size_t d = 0; d < p.graph.driven.size(); ++d)
      if (p.graph.driven[d].floating)
        add_note(start.note,
                 fmt::format("link-angle driver{} realised directly: an angular motor "
                             "between the ground and the link",
                             p.m.axis().timed() ? fmt::format(" ('{}')", p.m.drivers[d].name)
                                                : std::string()));
    OdeKinematicScene stepped(steps, p.m, p.graph, start);
    run_kinematic(original, p.m, reference, start, watch, true, stepped, begin, out);
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  return out;
}

class OdeEngine final : public Engine {
 public:
  std::string name() const override { return "ode"; }
  const SettingSchema& settings_schema() const override { return ode_settings(); }

  bool supports(const Mechanism& mechanism, std::string* why) const override {
    try {
      const SceneGraph g = ode_graph(mechanism);
      // A driven slide's friction is a linear motor beside its driving one, whose axis ODE fixes
      // in the world (dJointCreateLMotor).
      for (const DrivenCoordinate& d : g.driven) {
        const SceneJoint& j = g.joints[static_cast<size_t>(d.joint)];
        if (j.kind == SceneJoint::Kind::slide && j.source >= 0 &&
            mechanism.joints[static_cast<size_t>(j.source)].friction &&
            !g.bodies[static_cast<size_t>(j.a)].ground)
          throw std::runtime_error(fmt::format(
              "joint '{}' is driven and has friction on a moving guide: ODE's linear motor, "
              "which would carry its friction beside the driving motor, holds an axis fixed in "
              "the world",
              mechanism.joints[static_cast<size_t>(j.source)].name));
      }
    } catch (const std::exception& e) {
      if (why) *why = e.what();
      return false;
    }
    return true;
  }

  void check_settings(const Mechanism& m, const Settings& overrides) const override {
    (void)perturbed(m, parse_settings(overrides).shared.perturb_link);
  }

  EngineRun run(const Mechanism& original, const Trajectory& reference,
                const Settings& overrides) const override {
    if (original.dynamics) return run_ode_dynamics(original, reference, overrides);
    return run_ode_kinematic(original, reference, overrides);
  }
};

}  // namespace

std::unique_ptr<Engine> make_ode_engine() {
  return std::make_unique<OdeEngine>();
}

}  // namespace crosslink::sim
