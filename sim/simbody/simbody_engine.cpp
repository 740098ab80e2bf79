// Simbody 3.7 scene of a Mechanism: build, step, sample. See docs/engines.md, "Simbody".
//
// Reduced coordinates: one mobilizer per joint of the scene graph's spanning tree (a pin about z
// for a hinge, a slider for a slide), each cut hinge closed by a ball constraint (its z row is
// redundant; Simbody accepts it), the driven mobilizer's coordinate prescribed by the driver's
// law at position, velocity and acceleration level (Motion::Custom). Simbody integrates with
// error control and projects onto the constraints after every step, so the motion is accurate
// to its accuracy setting rather than to a power of the step; the forces are read at each
// state from the constraint multipliers and the mobilizers' reactions.
#include "sim/simbody/simbody_engine.h"

#include <fmt/format.h>
#include "sim/simbody/simbody_cxx20.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <vector>

#include <Eigen/SVD>

#include "analytic/model/planar.h"
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

constexpr long kPreroll = 4;  // periodic sweeps: steps before the first sample (and after the
                              // last); the start is exact, so this only centres the stencils
// A cam's compliant contact starts at the exact start's zero penetration and settles into the
// one its load holds over some tens of the reported poses' spacing.
constexpr long kContactPreroll = 64;
constexpr long kRing = 16;  // states kept for the dynamics run's state readout
// Forward dynamics reads rates and forces from Simbody's state, so the reported poses' spacing
// only sets the trapezoid rule of the loads' work: at 0.02 rad the Andrews squeezer's work is
// within 5e-5 % of the exact one (0.0025: 8e-7 %) at a third of the cost.
constexpr double kDynamicsMaxStepAngle = 0.02;
// A kinematic run's: its rates and accelerations are central differences of the reported poses.
constexpr double kKinematicMaxStepAngle = 0.0025;

// ---------------------------------------------------------------------------------------------
// Settings

struct Config {
  std::string integrator = "merson";
  double accuracy = 1e-8;
  double constraint_tolerance = 1e-10;
  double max_step = 0.0;    // 0: Simbody chooses (auto)
  double fixed_step = 0.0;  // 0: error-controlled
  bool interpolate = false;
  double dt = 0.0;  // the reported poses' spacing; 0: auto (max_step_angle)
  StepAngle max_step_angle;
  // Joint friction (docs/engines.md, "Joint friction").
  double friction_speed = 1e-4;  // v_s: of each friction joint's fastest rate in the reference
  // A cam's compliant contact (docs/cams.md, "The engines' contact"): each surface's material.
  double contact_stiffness = 2e11;      // [Pa]: steel's Young's modulus
  double contact_dissipation = 1000.0;  // Hunt and Crossley's c [s/m]
  SharedSettings shared;                // the watch's thresholds, the test hook, the step budget
};

const SettingSchema& simbody_settings() {
  using enum SettingKind;
  using enum AppliesTo;
  static const SettingSchema schema = {
      {.name = "integrator",
       .kind = choice,
       .default_value = "merson",
       .doc = "Simbody's integrator: Runge-Kutta-Merson, -Feldberg, RK3, RK2 (error-controlled), "
              "semi-explicit Euler 2, Verlet, explicit Euler, CPodes (BDF)",
       .words = {"merson", "feldberg", "rk3", "rk2", "semi_explicit_euler2", "verlet",
                 "explicit_euler", "cpodes"}},
      {.name = "accuracy",
       .kind = number,
       .default_value = "1e-08",
       .doc = "the integrator's relative accuracy per step (error control)",
       // Open at 1 too: Simbody asserts 0 < accuracy < 1 (Integrator::setAccuracy) and aborts.
       .range = {0.0, 1.0, true, true}},
      {.name = "constraint_tolerance",
       .kind = number,
       .default_value = "1e-10",
       .doc = "the constraints' tolerance Simbody projects to after each step",
       .range = {0.0, 1.0, true}},
      {.name = "max_step",
       .kind = number,
       .default_value = "auto",
       .doc =
           "the longest internal step [s]; auto: Simbody's choice (at most dt unless interpolate)",
       .range = kPositive,
       .words = {"auto"}},
      {.name = "fixed_step",
       .kind = number,
       .default_value = "off",
       .doc = "internal steps of this length [s] without error control; off: error-controlled",
       .range = kPositive,
       .words = {"off"}},
      {.name = "interpolate",
       .kind = choice,
       .default_value = "0",
       .doc = "1: reported poses interpolated between Simbody's own steps (and projected); 0: "
              "Simbody steps to each",
       .words = {"0", "1"}},
      {.name = "dt",
       .kind = number,
       .default_value = "auto",
       .doc = "the spacing of the poses the run reports [s] (Simbody steps to each); auto: "
              "max_step_angle",
       .range = kPositive,
       .words = {"auto"}},
      {.name = "max_step_angle",
       .kind = number,
       .default_value = "auto",
       .doc = "auto dt: the most the fastest link turns between two reported poses [rad]; auto: "
              "0.0025, forward dynamics 0.02",
       .range = kPositive,
       .words = {"auto"}},
      shared_setting("gap_threshold"),
      shared_setting("divergence_gap"),
      shared_setting("driver_threshold"),
      shared_setting("mass_model"),
      shared_setting("driver"),
      {.name = "forces", .doc = "how the joint forces are read", .reported = true},
      shared_setting("singular_rcond"),
      shared_setting("branch_distance"),
      shared_setting("energy_threshold"),
      shared_setting("divergence_energy"),
      shared_setting("energy_scale"),
      shared_setting("perturb_link"),
      [] {
        SettingSpec s = shared_setting("max_steps");
        s.doc =
            "the most steps of a run: its reported poses (refused before it starts), and "
            "Simbody's step attempts and projections (the run stops there, or once it is "
            "bound to pass it at its rate so far)";
        return s;
      }(),
      shared_setting("friction_load"),
      {.name = "friction_speed",
       .kind = number,
       .default_value = "0.0001",
       .doc = "the regularised friction's transition speed v_s (-limit x tanh(v / v_s)), a "
              "fraction of each friction joint's fastest rate in the reference: held, a joint "
              "creeps at v_s atanh(force / limit)",
       .range = {0.0, 1.0, true},
       .friction = true},
      {.name = "contact_stiffness",
       .kind = number,
       .default_value = "2e11",
       .doc = "a cam's contact surfaces' stiffness [Pa] (Hertz: Young's modulus; 2e11 steel)",
       .range = kPositive,
       .contact = true},
      {.name = "contact_dissipation",
       .kind = number,
       .default_value = "1000",
       .doc = "a cam's contact surfaces' Hunt-Crossley dissipation c [s/m]: the force is the "
              "Hertz force times 1 + 3/2 c x the rate of penetration",
       .range = kNonNegative,
       .contact = true},
  };
  return schema;
}

Config parse_settings(const Settings& overrides) {
  const SettingValues v(simbody_settings(), "Simbody", overrides);
  Config c;
  c.integrator = v.text("integrator");
  c.accuracy = v.number("accuracy");
  c.constraint_tolerance = v.number("constraint_tolerance");
  c.max_step = v.is("max_step", "auto") ? 0.0 : v.number("max_step");
  c.fixed_step = v.is("fixed_step", "off") ? 0.0 : v.number("fixed_step");
  c.interpolate = v.is("interpolate", "1");
  c.dt = v.is("dt", "auto") ? 0.0 : v.number("dt");
  c.max_step_angle = StepAngle(v, kKinematicMaxStepAngle, kDynamicsMaxStepAngle);
  c.friction_speed = v.number("friction_speed");
  c.contact_stiffness = v.number("contact_stiffness");
  c.contact_dissipation = v.number("contact_dissipation");
  c.shared = SharedSettings(v);
  return c;
}

// A Simbody exception's message on one line (it spans several, with the nested exceptions).
std::string simbody_error(const std::exception& e) {
  std::string out = "Simbody: ";
  bool space = false;
  for (const char* c = e.what(); *c; ++c) {
    const bool blank = std::isspace(static_cast<unsigned char>(*c)) != 0;
    if (blank && !space) out += ' ';
    if (!blank) out += *c;
    space = blank;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

// ---------------------------------------------------------------------------------------------
// The scene graph in Simbody's terms

SimTK::Vec3 vec3(const Eigen::Vector2d& v) {
  return {v.x(), v.y(), 0.0};
}
Eigen::Vector2d vec2(const SimTK::Vec3& v) {
  return {v[0], v[1]};
}
double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// The graph's tree policy for Simbody: MuJoCo's (no planar joints, no split loops), which both
// reduced-coordinate engines then share. A link's driven angle must be one mobilizer's. Its mesh
// contact is an elastic foundation (ElasticFoundationForce.h, 3.7: a spring of stiffness k a at
// the centre of each face of area a), read, not tried: a prism of the profile would press on a
// roller only where a face's centre lies inside it, with a force that grows with the faces'
// area and the prism's thickness rather than the contact's.
SceneGraph simbody_graph(const Mechanism& m) {
  SceneGraph g = scene_graph(
      m, TreePolicy{.contacts = true,
                    .arc_rows = true,
                    .no_mesh = "which Simbody's mesh contact would not hold as the profile: it is "
                               "an elastic foundation, a spring at the centre of each face "
                               "(ElasticFoundationForce.h), whose force follows the faces' area "
                               "and the prism's thickness rather than the contact (read, not "
                               "tried; docs/cams.md)"});
  if (g.cut_slide >= 0)
    throw std::runtime_error("a loop of slides only: Simbody's scene closes cuts at hinges");
  return g;
}

// Why the scene cannot drive this mechanism's driver ("" when it can): a driven angle that is a
// sum of mobilizer angles (a link without a ground pivot) would need a constraint of its own.
std::string driver_problem(const SceneGraph& g) {
  for (const DrivenCoordinate& d : g.driven)
    if (d.floating)
      return "the driven link has no ground pivot: its angle is a sum of mobilizer angles, which "
             "the Simbody scene does not prescribe";
  return "";
}

// The mobilizer coordinate of tree joint j per unit of the joint's value (theta_b - theta_a, or
// the slide's s): +1 when the tree runs from a to b, else -1.
double orientation(const SceneJoint& j) {
  return j.child == j.b ? 1.0 : -1.0;
}

// The driven mobilizer's prescribed coordinate: the driver's law relative to its value at the
// start (so a perturbed chain starts where it was assembled), at position, velocity and
// acceleration level, exactly.
class DriveMotion final : public SimTK::Motion::Custom::Implementation {
 public:
  DriveMotion(const Driver& driver, double t0, double coordinate0, double scale)
      : driver_(driver),
        law0_(driver.at_time(t0).value),
        coordinate0_(coordinate0),
        scale_(scale) {}
  SimTK::Motion::Level getLevel(const SimTK::State&) const override {
    return SimTK::Motion::Position;
  }
  void calcPrescribedPosition(const SimTK::State& s, int, SimTK::Real* q) const override {
    q[0] = coordinate0_ + scale_ * (driver_.at_time(s.getTime()).value - law0_);
  }
  void calcPrescribedPositionDot(const SimTK::State& s, int, SimTK::Real* qdot) const override {
    qdot[0] = scale_ * driver_.at_time(s.getTime()).rate;
  }
  void calcPrescribedPositionDotDot(const SimTK::State& s, int,
                                    SimTK::Real* qdotdot) const override {
    qdotdot[0] = scale_ * driver_.at_time(s.getTime()).accel;
  }

 private:
  Driver driver_;
  double law0_, coordinate0_, scale_;
};

// The moving links' bodies read back as the mechanism's coordinates (x, y, theta per moving link;
// the body frame is the link frame), each angle on the turn of the one q holds.
class Readback {
 public:
  Readback(const Mechanism& m, const SceneGraph& g, const std::vector<SimTK::MobilizedBody>& body) {
    for (size_t b = 0; b < g.bodies.size(); ++b)
      if (g.bodies[b].source >= 0 && !g.bodies[b].ground)
        links_.push_back({m.moving_index(g.bodies[b].source), body[b]});
  }
  // Position stage.
  void pose(const SimTK::State& s, Eigen::VectorXd& q) const {
    for (const auto& [k, body] : links_) {
      const SimTK::Transform& X = body.getBodyTransform(s);
      const SimTK::Mat33& R = X.R().asMat33();
      const double raw = std::atan2(R(1, 0), R(0, 0));
      q(3 * k) = X.p()[0];
      q(3 * k + 1) = X.p()[1];
      q(3 * k + 2) += std::remainder(raw - q(3 * k + 2), 2.0 * std::numbers::pi);
    }
  }
  // Velocity stage (and Acceleration with qddot).
  void rates(const SimTK::State& s, Eigen::VectorXd& qdot, Eigen::VectorXd* qddot) const {
    for (const auto& [k, body] : links_) {
      const SimTK::Vec3& v = body.getBodyOriginVelocity(s);
      qdot.segment<3>(3 * k) << v[0], v[1], body.getBodyAngularVelocity(s)[2];
      if (!qddot) continue;
      const SimTK::Vec3& a = body.getBodyOriginAcceleration(s);
      qddot->segment<3>(3 * k) << a[0], a[1], body.getBodyAngularAcceleration(s)[2];
    }
  }

 private:
  std::vector<std::pair<int, SimTK::MobilizedBody>> links_;  // (moving index, body)
};

// The definition's loads on the moving links, at their centres of mass: set for the next step
// (a kinematic run, where they change no motion), or evaluated by Simbody at every state from
// the state itself (DynamicsLoads at its time, positions and velocities): a dynamics run, and a
// kinematic run with a cam, whose follower the loads move (held over a step, a spring's force
// would lag by k v h: 0.13 % of the contact force's peak on eccentric_roller_spring.toml).
class LoadForce final : public SimTK::Force::Custom::Implementation {
 public:
  LoadForce(const Mechanism& m, const SceneGraph& g, const std::vector<SimTK::MobilizedBody>& body,
            const Readback& readback, const Eigen::VectorXd& q0, bool from_state)
      : readback_(readback), q_(q0), qdot_(Eigen::VectorXd::Zero(q0.size())) {
    for (size_t b = 0; b < g.bodies.size(); ++b)
      if (g.bodies[b].source >= 0 && !g.bodies[b].ground) {
        body_.push_back(body[b]);
        centre_.push_back(vec3(g.bodies[b].centre));
      }
    if (from_state) {
      dynamics_.emplace(m);
      if (!dynamics_->any()) dynamics_.reset();
    }
  }
  void set(const std::vector<BodyLoad>& loads) { fixed_ = loads; }
  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector&) const override {
    const std::vector<BodyLoad>* loads = &fixed_;
    if (dynamics_) {
      readback_.pose(s, q_);
      readback_.rates(s, qdot_, nullptr);
      loads = &dynamics_->at(s.getTime(), q_, qdot_);
    }
    for (size_t k = 0; k < loads->size() && k < body_.size(); ++k) {
      const BodyLoad& l = (*loads)[k];
      body_[k].applyForceToBodyPoint(s, centre_[k], vec3(l.force), forces);
      body_[k].applyBodyTorque(s, SimTK::Vec3(0, 0, l.moment), forces);
    }
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State&) const override { return 0.0; }

 private:
  const Readback& readback_;
  std::vector<SimTK::MobilizedBody> body_;  // per moving link
  std::vector<SimTK::Vec3> centre_;         // its centre of mass, local
  std::vector<BodyLoad> fixed_;
  mutable std::optional<DynamicsLoads> dynamics_;
  mutable Eigen::VectorXd q_, qdot_;
};

// Joint friction (docs/engines.md, "Joint friction"). Simbody 3.7 has no bounded constraint row
// (ConditionalConstraint.h declares BoundedSpeedConstraint and StateLimitedFriction "not
// implemented yet"), and a stick held by a Constraint::ConstantSpeed switched by events would
// hold a mobilizer only (a loop's cut pin has none): each friction joint's friction is a
// regularised Coulomb force, -limit x tanh(v / v_s), on its second link (a couple at a pin; at a
// slide a force along the line at the slider's point), its opposite on the first, v the joint's
// rate. It never sticks: held by a force F, the joint creeps at v_s atanh(F / limit). The limit
// (friction_limit) takes its load from Simbody's own reactions at the state a step starts from
// (the state's, not a step's as ODE's: no transients), extrapolated along the step at their rate
// since the step before (`friction_load`); after a step that ended within v_s of rest, the
// static limit. A state variable integrates the friction's power: its work over a step.
struct FrictionSetup {
  double t0 = 0.0;            // the start's time
  ReadingTrend start;         // the reference's forces at t0, and their rate
  bool extrapolated = true;   // the load extrapolated along the step
  std::vector<double> speed;  // per Mechanism joint: v_s [rad/s or m/s] (friction joints)
};

class FrictionForce final : public SimTK::Force::Custom::Implementation {
 public:
  FrictionForce(const Mechanism& m, const SceneGraph& g,
                const std::vector<SimTK::MobilizedBody>& body, const Readback& readback,
                const Eigen::VectorXd& q0, const SimTK::GeneralForceSubsystem& forces,
                FrictionSetup setup)
      : m_(m),
        readback_(readback),
        forces_(forces),
        q_(q0),
        loads_(m, std::move(setup.start), setup.extrapolated, 0),
        t_last_(setup.t0) {
    for (const SceneJoint& j : g.joints) {
      if (j.source < 0 || !m.joints[static_cast<size_t>(j.source)].friction) continue;
      const JointFriction& f = *m.joints[static_cast<size_t>(j.source)].friction;
      loaded_ |= f.load_dependent();
      rough_.push_back({.joint = j.source,
                        .a = body[static_cast<size_t>(j.a)],
                        .b = body[static_cast<size_t>(j.b)],
                        .slide = j.kind == SceneJoint::Kind::slide,
                        .ub = vec3(j.ub),
                        .direction = vec3(j.direction),
                        .speed = setup.speed[static_cast<size_t>(j.source)]});
    }
  }
  bool loaded() const { return loaded_; }
  // Before a step from state s (Acceleration stage): the reactions there (`reading`, when
  // loaded()), and whether each joint is held.
  void begin_step(const SimTK::State& s, const ForceReading* reading) {
    const double t = s.getTime();
    if (reading && loads_.geared()) readback_.pose(s, q_);
    loads_.record(reading, t - t_last_, q_);  // at the start, it replaces the reference's
    t_last_ = t;
    for (Rough& r : rough_) r.held = std::abs(rate(s, r)) < r.speed;
  }
  // Each friction at state s (Velocity stage) on its joint's second link into `out`; a slide's
  // also into its joint's force, as the exact method's.
  void write(const SimTK::State& s, ForceReading& out) const {
    for (const Rough& r : rough_) {
      const double f = friction(s, r);
      out.friction[static_cast<size_t>(r.joint)] = f;
      if (r.slide) out.joint_force[static_cast<size_t>(r.joint)] += f * vec2(axis(s, r));
    }
  }
  // The friction's work since the start [J].
  double work(const SimTK::State& s) const { return forces_.getZ(s)[z_]; }

  void calcForce(const SimTK::State& s, SimTK::Vector_<SimTK::SpatialVec>& forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector&) const override {
    for (const Rough& r : rough_) {
      const double f = friction(s, r);
      if (!r.slide) {
        r.b.applyBodyTorque(s, SimTK::Vec3(0, 0, f), forces);
        r.a.applyBodyTorque(s, SimTK::Vec3(0, 0, -f), forces);
        continue;
      }
      const SimTK::Vec3 along = f * axis(s, r);
      const SimTK::Vec3 p = r.b.findStationLocationInGround(s, r.ub);
      r.b.applyForceToBodyPoint(s, r.ub, along, forces);
      r.a.applyForceToBodyPoint(s, r.a.findStationAtGroundPoint(s, p), -along, forces);
    }
  }
  SimTK::Real calcPotentialEnergy(const SimTK::State&) const override { return 0.0; }
  void realizeTopology(SimTK::State& s) const override {
    z_ = forces_.allocateZ(s, SimTK::Vector(1, 0.0));
  }
  void realizeAcceleration(const SimTK::State& s) const override {
    double power = 0.0;
    for (const Rough& r : rough_) power += friction(s, r) * rate(s, r);
    forces_.updZDot(s)[z_] = power;
  }

 private:
  struct Rough {
    int joint = -1;  // the Mechanism joint
    SimTK::MobilizedBody a, b;
    bool slide = false;
    SimTK::Vec3 ub, direction;  // the joint's point on b; a slide's line direction on a
    double speed = 1.0;         // v_s
    bool held = false;          // the last step ended within v_s of rest
  };
  // A slide's line in the ground.
  static SimTK::Vec3 axis(const SimTK::State& s, const Rough& r) {
    return r.a.getBodyRotation(s) * r.direction;
  }
  // The joint's rate: b's relative to a (about z, or the slider's point along the line).
  static double rate(const SimTK::State& s, const Rough& r) {
    if (!r.slide) return r.b.getBodyAngularVelocity(s)[2] - r.a.getBodyAngularVelocity(s)[2];
    const SimTK::Vec3 p = r.b.findStationLocationInGround(s, r.ub);
    const SimTK::Vec3 on_a = r.a.findStationVelocityInGround(s, r.a.findStationAtGroundPoint(s, p));
    return SimTK::dot(r.b.findStationVelocityInGround(s, r.ub) - on_a, axis(s, r));
  }
  double friction(const SimTK::State& s, const Rough& r) const {
    const JointFriction& law = *m_.joints[static_cast<size_t>(r.joint)].friction;
    double limit = 0.0;
    if (!loaded_) {
      limit = law.limit(!r.slide, 0.0, r.held);
    } else {
      readback_.pose(s, q_);
      limit = friction_limit(m_, r.joint, q_, loads_.next(s.getTime() - t_last_), r.held);
    }
    return -limit * std::tanh(rate(s, r) / r.speed);
  }

  const Mechanism& m_;
  const Readback& readback_;
  const SimTK::GeneralForceSubsystem& forces_;
  std::vector<Rough> rough_;
  bool loaded_ = false;
  mutable Eigen::VectorXd q_;
  // The reactions at the step's start and their rate (no transients: Simbody's own state's).
  mutable FrictionLoads loads_;
  double t_last_;  // the time of the last reading
  mutable SimTK::ZIndex z_;
};

// The Simbody system of a scene graph at configuration q with rates qdot, at time t0; its driven
// mobilizer prescribed by the driver's law when `driven`. Throws (std::exception) when Simbody
// refuses it.
// A cam's contact surfaces' material (Config::contact_stiffness, contact_dissipation).
struct ContactSetup {
  double stiffness = 0.0, dissipation = 0.0;
};

class Scene {
 public:
  Scene(const Mechanism& m, const SceneGraph& g, const Eigen::VectorXd& q,
        const Eigen::VectorXd& qdot, double t0, bool driven,
        std::optional<FrictionSetup> friction = std::nullopt, ContactSetup contact = {})
      : m_(m), g_(g), matter_(system_), forces_(system_) {
    body_.resize(g.bodies.size());
    body_[0] = matter_.Ground();
    for (int ji : g.tree_order) {
      const SceneJoint& j = g.joints[static_cast<size_t>(ji)];
      const SceneBody& child = g.bodies[static_cast<size_t>(j.child)];
      const SimTK::Vec3 centre = vec3(child.centre);
      const SimTK::MassProperties mass(child.mass, centre,
                                       SimTK::Inertia(child.inertia, child.inertia, child.inertia)
                                           .shiftFromMassCenter(centre, child.mass));
      const bool forward = j.child == j.b;
      SimTK::MobilizedBody& parent = body_[static_cast<size_t>(j.parent)];
      if (j.kind == SceneJoint::Kind::hinge) {
        // q = theta_child - theta_parent: both frames keep their body's orientation.
        const SimTK::Transform on_parent(vec3(forward ? j.ua : j.ub));
        const SimTK::Transform on_child(vec3(forward ? j.ub : j.ua));
        body_[static_cast<size_t>(j.child)] =
            SimTK::MobilizedBody::Pin(parent, on_parent, SimTK::Body::Rigid(mass), on_child);
      } else if (j.kind == SceneJoint::Kind::slide) {
        // Frames along the line on the guide (a) and turned by the relative angle on the
        // slider (b): q = s from the guide, -s from the slider.
        const double along = std::atan2(j.direction.y(), j.direction.x());
        const SimTK::Transform guide(SimTK::Rotation(along, SimTK::ZAxis), vec3(j.origin));
        const SimTK::Transform slider(SimTK::Rotation(along - j.relative_angle, SimTK::ZAxis),
                                      vec3(j.ub));
        body_[static_cast<size_t>(j.child)] = SimTK::MobilizedBody::Slider(
            parent, forward ? guide : slider, SimTK::Body::Rigid(mass), forward ? slider : guide);
      } else {
        throw std::runtime_error("a planar joint in Simbody's tree");
      }
    }
    for (int ji : g.cuts) {
      const SceneJoint& j = g.joints[static_cast<size_t>(ji)];
      ball_.emplace_back(ji, SimTK::Constraint::Ball(body_[static_cast<size_t>(j.a)], vec3(j.ua),
                                                     body_[static_cast<size_t>(j.b)], vec3(j.ub)));
    }
    // A curved slot: a rod from the arc's centre to the pin, its radius long (one constraint
    // row, and no body between).
    for (const SceneArc& a : g.arcs)
      rods_.emplace_back(body_[static_cast<size_t>(a.guide)], vec3(a.centre),
                         body_[static_cast<size_t>(a.pin)], vec3(a.point), a.radius);
    // A gear pair or rack: a coordinate coupler holding its linear function of the mobilities
    // (SceneCoupling, with each q = orientation x value) at its start value.
    for (const SceneCoupling& c : g.couplings) {
      const int n = static_cast<int>(c.terms.size());
      SimTK::Vector coefficients(n + 1);
      std::vector<SimTK::MobilizedBodyIndex> mobods;
      std::vector<SimTK::MobilizerQIndex> qs;
      double start = 0.0;
      for (int k = 0; k < n; ++k) {
        const auto& [ji, coefficient] = c.terms[static_cast<size_t>(k)];
        const SceneJoint& j = g.joints[static_cast<size_t>(ji)];
        coefficients[k] = coefficient * orientation(j);
        start += coefficient * joint_value(j, q, qdot)[0];
        mobods.push_back(body_[static_cast<size_t>(j.child)].getMobilizedBodyIndex());
        qs.emplace_back(0);
      }
      coefficients[n] = -start;
      couplers_.emplace_back(matter_, new SimTK::Function::Linear(coefficients), mobods, qs);
    }
    SimTK::Force::UniformGravity(forces_, matter_, vec3(m.gravity));
    readback_.emplace(m, g, body_);
    load_ = new LoadForce(m, g, body_, *readback_, q, !driven || !g.contacts.empty());
    SimTK::Force::Custom(forces_, load_);  // Simbody owns load_
    if (friction) {
      friction_ = new FrictionForce(m, g, body_, *readback_, q, forces_, std::move(*friction));
      SimTK::Force::Custom(forces_, friction_);  // Simbody owns friction_
    }
    if (!g.contacts.empty()) add_contacts(contact);
    // Each driver's mobilizer prescribed by its own law.
    for (size_t di = 0; driven && di < g.driven.size(); ++di) {
      const DrivenCoordinate& d = g.driven[di];
      const SceneJoint& dj = g.joints[static_cast<size_t>(d.joint)];
      const double coordinate0 = orientation(dj) * joint_value(dj, q, qdot)[0];
      SimTK::MobilizedBody& mobod = body_[static_cast<size_t>(dj.child)];
      SimTK::Motion::Custom(
          mobod, new DriveMotion(m.drivers[di], t0, coordinate0, orientation(dj) * d.sign));
    }
    system_.realizeTopology();
    for (Surfaces& pair : surfaces_)
      for (auto* which : {&pair.cam, &pair.follower})
        which->index = tracker_->getContactSurfaceIndex(
            body_[static_cast<size_t>(which->body)].getMobilizedBodyIndex(), which->on_body);
    state_ = system_.getDefaultState();
    state_.setTime(t0);
    for (int ji : g.tree_order) {
      const SceneJoint& j = g.joints[static_cast<size_t>(ji)];
      const Eigen::Vector2d value = orientation(j) * joint_value(j, q, qdot);
      body_[static_cast<size_t>(j.child)].setOneQ(state_, 0, value[0]);
      body_[static_cast<size_t>(j.child)].setOneU(state_, 0, value[1]);
    }
    system_.realize(state_, SimTK::Stage::Position);
  }

  const SimTK::MultibodySystem& system() const { return system_; }
  const SimTK::SimbodyMatterSubsystem& matter() const { return matter_; }
  const SimTK::State& start() const { return state_; }
  const Readback& readback() const { return *readback_; }
  LoadForce& loads() { return *load_; }
  FrictionForce* friction() { return friction_; }  // null without joint friction

  // The constraint forces at state s (Acceleration stage), in the mechanism's terms: a tree
  // joint's from its mobilizer's reaction, a cut hinge's from its ball; with `effort`, each
  // driver's effort from its driven mobilizer's reaction along its coordinate.
  void read_forces(const SimTK::State& s, bool effort, ForceReading& out) const {
    out.set_zero();
    // A coupler's multiplier lambda applies -lambda x coefficient along each of its coordinates
    // (a constraint force's sign, as the balls'): as a couple on the first moving gear it is the
    // gear's (write_forces puts it on the teeth); a mobilizer's reaction counts what falls on its
    // coordinate, which the exact method leaves out of the joint's force (a rack's slide: a push
    // along the line) and of the driver's effort.
    std::vector<double> coupled(couplers_.empty() ? 0 : g_.joints.size(), 0.0);
    for (size_t k = 0; k < couplers_.size(); ++k) {
      const SceneCoupling& c = g_.couplings[k];
      const double applied = -couplers_[k].getMultipliersAsVector(s)[0];
      out.gear_couple[static_cast<size_t>(c.source)] = c.on_first * applied;
      for (const auto& [ji, coefficient] : c.terms)
        coupled[static_cast<size_t>(ji)] += coefficient * applied;
    }
    for (size_t ji = 0; ji < g_.joints.size(); ++ji) {
      const SceneJoint& j = g_.joints[ji];
      if (j.block_guide) continue;  // a slot's force is its pin's
      const SimTK::MobilizedBody& b = body_[static_cast<size_t>(j.b)];
      const Eigen::Vector2d point_b = vec2(b.getBodyTransform(s) * vec3(j.ub));
      Eigen::Vector2d on_b = Eigen::Vector2d::Zero();
      double couple_b = 0.0;  // on b about its point ub
      if (j.in_tree) {
        const SimTK::MobilizedBody& child = body_[static_cast<size_t>(j.child)];
        const SimTK::SpatialVec r = child.findMobilizerReactionOnBodyAtMInGround(s);
        const Eigen::Vector2d at = vec2(child.getBodyTransform(s) * child.getOutboardFrame(s).p());
        const Eigen::Vector2d f = vec2(r[1]);
        const double sign = orientation(j);  // the reaction on a is minus that on b
        on_b = sign * f;
        couple_b = sign * (r[0][2] + cross2(at - point_b, f));
      } else {
        const auto it = std::find_if(ball_.begin(), ball_.end(), [&](const auto& c) {
          return c.first == static_cast<int>(ji);
        });
        // Simbody reports the reaction with a constraint force's sign (the opposite of an applied
        // force's; SimbodyEngine.FourBarForcesMatchTheExactReference holds it).
        on_b = -vec2(b.getBodyRotation(s) * it->second.getBallReactionForceOnBody2(s));
      }
      if (j.kind == SceneJoint::Kind::slide) out.couple[static_cast<size_t>(j.source)] = couple_b;
      if (!coupled.empty() && coupled[ji] != 0.0) {
        if (j.kind == SceneJoint::Kind::slide)
          on_b -= coupled[ji] *
                  vec2(body_[static_cast<size_t>(j.a)].getBodyRotation(s) * vec3(j.direction));
        else
          couple_b -= coupled[ji];
      }
      for (size_t di = 0; effort && di < g_.driven.size(); ++di) {
        const DrivenCoordinate& d = g_.driven[di];
        if (static_cast<int>(ji) != d.joint) continue;
        if (j.kind == SceneJoint::Kind::slide) {
          const Eigen::Vector2d u =
              vec2(body_[static_cast<size_t>(j.a)].getBodyRotation(s) * vec3(j.direction));
          const double axial = on_b.dot(u);
          out.effort_of(static_cast<int>(di)) = d.sign * axial;
          on_b -= axial * u;
        } else {
          out.effort_of(static_cast<int>(di)) = d.sign * couple_b;
        }
      }
      out.joint_force[static_cast<size_t>(j.source)] = on_b;
    }
    if (friction_) friction_->write(s, out);
    // A curved slot: its rod's tension pulls the pin towards the arc's centre.
    for (size_t k = 0; k < rods_.size(); ++k)
      out.joint_force[static_cast<size_t>(g_.arcs[k].source)] =
          -rods_[k].getRodTension(s) * vec2(rods_[k].findRodOrientationInG(s));
    // A cam's contact: its compliant force on the follower, while the surfaces touch (a yoke's
    // two faces are one joint's).
    for (size_t k = 0; k < surfaces_.size(); ++k) {
      const SimTK::ContactSnapshot& active = tracker_->getActiveContacts(s);
      const SimTK::ContactId id =
          active.getContactIdForSurfacePair(surfaces_[k].cam.index, surfaces_[k].follower.index);
      if (!id.isValid()) continue;
      const SimTK::Vec3 on_second = compliant_->getContactForceById(s, id).getForceOnSurface2()[1];
      const double sign =
          active.getContactById(id).getSurface2() == surfaces_[k].follower.index ? 1.0 : -1.0;
      out.joint_force[static_cast<size_t>(g_.contacts[k].source)] += sign * vec2(on_second);
    }
  }

 private:
  // The cams' contacts (SceneContact): Simbody's compliant contact, the Hertz force of its
  // ContactTrackerSubsystem's sphere-sphere and half-space-sphere pairs with Hunt and Crossley's
  // dissipation (CompliantContactSubsystem's default generators), frictionless; a flat face is a
  // half-space through its line, exact as the box of the other engines.
  void add_contacts(const ContactSetup& contact) {
    tracker_.emplace(system_);
    compliant_.emplace(system_, *tracker_);
    const SimTK::ContactMaterial material(contact.stiffness, contact.dissipation, 0.0, 0.0, 0.0);
    std::vector<int> on_body(g_.bodies.size(), 0);
    const auto add = [&](int body, const SimTK::Transform& at,
                         const SimTK::ContactGeometry& shape) {
      body_[static_cast<size_t>(body)].updBody().addContactSurface(
          at, SimTK::ContactSurface(shape, material));
      return Surface{body, on_body[static_cast<size_t>(body)]++, {}};
    };
    for (const SceneContact& c : g_.contacts) {
      Surfaces pair;
      // A yoke's far face touches the near face's disc: a second sphere there would touch the
      // near face too, and double its contact.
      pair.cam = c.far ? surfaces_.back().cam
                       : add(c.cam, SimTK::Transform(vec3(c.cam_centre)),
                             SimTK::ContactGeometry::Sphere(c.cam_radius));
      if (c.face) {
        // The half-space x > 0 of its frame, its outward normal -x towards the cam: x along the
        // face's normal away from the cam, the origin on the face's line.
        const double normal = c.box_angle + 0.5 * std::numbers::pi;
        const Eigen::Vector2d away(std::cos(normal), std::sin(normal));
        const Eigen::Vector2d on_face = c.follower_centre - c.box_half.y() * away;
        pair.follower =
            add(c.follower, SimTK::Transform(SimTK::Rotation(normal, SimTK::ZAxis), vec3(on_face)),
                SimTK::ContactGeometry::HalfSpace());
      } else {
        pair.follower = add(c.follower, SimTK::Transform(vec3(c.follower_centre)),
                            SimTK::ContactGeometry::Sphere(c.follower_radius));
      }
      surfaces_.push_back(pair);
    }
  }

  // A joint's value and rate (theta_b - theta_a, or the slide's s) from the mechanism's state.
  Eigen::Vector2d joint_value(const SceneJoint& j, const Eigen::VectorXd& q,
                              const Eigen::VectorXd& qdot) const {
    const BodyMotion a = body_motion(m_, g_.bodies[static_cast<size_t>(j.a)], q, &qdot);
    const BodyMotion b = body_motion(m_, g_.bodies[static_cast<size_t>(j.b)], q, &qdot);
    if (j.kind == SceneJoint::Kind::hinge) return {b.theta - a.theta, b.omega - a.omega};
    const Projection p = project(a, j.origin, j.direction, b, j.ub);
    return {p.value, p.rate};
  }

  const Mechanism& m_;
  const SceneGraph& g_;
  SimTK::MultibodySystem system_;
  SimTK::SimbodyMatterSubsystem matter_;
  SimTK::GeneralForceSubsystem forces_;
  std::vector<SimTK::MobilizedBody> body_;                      // per scene body; 0 the ground
  std::vector<std::pair<int, SimTK::Constraint::Ball>> ball_;   // (cut joint, its ball)
  std::vector<SimTK::Constraint::Rod> rods_;                    // per SceneArc
  std::vector<SimTK::Constraint::CoordinateCoupler> couplers_;  // per SceneCoupling
  std::optional<Readback> readback_;
  LoadForce* load_ = nullptr;
  FrictionForce* friction_ = nullptr;
  // Cams: the contact subsystems and, per SceneContact, its two surfaces (body, its surface's
  // number on the body, and once the topology is realised its index in the tracker).
  std::optional<SimTK::ContactTrackerSubsystem> tracker_;
  std::optional<SimTK::CompliantContactSubsystem> compliant_;
  struct Surface {
    int body = -1, on_body = 0;
    SimTK::ContactSurfaceIndex index;
  };
  struct Surfaces {
    Surface cam, follower;
  };
  std::vector<Surfaces> surfaces_;
  SimTK::State state_;
};

std::unique_ptr<SimTK::Integrator> make_integrator(const Config& c,
                                                   const SimTK::MultibodySystem& system) {
  std::unique_ptr<SimTK::Integrator> out;
  const std::string& name = c.integrator;
  if (name == "merson")
    out = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(system);
  else if (name == "feldberg")
    out = std::make_unique<SimTK::RungeKuttaFeldbergIntegrator>(system);
  else if (name == "rk3")
    out = std::make_unique<SimTK::RungeKutta3Integrator>(system);
  else if (name == "rk2")
    out = std::make_unique<SimTK::RungeKutta2Integrator>(system);
  else if (name == "semi_explicit_euler2")
    out = std::make_unique<SimTK::SemiExplicitEuler2Integrator>(system);
  else if (name == "verlet")
    out = std::make_unique<SimTK::VerletIntegrator>(system);
  else if (name == "explicit_euler")
    out = std::make_unique<SimTK::ExplicitEulerIntegrator>(system);
  else
    out = std::make_unique<SimTK::CPodesIntegrator>(system, SimTK::CPodes::BDF,
                                                    SimTK::CPodes::Newton);
  out->setAccuracy(c.accuracy);
  out->setConstraintTolerance(c.constraint_tolerance);
  if (c.max_step > 0.0) out->setMaximumStepSize(c.max_step);
  if (c.fixed_step > 0.0) out->setFixedStepSize(c.fixed_step);
  out->setAllowInterpolation(c.interpolate);
  out->setProjectInterpolatedStates(true);
  return out;
}

// The reciprocal condition of the loop constraints' position Jacobian (Simbody's Pq, its rows out
// of the plane, identically zero, left out) at state s: its smallest singular value over its
// largest; 1 without a loop. It is what Simbody's projection onto the loops solves with.
double loops_rcond(const Scene& scene, const SimTK::State& s) {
  SimTK::State at = s;
  scene.system().realize(at, SimTK::Stage::Position);
  SimTK::Matrix pq;
  scene.matter().calcPq(at, pq);
  Eigen::MatrixXd j(pq.nrow(), pq.ncol());
  for (int r = 0; r < pq.nrow(); ++r)
    for (int c = 0; c < pq.ncol(); ++c) j(r, c) = pq(r, c);
  const double largest_row = j.rows() > 0 ? j.rowwise().norm().maxCoeff() : 0.0;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index r = 0; r < j.rows(); ++r)
    if (j.row(r).norm() > 1e-12 * largest_row) kept.push_back(r);
  if (kept.empty()) return 1.0;
  const Eigen::VectorXd sv =
      Eigen::JacobiSVD<Eigen::MatrixXd>(j(kept, Eigen::all)).singularValues();
  return sv.size() < static_cast<Eigen::Index>(kept.size()) || sv[0] == 0.0 ? 0.0
                                                                            : sv.tail(1)[0] / sv[0];
}

// Why the integrator stopped, with the loops' conditioning where it stopped against the start's:
// at a singular position (a change point, a toggle, A02's parallel bars) the projection onto
// rank-deficient loop constraints has no unique solution and the step fails.
std::string stopped_at(const Scene& scene, const SimTK::State& s, const std::string& why) {
  try {
    const double there = loops_rcond(scene, s), start = loops_rcond(scene, scene.start());
    return fmt::format(
        "{} (the loop constraints' Jacobian at t = {:.6g} s: reciprocal condition {:.2g}, {:.2g} "
        "of the start's {:.2g}{})",
        why, s.getTime(), there, there / start, start,
        there < 1e-3 * start ? ": a singular position of the loops" : "");
  } catch (const std::exception&) {
    return why;
  }
}

// The scene stepped by its integrator to each reported pose, read back as the mechanism's
// coordinates: what both runs' scenes share. A Simbody exception becomes the step's alarm (the
// run stops there, diverged), never a crash.
class SimbodySteps {
 public:
  // `t_end`: the time the run ends at, for the projection of its work.
  SimbodySteps(Scene& scene, const Config& c, const Mechanism& m, const Eigen::VectorXd& q0,
               double t_end)
      : scene_(scene),
        reading_(m.joints.size(), m.drivers.size()),
        q_(q0),
        scratch_(scene.start()),
        max_steps_(c.shared.max_steps),
        t_begin_(scene.start().getTime()),
        t_end_(t_end) {
    integrator_ = make_integrator(c, scene.system());
    // Control comes back every so many internal steps, so that a run whose step collapses (at a
    // singular passage CPodes' step fell to 1e-17 s, where t + h = t, and stepped on for hours
    // on IFToMM A02) stops with its reason instead of stepping on.
    integrator_->setInternalStepLimit(kInternalStepsPerCall);
    integrator_->initialize(scene.start());
    scene_.readback().pose(integrator_->getState(), q_);
  }
  // The run's work in steps, what max_steps bounds: every internal step Simbody attempted
  // (rejected ones cost as much) and every projection onto the constraints (a Newton solve of
  // the loops, about a step's work; at a mass ratio of 1e18 there were more than steps, and
  // each step took 0.5 ms instead of 10 us).
  long work() const {
    return static_cast<long>(integrator_->getNumStepsAttempted()) +
           static_cast<long>(integrator_->getNumProjections());
  }
  // Advances to time t1; "" or why the integrator could not.
  std::string advance(double t1) {
    try {
      FrictionForce* friction = scene_.friction();
      double work_before = 0.0;
      if (friction) {
        // The load at the state the step starts from; the advanced state's cache, computed with
        // the last step's, goes.
        if (friction->loaded())
          if (std::string why = forces(false, reading_); !why.empty()) return why;
        friction->begin_step(integrator_->getState(), friction->loaded() ? &reading_ : nullptr);
        integrator_->updAdvancedState().invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
        work_before = friction->work(integrator_->getState());
      }
      while (integrator_->getTime() < t1) {
        const double before = integrator_->getTime();
        // No more steps in one call than the budget has left, so that it stops at max_steps.
        integrator_->setInternalStepLimit(static_cast<int>(
            std::clamp(max_steps_ - work(), 1L, static_cast<long>(kInternalStepsPerCall))));
        const SimTK::Integrator::SuccessfulStepStatus status = integrator_->stepTo(t1);
        if (integrator_->isSimulationOver())
          return stopped_at(
              scene_, integrator_->getState(),
              "Simbody's integrator stopped: " + SimTK::Integrator::getTerminationReasonString(
                                                     integrator_->getTerminationReason()));
        if (status == SimTK::Integrator::ReachedStepLimit && integrator_->getTime() == before)
          return stopped_at(
              scene_, integrator_->getState(),
              fmt::format("Simbody's integrator does not advance: its step fell to {:.2g} s, "
                          "below the time's resolution",
                          integrator_->getPreviousStepSizeTaken()));
        if (std::string why = over_budget(); !why.empty())
          return stopped_at(scene_, integrator_->getState(), why);
      }
      if (friction) friction_work_ = friction->work(integrator_->getState()) - work_before;
    } catch (const std::exception& e) {
      return stopped_at(scene_, integrator_->getState(), simbody_error(e));
    }
    scene_.readback().pose(integrator_->getState(), q_);
    return "";
  }
  double friction_work() const { return friction_work_; }  // over the last advance [J]
  // The forces at the current state, with the loads set since it was realized.
  std::string forces(bool effort, ForceReading& out) {
    try {
      scratch_ = integrator_->getState();
      scratch_.invalidateAllCacheAtOrAbove(SimTK::Stage::Dynamics);
      scene_.system().realize(scratch_, SimTK::Stage::Acceleration);
      scene_.read_forces(scratch_, effort, out);
    } catch (const std::exception& e) {
      return simbody_error(e);
    }
    return "";
  }
  const SimTK::Integrator& integrator() const { return *integrator_; }
  const Eigen::VectorXd& pose() const { return q_; }
  Scene& scene() { return scene_; }
  SimTK::State& scratch() { return scratch_; }
  long evaluations() const { return integrator_->getNumRealizations(); }
  std::string note(const Config& c) const {
    return fmt::format("Simbody {} took {} internal steps ({} realizations, {} projections)",
                       c.integrator, integrator_->getNumStepsTaken(),
                       integrator_->getNumRealizations(), integrator_->getNumProjections());
  }

 private:
  static constexpr int kInternalStepsPerCall = 1'000;
  // "" while the run's work is within max_steps, and projected to stay within it: after the first
  // kInternalStepsPerCall steps' work, the work so far over the time covered, times the run's
  // time, must not exceed it either (a run whose steps shrink 100-fold stops in a second, not in
  // 19 minutes of steps that would all count).
  std::string over_budget() const {
    const long done = work();
    const double t = integrator_->getTime();
    const auto what = [&] {
      return fmt::format(
          "{} step attempts and {} projections onto the constraints by t = {:.6g} "
          "s, its last step {:.2g} s",
          integrator_->getNumStepsAttempted(), integrator_->getNumProjections(), t,
          integrator_->getPreviousStepSizeTaken());
    };
    if (done >= max_steps_)
      return fmt::format(
          "Simbody's work reached max_steps = {} steps, the most of one run (raise it with "
          "--max-steps N): {}",
          max_steps_, what());
    if (done < kInternalStepsPerCall || !(t > t_begin_)) return "";
    const double projected = static_cast<double>(done) * (t_end_ - t_begin_) / (t - t_begin_);
    if (projected <= static_cast<double>(max_steps_)) return "";
    return fmt::format(
        "Simbody's work would exceed max_steps = {} steps, the most of one run (raise it with "
        "--max-steps N): at its rate so far the run takes about {:.3g} ({} over {:.3g} of its "
        "{:.3g} s)",
        max_steps_, projected, what(), t - t_begin_, t_end_ - t_begin_);
  }
  Scene& scene_;
  ForceReading reading_;  // scratch: the friction's load
  double friction_work_ = 0.0;
  std::unique_ptr<SimTK::Integrator> integrator_;
  Eigen::VectorXd q_;
  SimTK::State scratch_;
  long max_steps_;
  double t_begin_, t_end_;
};

// ---------------------------------------------------------------------------------------------
// Runs

// The settings, the mechanism the scene is built from (perturb_link) and the thresholds' auto
// values, refused (std::exception) before anything is built.
struct Prepared {
  Config config;
  Mechanism m;
  Span span;
  SceneGraph graph;
};

Prepared prepare(const Mechanism& original, const Trajectory& reference,
                 const Settings& overrides) {
  Prepared p;
  p.config = parse_settings(overrides);
  p.m = perturbed(original, p.config.shared.perturb_link);
  p.config.shared.resolve(p.m);
  p.span = usable_span(reference);
  p.graph = simbody_graph(p.m);
  return p;
}

// The reported poses' spacing: dt, or the step in which the reference's fastest link turns by
// max_step_angle (central differences of the poses err as (omega dt)^2).
double wanted_step(const Trajectory& reference, const Config& c, const Span& span, bool dynamics) {
  return step_length(reference, span, c.dt, c.max_step_angle.of(dynamics), 0);
}

// The friction's setup for a run over `span` of the reference, from time t0 (none without joint
// friction): each friction joint's v_s the setting's fraction of its fastest rate over the
// reference's usable samples (of the fastest link's, or that times the size for a slide, where
// the joint never moves).
std::optional<FrictionSetup> friction_setup(const Mechanism& m, const Trajectory& reference,
                                            const Span& span, double t0, const Config& c) {
  if (!m.has_friction()) return std::nullopt;
  FrictionSetup out{.t0 = t0,
                    .start = reference_trend(m, reference, span.first, t0),
                    .extrapolated = c.shared.extrapolated_load,
                    .speed = std::vector<double>(m.joints.size(), 0.0)};
  const std::vector<int> slides = m.slide_joints();
  const auto omega = [&](int link, int k) {
    const int i = m.moving_index(link);
    return i < 0 ? 0.0 : reference.omega(k, i);
  };
  for (int ji : m.friction_joints()) {
    const Joint& j = m.joints[static_cast<size_t>(ji)];
    const auto slide = std::find(slides.begin(), slides.end(), ji);
    double fastest = 0.0;
    for (int k = span.first; k <= span.last; ++k) {
      if (!usable(reference.status[static_cast<size_t>(k)])) continue;
      const double rate = slide != slides.end() ? reference.sdot(k, slide - slides.begin())
                                                : omega(j.link_b, k) - omega(j.link_a, k);
      fastest = std::max(fastest, std::abs(rate));
    }
    if (fastest == 0.0) fastest = fastest_rate(reference, span) * (j.is_slide() ? m.size() : 1.0);
    out.speed[static_cast<size_t>(ji)] = c.friction_speed * (fastest > 0.0 ? fastest : 1.0);
  }
  return out;
}

Settings common_settings(const Config& c, double dt, bool dynamics, bool friction, bool contact) {
  Settings values = {{"integrator", c.integrator},
                     {"accuracy", format_number(c.accuracy)},
                     {"constraint_tolerance", format_number(c.constraint_tolerance)},
                     {"max_step", c.max_step > 0.0 ? format_number(c.max_step) : "auto"},
                     {"fixed_step", c.fixed_step > 0.0 ? format_number(c.fixed_step) : "off"},
                     {"interpolate", c.interpolate ? "1" : "0"},
                     {"dt", format_number(dt)},
                     {"max_step_angle", c.dt == 0.0 ? format_number(c.max_step_angle.of(dynamics))
                                                    : "unused (dt given)"}};
  if (friction) values.emplace_back("friction_speed", format_number(c.friction_speed));
  if (contact) {
    values.emplace_back("contact_stiffness", format_number(c.contact_stiffness));
    values.emplace_back("contact_dissipation", format_number(c.contact_dissipation));
  }
  return values;
}

// A kinematic run's scene for the shared run loop: the driven mobilizer follows the law by
// itself (Motion::Custom), so drive() has nothing to do; forces at the pose a step leaves.
class SimbodyKinematicScene final : public KinematicScene {
 public:
  SimbodyKinematicScene(SimbodySteps& steps, const Config& c) : steps_(steps), c_(c) {}
  void drive(const std::vector<double>&) override {}
  void apply(const std::vector<BodyLoad>& loads) override { steps_.scene().loads().set(loads); }
  std::string step(double h, ForceReading* forces) override {
    if (forces)
      if (std::string why = steps_.forces(true, *forces); !why.empty()) return why;
    return steps_.advance(steps_.integrator().getTime() + h);
  }
  void read_pose(Eigen::VectorXd& q) override { q = steps_.pose(); }
  long evaluations() const override { return steps_.evaluations(); }
  std::string note() const override { return steps_.note(c_); }

 private:
  SimbodySteps& steps_;
  const Config& c_;
};

// A dynamics run's scene for the shared run loop: Simbody evaluates the loads itself at every
// state (LoadForce), and the samples take its own state (rates and forces at the state it
// integrated to), kept for the last kRing steps.
class SimbodyDynamicsScene final : public DynamicsScene {
 public:
  SimbodyDynamicsScene(SimbodySteps& steps, const Config& c) : steps_(steps), c_(c) { keep(0); }
  bool evaluates_loads() const override { return true; }
  std::string step(double t0, double h, ForceReading* forces) override {
    if (forces)
      if (std::string why = steps_.forces(false, *forces); !why.empty()) return why;
    std::string why = steps_.advance(t0 + h);
    keep(++taken_);
    return why;
  }
  void read_pose(Eigen::VectorXd& q) override { q = steps_.pose(); }
  bool reads_state() const override { return true; }
  void read_state(long S, double t, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot,
                  ForceReading& forces) override {
    const Kept& k = ring_[static_cast<size_t>(S % kRing)];
    SimTK::State& s = steps_.scratch();
    s.setTime(t);
    s.updQ() = k.q;
    s.updU() = k.u;
    const Scene& scene = steps_.scene();
    scene.system().realize(s, SimTK::Stage::Acceleration);
    scene.readback().rates(s, qdot, &qddot);
    scene.read_forces(s, false, forces);
  }
  long evaluations() const override { return steps_.evaluations(); }
  std::string note() const override { return steps_.note(c_); }
  double friction_work() const override { return steps_.friction_work(); }

 private:
  struct Kept {
    SimTK::Vector q, u;
  };
  void keep(long k) {
    const SimTK::State& s = steps_.integrator().getState();
    Kept& kept = ring_[static_cast<size_t>(k % kRing)];
    kept.q = s.getQ();
    kept.u = s.getU();
  }
  SimbodySteps& steps_;
  const Config& c_;
  std::array<Kept, kRing> ring_;
  long taken_ = 0;
};

EngineRun run_dynamics(const Mechanism& original, const Trajectory& reference,
                       const Settings& overrides) {
  const auto begin = Clock::now();
  EngineRun out;
  out.trajectory.method = "simbody";
  out.trajectory.resize_as(original, reference, true, true);
  Prepared p;
  DynamicsPlan plan;
  try {
    p = prepare(original, reference, overrides);
    plan = plan_dynamics(original, p.m, reference, wanted_step(reference, p.config, p.span, true),
                         InnerTimes::step_multiples, p.config.shared.max_steps,
                         !p.config.shared.perturb_link.empty());
  } catch (const std::exception& e) {
    return failed_run(std::move(out), e.what());
  }
  const Config& c = p.config;
  const double energy_scale = std::max(reference_energy_scale(original, reference), 1e-12);
  Settings values =
      common_settings(c, plan.grid.dt, true, p.m.has_friction(), !p.graph.contacts.empty());
  const Settings shared = c.shared.dynamics_printed(energy_scale, p.m.has_friction());
  values.insert(values.end(), shared.begin(), shared.end());
  values.emplace_back("forces",
                      "mobilizer reactions and ball constraint forces at each sampled state");
  out.settings = printed_settings(simbody_settings(), RunKind::dynamics, values, p.m.has_friction(),
                                  !p.graph.contacts.empty());
  std::optional<Scene> scene;
  std::optional<SimbodySteps> steps;
  try {
    scene.emplace(p.m, p.graph, plan.start.q, plan.start.qdot, plan.grid.time.front(), false,
                  friction_setup(p.m, reference, plan.span, plan.grid.time.front(), c));
    steps.emplace(*scene, c, p.m, plan.start.q, plan.grid.time.back());
  } catch (const std::exception& e) {
    return failed_run(std::move(out), "scene build failed: " + simbody_error(e));
  }
  SimbodyDynamicsScene stepped(*steps, c);
  const DynamicsWatch watch = c.shared.dynamics_watch(p.m, energy_scale);
  sim::run_dynamics(original, p.m, reference, plan, watch, true, stepped, begin, out);
  return out;
}

class SimbodyEngine final : public Engine {
 public:
  std::string name() const override { return "simbody"; }
  const SettingSchema& settings_schema() const override { return simbody_settings(); }

  bool supports(const Mechanism& mechanism, std::string* why) const override {
    try {
      const SceneGraph g = simbody_graph(mechanism);
      if (const std::string problem = driver_problem(g); !problem.empty() && !mechanism.dynamics) {
        if (why) *why = problem;
        return false;
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
    if (original.dynamics) return run_dynamics(original, reference, overrides);
    const auto begin = Clock::now();
    EngineRun out;
    out.trajectory.method = "simbody";
    out.trajectory.resize_as(original, reference, false);
    Prepared p;
    KinematicPlan plan;
    try {
      p = prepare(original, reference, overrides);
      if (const std::string problem = driver_problem(p.graph); !problem.empty())
        throw std::runtime_error(problem);
      plan = plan_kinematic(p.m, reference, wanted_step(reference, p.config, p.span, false),
                            InnerTimes::step_multiples,
                            p.graph.contacts.empty() ? kPreroll : kContactPreroll,
                            p.config.shared.max_steps, p.config.shared.singular_rcond,
                            !p.config.shared.perturb_link.empty());
    } catch (const std::exception& e) {
      return failed_run(std::move(out), e.what());
    }
    const Config& c = p.config;
    Settings values =
        common_settings(c, plan.grid.dt, false, p.m.has_friction(), !p.graph.contacts.empty());
    const Settings shared = c.shared.kinematic_printed(p.m.has_friction());
    values.insert(values.end(), shared.begin(), shared.end());
    values.emplace_back("forces",
                        "mobilizer reactions, ball constraint forces and the driven mobilizer's "
                        "prescribed-motion force at the pose each step leaves");
    out.settings = printed_settings(simbody_settings(), RunKind::kinematic, values,
                                    p.m.has_friction(), !p.graph.contacts.empty());
    std::optional<Scene> scene;
    std::optional<SimbodySteps> steps;
    try {
      scene.emplace(p.m, p.graph, plan.q, plan.qdot, plan.grid.time.front(), true,
                    friction_setup(p.m, reference, plan.span, plan.grid.time.front(), c),
                    ContactSetup{c.contact_stiffness, c.contact_dissipation});
      steps.emplace(*scene, c, p.m, plan.q, plan.grid.time.back());
    } catch (const std::exception& e) {
      return failed_run(std::move(out), "scene build failed: " + simbody_error(e));
    }
    SimbodyKinematicScene stepped(*steps, c);
    const KinematicWatch watch = c.shared.kinematic_watch(p.m);
    run_kinematic(original, p.m, reference, plan, watch, true, stepped, begin, out);
    return out;
  }
};

}  // namespace

std::unique_ptr<Engine> make_simbody_engine() {
  return std::make_unique<SimbodyEngine>();
}

}  // namespace crosslink::sim
