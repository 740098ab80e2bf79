// MuJoCo engine: builds the scene (scene.h), loads it from a virtual file system, steps it at
// the reference's times with the driver enforced every step, watches the loop gap, and reads
// positions, velocities and accelerations at the sampled steps.
#include "sim/mujoco/mujoco_engine.h"
#include "sim/run_loop.h"
#include "sim/sampling.h"
#include "sim/settings.h"
#include "sim/statuses.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "analytic/kinematics/newton.h"
#include "analytic/model/planar.h"
#include "sim/dynamics_run.h"
#include "sim/forces.h"
#include "sim/kinematic_run.h"
#include "sim/mujoco/scene.h"

namespace crosslink::sim {
namespace {

using mujoco_scene::MjcfOptions;
using mujoco_scene::Scene;
using mujoco_scene::SceneJoint;
using mujoco_scene::SceneLink;

// ---------------------------------------------------------------------------------------------
// MuJoCo's messages

// MuJoCo 2.2.2 reports through mju_warning and mju_error (engine_util_errmem.c): without user
// handlers a warning is printed on stdout (so `compare --json -` was no longer JSON) and appended
// to MUJOCO_LOG.TXT in the current folder, and an error does the same and exits the process.
// With handlers neither is written: a warning becomes a note of the run, an error an exception
// (MuJoCo's own XML loader throws from its handler in the same way). Once per mjData and
// warning type (mj_warning), so a run holds few; the same text is kept once with its count.
thread_local std::vector<std::pair<std::string, int>> t_warnings;

void on_warning(const char* message) {
  // A full constraint or contact buffer drops rows from the solve: the run is wrong, not noted.
  // The scene's <size> holds every row it can make (scene.cpp), so this is crosslink's error.
  if (std::string_view(message).starts_with("Pre-allocated"))
    throw std::runtime_error(fmt::format(
        "MuJoCo error: {} (crosslink sizes the scene's buffers from its equalities, <size> in "
        "the MJCF: this scene made more rows; docs/engines.md, \"Sizes\")",
        message));
  for (auto& [text, count] : t_warnings)
    if (text == message) {
      ++count;
      return;
    }
  t_warnings.emplace_back(message, 1);
}

[[noreturn]] void on_error(const char* message) {
  // The stack is sized by MuJoCo's own rule from the scene's rows (scene.cpp): say so.
  if (std::string_view(message) == "Stack overflow")
    throw std::runtime_error(
        "MuJoCo error: Stack overflow (its stack, mjModel.nstack, is sized by MuJoCo's rule "
        "from the scene's <size>; docs/engines.md, \"Sizes\")");
  throw std::runtime_error(std::string("MuJoCo error: ") + message);
}

// The handlers are installed once per process (MuJoCo's mju_user_* are process-wide, read by
// every thread's runs; the warnings they gather are the thread's own), the warnings gathered for
// the life of one run.
class MessageCapture {
 public:
  MessageCapture() {
    static std::once_flag once;
    std::call_once(once, [] {
      mju_user_warning = on_warning;
      mju_user_error = on_error;
    });
    t_warnings.clear();
  }
  MessageCapture(const MessageCapture&) = delete;
  MessageCapture& operator=(const MessageCapture&) = delete;
  ~MessageCapture() { t_warnings.clear(); }
  // The warnings so far as notes of `message`.
  static void note(std::string& message) {
    for (const auto& [text, count] : t_warnings)
      add_note(message, count > 1 ? fmt::format("MuJoCo warning ({} times): {}", count, text)
                                  : "MuJoCo warning: " + text);
    t_warnings.clear();
  }
};

// ---------------------------------------------------------------------------------------------
// Settings

const char* const kSolimp = "0.9999 0.9999 0.001 0.5 2";
// A cam's contact: an impedance of 0.5 lets the contact settle at a steady penetration (4 (1 - d)
// h^2 times the follower's unconstrained acceleration into the cam): nearer 1 the penetration
// vanishes and the contact flickers on and off, lower (0.3) and higher (0.6) its force alternates
// between 0 and twice its value from step to step (measured on eccentric_roller_spring.toml from
// 120 to 260 rpm, dt auto and halved; docs/cams.md, "The engines' contact").
const char* const kContactSolimp = "0.5 0.5 0.001 0.5 2";
// The conditioning limits below are fractions of the chain's own (the reference's median rcond,
// analytic/reference/trust.h), chosen to equal the absolute limits they replace on the bundled
// linkages: 1e-6 at a four-bar's 0.1, 1e-3 at IFToMM A02 N = 2's 0.033.
constexpr double kSingularRcond = 1e-5;
// Forward dynamics passes singular positions under its own momentum; within about 0.005 rad of
// one (IFToMM A02's change point: rcond 1.3e-4 and 3.7e-4) the soft constraint solve's
// acceleration is off by 2 to 8 % of its peak in the direction the chain gains there, at every
// step (measured; docs/engines.md, "Forward dynamics"), while from 6.7e-4 on it is within 1e-5:
// flagged below 1e-3 there, 0.03 of that chain's own conditioning (0.033).
constexpr double kDynamicsSingularRcond = 0.03;
// Periodic sweeps: steps run before the first sample and after the last. A cam's soft contact
// starts at the exact start's zero penetration and settles to the one its load holds over some
// tens of steps (docs/cams.md, "The engines' contact").
constexpr long kPreroll = 8, kContactPreroll = 64;
long preroll(const Mechanism& m) {
  return m.has_cam() ? kContactPreroll : kPreroll;
}
// A sample whose configuration, closed exactly on the definition, is further than this from the
// reference's (of the mechanism's size, or rad) is on another assembly mode: branch_jump. Closed
// configurations on the same branch agree to the Newton tolerance.
constexpr double kBranchDistance = 1e-4;

struct Config {
  std::string dt = "auto";
  double max_step_angle = 0.0025;
  std::string integrator = "Euler", solver = "Newton";
  int iterations = 20;
  double tolerance = 1e-10;
  std::string solref = "deadbeat", solimp = kSolimp;
  std::string driver_solref = "deadbeat", driver_solimp = kSolimp;
  std::string friction_solref = "auto";
  std::string contact_solref = "auto", contact_solimp = kContactSolimp;
  int cam_facets = kDefaultCamFacets;
  bool extrapolated_load = true;
  std::string gap_threshold = "auto", driver_threshold = "auto";
  std::string perturb_link = "none";
  std::string force_read = "centred";     // centred | raw (docs/engines.md, "Forces")
  std::optional<double> driver_armature;  // none: auto (driver_armature())
  long max_steps = kDefaultMaxSteps;
  // Forward dynamics only (docs/engines.md, "Forward dynamics").
  std::string start = "auto";      // staggered | exact; auto: staggered for Euler and implicit
  std::string readout = "auto";    // differences | state; auto: state for RK4
  double energy_threshold = 1e-3;  // |energy.error| over the energy scale: an event
  double divergence_energy = 1.0;  // beyond it the run stops: diverged
  // Samples whose configuration's constraint Jacobian (scaled as the Newton solver's) is worse
  // conditioned are flagged singular. auto: kSingularRcond for a kinematic run,
  // kDynamicsSingularRcond for a dynamics run.
  std::string singular_rcond = "auto";
};

// Every setting, its default and what it takes, and the values a run reports, in the order a run
// prints them (sim/settings.h; docs/engines.md, "MuJoCo").
const SettingSchema& mujoco_settings() {
  using enum SettingKind;
  using enum AppliesTo;
  static const SettingSchema schema = {
      {.name = "dt",
       .kind = number,
       .default_value = "auto",
       .doc = "time step [s]; auto: the longest dividing each sample interval within "
              "max_step_angle",
       .range = kPositive,
       .words = {"auto"}},
      {.name = "steps_per_sample",
       .doc = "the steps in the sample interval of the longest step",
       .reported = true},
      {.name = "max_step_angle",
       .kind = number,
       .default_value = "0.0025",
       .doc = "auto dt: the most the fastest link turns in a step [rad]",
       .range = kPositive},
      {.name = "integrator",
       .kind = choice,
       .default_value = "Euler",
       .doc = "MuJoCo's integrator",
       .words = {"Euler", "RK4", "implicit"}},
      {.name = "solver",
       .kind = choice,
       .default_value = "Newton",
       .doc = "MuJoCo's constraint solver",
       .words = {"Newton", "CG", "PGS"}},
      {.name = "iterations",
       .kind = count,
       .default_value = "20",
       .doc = "the solver's iterations per step",
       .most = kMostIterations},
      {.name = "tolerance",
       .kind = number,
       .default_value = "1e-10",
       .doc = "the solver's tolerance (0: every iteration runs)",
       .range = kNonNegative},
      {.name = "solref",
       .kind = text,
       .default_value = "deadbeat",
       .doc = "the loop constraints' solref",
       .allowed = "deadbeat (-1/dt^2, -1/dt), or timeconst dampratio (both > 0), or -stiffness "
                  "-damping (stiffness > 0, damping >= 0)"},
      {.name = "solimp",
       .kind = text,
       .default_value = kSolimp,
       .doc = "the loop constraints' solimp",
       .allowed = "dmin dmax width [midpoint [power]]: dmin, dmax in (0, 1), width > 0, "
                  "midpoint in [0, 1], power >= 1"},
      {.name = "driver_solref",
       .kind = text,
       .default_value = "deadbeat",
       .doc = "the driver's solref",
       .allowed = "deadbeat (-1/dt^2, -1/dt), or timeconst dampratio (both > 0), or -stiffness "
                  "-damping (stiffness > 0, damping >= 0)",
       .applies_to = kinematic},
      {.name = "driver_solimp",
       .kind = text,
       .default_value = kSolimp,
       .doc = "the driver's solimp",
       .allowed = "dmin dmax width [midpoint [power]]: dmin, dmax in (0, 1), width > 0, "
                  "midpoint in [0, 1], power >= 1",
       .applies_to = kinematic},
      shared_setting("friction_load"),
      {.name = "friction_solref",
       .kind = text,
       .default_value = "auto",
       .doc = "joint friction's solreffriction (its frictionloss rows; MuJoCo's own default is "
              "0.02 1)",
       .allowed = "auto (2 dt, 1), or timeconst dampratio (both > 0), or -stiffness -damping "
                  "(stiffness > 0, damping >= 0)",
       .friction = true},
      {.name = "contact_solref",
       .kind = text,
       .default_value = "auto",
       .doc = "a cam's contact pair's solref",
       .allowed = "auto (2 dt, 1), or timeconst dampratio (both > 0), or -stiffness -damping "
                  "(stiffness > 0, damping >= 0)",
       .contact = true},
      {.name = "contact_solimp",
       .kind = text,
       .default_value = kContactSolimp,
       .doc = "a cam's contact pair's solimp",
       .allowed = "dmin dmax width [midpoint [power]]: dmin, dmax in (0, 1), width > 0, "
                  "midpoint in [0, 1], power >= 1",
       .contact = true},
      shared_setting("cam_facets"),
      {.name = "driver_armature",
       .kind = number,
       .default_value = "auto",
       .doc = "armature of the driven joint; auto: 1e-2 of the inertia it moves",
       .range = kNonNegative,
       .words = {"auto"},
       .applies_to = kinematic},
      {.name = "gap_threshold",
       .kind = number,
       .default_value = "auto",
       .doc = "a larger cut gap [m] since the previous sample flags loop_gap; auto: 1e-4 x size",
       .range = kPositive,
       .words = {"auto"}},
      {.name = "driver_threshold",
       .kind = number,
       .default_value = "auto",
       .doc = "a driven joint further from its target [rad or m] is lost; auto: 1e-3 rad (1e-3 "
              "x size for a slider)",
       .range = kPositive,
       .words = {"auto"},
       .applies_to = kinematic},
      {.name = "singular_rcond",
       .kind = number,
       .default_value = "auto",
       .doc = "samples conditioned worse than this fraction of the chain's own are singular; "
              "auto: 1e-5 (dynamics 0.03)",
       .range = kRcond,
       .words = {"auto"}},
      shared_setting("perturb_link"),
      shared_setting("mass_model"),
      {.name = "force_read",
       .kind = choice,
       .default_value = "centred",
       .doc = "forces at the sampled pose's velocity, or efc_force as solved",
       .words = {"centred", "raw"}},
      {.name = "derivatives",
       .doc = "how rates are read from the step positions",
       .applies_to = kinematic,
       .reported = true},
      shared_setting("driver"),
      {.name = "start",
       .kind = choice,
       .default_value = "auto",
       .doc = "forward dynamics: staggered (v0 - h/2 a0) or exact start; auto: staggered for "
              "Euler and implicit",
       .words = {"auto", "staggered", "exact"},
       .applies_to = dynamics},
      {.name = "readout",
       .kind = choice,
       .default_value = "auto",
       .doc = "forward dynamics: rates from position differences or the state; auto: state for "
              "RK4",
       .words = {"auto", "differences", "state"},
       .applies_to = dynamics},
      {.name = "energy_threshold",
       .kind = number,
       .default_value = "0.001",
       .doc = "forward dynamics: an energy error over the energy scale beyond it is an event",
       .range = kPositive,
       .applies_to = dynamics},
      shared_setting("divergence_energy"),
      shared_setting("energy_scale"),
      shared_setting("max_steps"),
  };
  return schema;
}

// singular_rcond in force: the setting, or with auto the run's own default.
double singular_rcond(const Config& c, double automatic) {
  return c.singular_rcond == "auto" ? automatic
                                    : setting_number("singular_rcond", c.singular_rcond);
}

Config parse_settings(const Settings& overrides) {
  const SettingValues v(mujoco_settings(), "MuJoCo", overrides);
  Config c;
  for (auto [name, field] : {std::pair{"dt", &c.dt},
                             {"integrator", &c.integrator},
                             {"solver", &c.solver},
                             {"solref", &c.solref},
                             {"solimp", &c.solimp},
                             {"driver_solref", &c.driver_solref},
                             {"driver_solimp", &c.driver_solimp},
                             {"friction_solref", &c.friction_solref},
                             {"contact_solref", &c.contact_solref},
                             {"contact_solimp", &c.contact_solimp},
                             {"gap_threshold", &c.gap_threshold},
                             {"driver_threshold", &c.driver_threshold},
                             {"perturb_link", &c.perturb_link},
                             {"force_read", &c.force_read},
                             {"start", &c.start},
                             {"readout", &c.readout},
                             {"singular_rcond", &c.singular_rcond}})
    *field = v.text(name);
  c.max_step_angle = v.number("max_step_angle");
  c.iterations = static_cast<int>(v.count("iterations"));
  c.tolerance = v.number("tolerance");
  c.extrapolated_load = v.is("friction_load", "extrapolated");
  if (!v.is("driver_armature", "auto")) c.driver_armature = v.number("driver_armature");
  c.max_steps = v.count("max_steps");
  c.cam_facets = static_cast<int>(v.count("cam_facets"));
  c.energy_threshold = v.number("energy_threshold");
  c.divergence_energy = v.number("divergence_energy");
  return c;
}

// MuJoCo's two formats (its modeling guide, "Solver parameters"): (timeconst, dampratio), both
// positive, or the direct (-stiffness, -damping), negative. A 0 is neither (and a loop without
// stiffness never pulls its gap back), a negative damping feeds the gap: both refused, as are the
// formats mixed, which MuJoCo tells apart by the first number's sign alone.
Eigen::Vector2d solref_of(const std::string& name, const std::string& text, double dt) {
  if (text == "deadbeat") return {-1.0 / (dt * dt), -1.0 / dt};
  const std::vector<double> v = setting_numbers(name, text);
  const char* why = nullptr;
  if (v.size() != 2)
    why = "2 numbers";
  else if (v[0] > 0.0 && !(v[1] > 0.0))
    why = "a positive dampratio after a positive timeconst";
  else if (v[0] == 0.0)
    why = "a timeconst > 0, or a stiffness > 0 (-stiffness < 0)";
  else if (v[0] < 0.0 && v[1] > 0.0)
    why = "a damping >= 0 (-damping <= 0) after a negative -stiffness";
  if (why)
    throw std::runtime_error(fmt::format(
        "setting {} = \"{}\": expected {} (MuJoCo's solref: timeconst dampratio, both positive, "
        "or -stiffness -damping, stiffness > 0 and damping >= 0; or deadbeat)",
        name, text, why));
  return {v[0], v[1]};
}

// The frictionloss rows' and the cams' contact pairs' solref. auto: a time constant of two steps,
// critically damped, the stiffest MuJoCo honours (with mjENBL_REFSAFE a shorter one is raised to
// it): for friction the least creep and error (docs/engines.md, "Joint friction"), for a contact
// the least penetration without bounce (docs/cams.md, "The engines' contact"); no deadbeat (its
// step's, which the rows would not follow).
Eigen::Vector2d two_step_solref(const std::string& name, const std::string& text, double dt) {
  if (text == "auto") return {2.0 * dt, 1.0};
  if (text == "deadbeat")
    throw std::runtime_error(fmt::format(
        "setting {} = \"deadbeat\": expected timeconst dampratio or -stiffness -damping", name));
  return solref_of(name, text, 1.0);
}

// MuJoCo's (dmin, dmax, width, midpoint, power), its defaults after the numbers given: the
// impedances d lie in (0, 1) (MuJoCo clamps them to [1e-4, 0.9999] silently), the width of the
// violation over which d moves is positive, the midpoint is in [0, 1] and the power 1 or more.
Eigen::Matrix<double, 5, 1> solimp_of(const std::string& name, const std::string& text) {
  std::vector<double> v = setting_numbers(name, text);
  const std::array<double, 5> defaults = {0.9, 0.95, 0.001, 0.5, 2.0};  // MuJoCo's
  const char* why = nullptr;
  const bool counted = v.size() >= 3 && v.size() <= 5;
  for (size_t i = v.size(); counted && i < 5; ++i) v.push_back(defaults[i]);
  if (!counted)
    why = "3 to 5 numbers";
  else if (!(v[0] > 0.0 && v[0] < 1.0))
    why = "dmin (the 1st) in (0, 1)";
  else if (!(v[1] > 0.0 && v[1] < 1.0))
    why = "dmax (the 2nd) in (0, 1)";
  else if (!(v[2] > 0.0))
    why = "a positive width (the 3rd)";
  else if (!(v[3] >= 0.0 && v[3] <= 1.0))
    why = "midpoint (the 4th) in [0, 1]";
  else if (!(v[4] >= 1.0))
    why = "power (the 5th) 1 or more";
  if (why)
    throw std::runtime_error(fmt::format(
        "setting {} = \"{}\": expected {} (MuJoCo's solimp: dmin dmax width [midpoint [power]])",
        name, text, why));
  return Eigen::Map<const Eigen::Matrix<double, 5, 1>>(v.data());
}

// ---------------------------------------------------------------------------------------------
// The starting configuration and the time grid

// Absolute coordinates and their rates at the reference's first usable sample, solved exactly.
struct Start {
  Eigen::VectorXd q, qdot;
};

// At the reference's sample `first`; nullopt when the chain does not close there on a
// well-conditioned pose.
std::optional<Start> exact_start(const Mechanism& m, const Trajectory& reference, int first) {
  KinematicState state(m);
  state.q = reference_coordinates(m, reference, first);
  reference_drivers(m, reference, first, state);
  const NewtonSolver solver(m);
  const SolveReport report = solver.solve(state);
  if (report.status != PoseStatus::ok) return std::nullopt;
  return Start{state.q, state.qdot};
}

// The longest step: dt, or with dt auto the step in which the reference's fastest link turns by
// max_step_angle (errors grow as (omega dt)^2): step_length's rule.
double wanted_step(const Trajectory& reference, const Config& c, const Span& span) {
  const double dt = c.dt != "auto" ? setting_number("dt", c.dt, kPositive) : 0.0;
  return step_length(reference, span, dt, c.max_step_angle, 0);
}

MjcfOptions mjcf_options(const Mechanism& m, const Config& c, double dt) {
  MjcfOptions o;
  o.dt = dt;
  o.integrator = c.integrator;
  o.solver = c.solver;
  o.iterations = c.iterations;
  o.tolerance = c.tolerance;
  o.solref = solref_of("solref", c.solref, dt);
  o.solimp = solimp_of("solimp", c.solimp);
  o.driver_solref = solref_of("driver_solref", c.driver_solref, dt);
  o.driver_solimp = solimp_of("driver_solimp", c.driver_solimp);
  o.friction_solref = two_step_solref("friction_solref", c.friction_solref, dt);
  o.contact_solref = two_step_solref("contact_solref", c.contact_solref, dt);
  o.contact_solimp = solimp_of("contact_solimp", c.contact_solimp);
  o.gravity = m.gravity;
  return o;
}

// The rotor inertia the driven joint gets. MuJoCo keeps 1 - dmax = 1e-4 of softness in every
// equality row, scaled by the row's inverse inertia: a driven joint that is light against what
// it drives (Khurmi's massless crank on a 250 kg piston: 6e-6 against 22 kg m^2) gives way, and
// the driver is lost. auto: whatever tops the joint's own inertia up to 1e-2 of `inertia` (the
// generalised inertia the driver moves, driver_inertia()); the readers take the armature's share
// back out of the effort. A tendon driver has no armature in 2.2.2. Several drivers: each driven
// joint by the same rule, `inertia` the one its driver moves with the others held.
double driver_armature(const Config& c, const Scene& s, const DrivenCoordinate& driven,
                       double inertia) {
  if (c.driver_armature) return *c.driver_armature * s.mass_scale;
  inertia *= s.mass_scale;
  if (driven.joint < 0 || driven.floating) return 0.0;
  const SceneJoint& j = s.joints[static_cast<size_t>(driven.joint)];
  const SceneLink& child = s.links[static_cast<size_t>(j.child)];
  const Eigen::Vector2d at = j.child == j.b ? j.ub : j.ua;
  const double own = j.kind == SceneJoint::Kind::hinge
                         ? child.inertia + child.mass * (child.centre - at).squaredNorm()
                         : child.mass;
  return std::max(0.0, 1e-2 * inertia - own);
}

// ---------------------------------------------------------------------------------------------
// MuJoCo model and data

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// Loads MJCF text through a virtual file system (no file on disk).
ModelPtr load_model(const std::string& xml) {
  auto vfs = std::make_unique<mjVFS>();  // about 2 MB: on the heap
  mj_defaultVFS(vfs.get());
  const char* name = "crosslink.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), name, static_cast<int>(xml.size())) != 0)
    throw std::runtime_error("MuJoCo: could not create the virtual file");
  const int file = mj_findFileVFS(vfs.get(), name);
  std::memcpy(vfs->filedata[file], xml.data(), xml.size());
  std::array<char, 1000> error{};
  mjModel* model = mj_loadXML(name, vfs.get(), error.data(), static_cast<int>(error.size()));
  mj_deleteVFS(vfs.get());
  if (!model)
    throw std::runtime_error(fmt::format("MuJoCo could not load the scene: {}", error.data()));
  return ModelPtr(model);
}

// Value (qpos) of a scene joint and its rate, from the mechanism's absolute coordinates.
Eigen::Vector2d joint_motion(const Mechanism& m, const Scene& s, const SceneJoint& j,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) {
  const BodyMotion a = body_motion(m, s.links[j.a], q, &qdot),
                   b = body_motion(m, s.links[j.b], q, &qdot);
  if (j.kind == SceneJoint::Kind::hinge) return {b.theta - a.theta, b.omega - a.omega};
  const Projection p = project(a, j.origin, j.direction, b, j.ub);
  return {p.value, p.rate};
}

// Everything a run and mujoco_mjcf share: settings, start, grid, scene, MJCF.
struct Prepared {
  Config config;
  Span span;
  Start start;
  TimeGrid grid;
  Scene scene;
  MjcfOptions options;
  std::string mjcf;
  bool periodic = false;  // the run covers whole cycles (a pre-roll on each side)
  KinematicPlan plan;     // a kinematic run's (span, grid and start as above)
  DynamicsPlan dynamics;  // a dynamics run's
};

Prepared prepare(const Mechanism& m, const Trajectory& reference, const Settings& overrides) {
  Prepared p;
  p.config = parse_settings(overrides);
  const Mechanism scene_mechanism = perturbed(m, p.config.perturb_link);
  p.span = usable_span(reference);
  p.plan = plan_kinematic(scene_mechanism, reference, wanted_step(reference, p.config, p.span),
                          InnerTimes::step_multiples, preroll(m), p.config.max_steps,
                          singular_rcond(p.config, kSingularRcond),
                          !p.config.perturb_link.empty() && p.config.perturb_link != "none");
  p.grid = p.plan.grid;
  p.start = Start{p.plan.q, p.plan.qdot};
  p.periodic = p.plan.preroll > 0;
  p.scene = mujoco_scene::build_scene(scene_mechanism, p.start.q, p.config.cam_facets);
  p.options = mjcf_options(m, p.config, p.grid.dt);
  for (size_t d = 0; d < p.scene.driven.size(); ++d)
    p.options.driver_armature.push_back(driver_armature(
        p.config, p.scene, p.scene.driven[d], driver_inertia(m, reference, static_cast<int>(d))));
  p.mjcf = mujoco_scene::to_mjcf(m, p.scene, p.options);
  return p;
}

std::string numbers(const Eigen::VectorXd& v) {
  std::string text;
  for (Eigen::Index i = 0; i < v.size(); ++i) text += fmt::format("{}{:.6g}", i ? " " : "", v(i));
  return text;
}

// ---------------------------------------------------------------------------------------------
// Stepping and sampling

// Poses (x, y, theta per moving link, Mechanism order) at one step: body origins from MuJoCo,
// angles unwrapped against the previous step so they stay continuous like the reference's.
class PoseReader {
 public:
  PoseReader(const Mechanism& m, const Scene& s, const mjModel* model, const Eigen::VectorXd& q0)
      : last_(q0) {
    for (size_t l = 0; l < s.links.size(); ++l)
      if (s.links[l].source >= 0 && !s.links[l].ground)
        bodies_.push_back({m.moving_index(s.links[l].source),
                           mj_name2id(model, mjOBJ_BODY, s.links[l].name.c_str())});
  }
  const Eigen::VectorXd& read(const mjData* d) {
    for (const auto& [k, body] : bodies_) {
      const mjtNum* mat = d->xmat + 9 * body;
      const double raw = std::atan2(mat[3], mat[0]);
      last_(3 * k) = d->xpos[3 * body];
      last_(3 * k + 1) = d->xpos[3 * body + 1];
      last_(3 * k + 2) += std::remainder(raw - last_(3 * k + 2), 2.0 * std::numbers::pi);
    }
    return last_;
  }

 private:
  Eigen::VectorXd last_;
  std::vector<std::pair<int, int>> bodies_;  // (moving index, MuJoCo body id)
};

// ---------------------------------------------------------------------------------------------
// Reading forces

// A friction joint's frictionloss: on its degree of freedom (a tree joint), or on the fixed
// tendon over its relative rotation (a loop's cut pin); its row's type and id, its coordinate's
// terms over qpos, and the Mechanism joint.
struct FrictionRow {
  bool tendon = false;
  int id = -1;                               // the dof, or the tendon
  std::vector<std::pair<int, double>> qpos;  // (qpos address, coefficient)
  int joint = -1;
  // Its bound for the next step [in the scene's unit of mass].
  void bound(mjModel* mm, double value) const {
    (tendon ? mm->tendon_frictionloss : mm->dof_frictionloss)[id] = value;
  }
  // Its row's force in `d` (0 when its bound was 0: no row), in the scene's unit of mass.
  double force(const mjData* d) const {
    const int type = tendon ? mjCNSTR_FRICTION_TENDON : mjCNSTR_FRICTION_DOF;
    for (int r = d->ne; r < d->nefc; ++r)
      if (d->efc_type[r] == type && d->efc_id[r] == id) return d->efc_force[r];
    return 0.0;
  }
  // Its coordinate's change from `before` to d's qpos.
  double moved(const mjData* d, const std::vector<mjtNum>& before) const {
    double change = 0.0;
    for (const auto& [at, coefficient] : qpos)
      change += coefficient * (d->qpos[at] - before[static_cast<size_t>(at)]);
    return change;
  }
};
FrictionRow friction_row(const mjModel* mm, const SceneJoint& j) {
  FrictionRow f;
  f.joint = j.source;
  f.tendon = !j.friction_terms.empty();
  if (!f.tendon) {
    const int joint = mj_name2id(mm, mjOBJ_JOINT, j.name.c_str());
    f.id = mm->jnt_dofadr[joint];
    f.qpos = {{mm->jnt_qposadr[joint], 1.0}};
    return f;
  }
  f.id = mj_name2id(mm, mjOBJ_TENDON, j.friction_tendon().c_str());
  for (int w = mm->tendon_adr[f.id]; w < mm->tendon_adr[f.id] + mm->tendon_num[f.id]; ++w)
    f.qpos.emplace_back(mm->jnt_qposadr[mm->wrap_objid[w]], mm->wrap_prm[w]);
  return f;
}

// The constraint forces of the pose a step leaves, in the mechanism's terms. mj_step (Euler)
// solves the constraints at (q_k, v_k-1/2): its qacc is the second difference of the poses
// k-1, k, k+1 (centred on pose k), but the velocity terms of the equations of motion (the tree's
// Coriolis and centrifugal forces in qfrc_bias) are taken at the mid-step velocity half a step
// behind, an O(dt) error in every force ("raw"). "centred" evaluates qfrc_bias again at
// v_k = v_k+1/2 - dt/2 qacc and adds the equality forces that balance the difference at the same
// qacc, J^T df = qfrc_bias(v_k) - qfrc_bias(v_k-1/2): MuJoCo's forces at the pose's own velocity,
// O(dt^2). Equality rows (efc_type mjCNSTR_EQUALITY, efc_id the equality) give the driver's
// effort and the cut joints' forces (a connect's force acts on body1, minus on body2); the tree
// joints' reactions are cfrc_int from mj_rnePostConstraint on a scratch mjData at the pose
// (2.2.2 includes connect forces in cfrc_ext: engine_core_smooth.c).
class ForceReader {
 public:
  ForceReader(const Mechanism& m, const Scene& s, const mjModel* mm, bool centred)
      : m_(m), s_(s), mm_(mm), centred_(centred), scratch_(mj_makeData(mm)) {
    auto body = [&](int link) {
      return s.links[link].ground ? 0 : mj_name2id(mm, mjOBJ_BODY, s.links[link].name.c_str());
    };
    for (size_t l = 0; l < s.links.size(); ++l) body_.push_back(body(static_cast<int>(l)));
    for (size_t d = 0; d < s.driven.size(); ++d) {
      driver_eq_.push_back(mj_name2id(mm, mjOBJ_EQUALITY, s.driver_names[d].c_str()));
      driven_dof_.push_back(-1);
      if (driver_eq_.back() >= 0 && !s.driven[d].floating) {
        const int joint = mj_name2id(mm, mjOBJ_JOINT, s.joints[s.driven[d].joint].name.c_str());
        driven_dof_.back() = mm->jnt_dofadr[joint];
      }
    }
    for (const SceneJoint& j : s.joints)
      cut_eq_.push_back(j.in_tree ? -1 : mj_name2id(mm, mjOBJ_EQUALITY, j.name.c_str()));
    for (const SceneCoupling& c : s.couplings)
      coupling_eq_.push_back(
          mj_name2id(mm, mjOBJ_EQUALITY, m.joints[static_cast<size_t>(c.source)].name.c_str()));
    for (const SceneArc& a : s.arcs)
      arc_eq_.push_back(
          mj_name2id(mm, mjOBJ_EQUALITY, m.joints[static_cast<size_t>(a.source)].name.c_str()));
    for (const SceneJoint& j : s.joints)
      if (j.friction) friction_rows_.push_back(friction_row(mm, j));
    for (const SceneContact& c : s.contacts)
      contact_geoms_.emplace_back(
          mj_name2id(mm, mjOBJ_GEOM, mujoco_scene::contact_geom(m, c, true).c_str()),
          mj_name2id(mm, mjOBJ_GEOM, mujoco_scene::contact_geom(m, c, false).c_str()));
  }

  // `d` right after mj_step from pose k (its forward data: efc_*, qacc, qfrc_bias, xfrc_applied);
  // qpos_k the positions of pose k; h the step's length.
  void read(const mjData* d, const std::vector<mjtNum>& qpos_k, double h, ForceReading& out) {
    const int nv = mm_->nv, ne = d->ne;
    mjData* d2 = scratch_.get();
    std::copy(qpos_k.begin(), qpos_k.end(), d2->qpos);
    const double back = centred_ ? 0.5 * h : h;
    for (int i = 0; i < nv; ++i) d2->qvel[i] = d->qvel[i] - back * d->qacc[i];
    std::copy(d->xfrc_applied, d->xfrc_applied + 6 * mm_->nbody, d2->xfrc_applied);
    mj_fwdPosition(mm_, d2);
    mj_fwdVelocity(mm_, d2);
    if (d2->ne != ne || d2->nefc != d->nefc)
      throw std::runtime_error("MuJoCo: the constraint rows changed between step and read");
    std::copy(d->efc_force, d->efc_force + d->nefc, d2->efc_force);
    // The rows that hold the pose at any velocity: the equalities, and a cam's contact while it
    // pushes (a frictionless contact's one row). No such row (forward dynamics of an open chain:
    // no driver equality, no cut joint, IFToMM A01's pendulum): nothing to centre, and Eigen's
    // decomposition of an nv x 0 matrix reads out of bounds.
    std::vector<int> held;
    for (int r = 0; r < d->nefc; ++r)
      if (r < ne || d->efc_type[r] == mjCNSTR_CONTACT_FRICTIONLESS) held.push_back(r);
    if (centred_ && !held.empty()) {
      using RowMajor = Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      const Eigen::Map<const RowMajor> all(d->efc_J, d->nefc, nv);
      const RowMajor jacobian = all(held, Eigen::all);  // row-major as efc_J: the same solve
      const Eigen::VectorXd bias = Eigen::Map<const Eigen::VectorXd>(d2->qfrc_bias, nv) -
                                   Eigen::Map<const Eigen::VectorXd>(d->qfrc_bias, nv);
      // Least squares: a connect's z row is zero in a planar scene.
      const Eigen::VectorXd change =
          jacobian.transpose().completeOrthogonalDecomposition().solve(bias);
      for (size_t i = 0; i < held.size(); ++i)
        d2->efc_force[held[i]] += change(static_cast<Eigen::Index>(i));
    }
    const Eigen::VectorXd force = Eigen::Map<const Eigen::VectorXd>(d2->efc_force, ne);
    std::copy(d->qacc, d->qacc + nv, d2->qacc);
    rne_post_constraint(d2, force);
    extract(d2, force, out);
  }

  // MuJoCo's own forces at the state of `forwarded`, on which mj_forward has just run (its
  // constraint forces and accelerations at its positions and velocities).
  void read_state(mjData* forwarded, ForceReading& out) {
    const Eigen::VectorXd force =
        Eigen::Map<const Eigen::VectorXd>(forwarded->efc_force, forwarded->ne);
    rne_post_constraint(forwarded, force);
    extract(forwarded, force, out);
  }

 private:
  int row_of(const mjData* d, int eq) const {
    for (int r = 0; r < d->ne; ++r)
      if (d->efc_type[r] == mjCNSTR_EQUALITY && d->efc_id[r] == eq) return r;
    throw std::runtime_error("MuJoCo: no constraint row for an equality");
  }

  // Curved slot k's force on its pin, from the equality forces: its tendon's force f pulls the
  // pin towards the arc's centre (the length |P - C| grows along u = (P - C) / |P - C|, so J^T f
  // is f u at P and -f u at C).
  Eigen::Vector2d arc_force(const mjData* d, const Eigen::VectorXd& force, size_t k) const {
    const SceneArc& a = s_.arcs[k];
    const Eigen::Vector2d u =
        (world_point(d, a.pin, a.point) - world_point(d, a.guide, a.centre)).normalized();
    return force(row_of(d, arc_eq_[k])) * u;
  }

  // mj_rnePostConstraint (cfrc_int) with the curved slots' tendon forces counted on the bodies:
  // MuJoCo counts a connect's and a contact's there, not a tendon's, which would be read as the
  // tree joints' instead. Each goes in as an applied force at its sites for the call.
  void rne_post_constraint(mjData* d, const Eigen::VectorXd& force) const {
    if (arc_eq_.empty()) {
      mj_rnePostConstraint(mm_, d);
      return;
    }
    const std::vector<mjtNum> applied(d->xfrc_applied, d->xfrc_applied + 6 * mm_->nbody);
    const auto push = [&](int link, const Eigen::Vector2d& local, const Eigen::Vector2d& f) {
      const int body = body_[static_cast<size_t>(link)];
      if (body == 0) return;  // the world's is read by no joint
      const Eigen::Vector2d com(d->xipos[3 * body], d->xipos[3 * body + 1]);
      mjtNum* x = d->xfrc_applied + 6 * body;  // force, then torque about the centre of mass
      x[0] += f.x();
      x[1] += f.y();
      x[5] += cross2(world_point(d, link, local) - com, f);
    };
    for (size_t k = 0; k < arc_eq_.size(); ++k) {
      const Eigen::Vector2d on_pin = arc_force(d, force, k);
      push(s_.arcs[k].pin, s_.arcs[k].point, on_pin);
      push(s_.arcs[k].guide, s_.arcs[k].centre, -on_pin);
    }
    mj_rnePostConstraint(mm_, d);
    std::copy(applied.begin(), applied.end(), d->xfrc_applied);
  }

  // The reading from d2 (constraint rows, and cfrc_int after mj_rnePostConstraint) with the
  // equality forces `force`. Without a driver equality (forward dynamics) the effort is left at
  // zero: it is an applied load there, not a reaction.
  void extract(const mjData* d2, const Eigen::VectorXd& force, ForceReading& out) const {
    out.set_zero();
    const auto row_of = [&](int eq) { return this->row_of(d2, eq); };
    for (size_t d = 0; d < driver_eq_.size(); ++d) {
      if (driver_eq_[d] < 0) continue;
      // The driver moves the driven joint's armature too (driver_armature): its share, the
      // armature times the joint's acceleration, is not the linkage's.
      double on_joint = force(row_of(driver_eq_[d]));
      const int dof = driven_dof_[d];
      if (dof >= 0) on_joint -= mm_->dof_armature[dof] * d2->qacc[dof];
      out.effort_of(static_cast<int>(d)) = s_.driven[d].sign * on_joint;
    }
    for (size_t ji = 0; ji < s_.joints.size(); ++ji) {
      const SceneJoint& j = s_.joints[ji];
      if (j.block_guide) continue;  // a slot's force is its pin's
      Eigen::Vector2d on_b;
      double couple_b = 0.0;
      Eigen::Vector2d about = Eigen::Vector2d::Zero();
      if (!j.in_tree) {
        const int r = row_of(cut_eq_[ji]);
        on_b = -Eigen::Vector2d(force(r), force(r + 1));  // the connect's force is on a
      } else {
        // cfrc_int: the parent's wrench on the child's subtree, torque about its root's subtree
        // centre of mass.
        const int child = body_[static_cast<size_t>(j.child)];
        const mjtNum* w = d2->cfrc_int + 6 * child;
        const double sign = j.child == j.b ? 1.0 : -1.0;
        on_b = sign * Eigen::Vector2d(w[3], w[4]);
        couple_b = sign * w[2];
        const mjtNum* c = d2->subtree_com + 3 * mm_->body_rootid[child];
        about = Eigen::Vector2d(c[0], c[1]);
      }
      if (j.kind == SceneJoint::Kind::slide) {
        const Eigen::Vector2d at = world_point(d2, j.b, j.ub);
        out.couple[static_cast<size_t>(j.source)] = couple_b + cross2(about - at, on_b);
      }
      for (size_t d = 0; d < driver_eq_.size(); ++d)
        if (driver_eq_[d] >= 0 && m_.drivers[d].type == DriverType::slider &&
            j.source == m_.drivers[d].joint) {
          // The driver's axial force is the effort, not the joint's reaction.
          const Eigen::Vector2d u = world_direction(d2, j.a, j.direction);
          on_b -= out.effort_of(static_cast<int>(d)) * u;
        }
      out.joint_force[static_cast<size_t>(j.source)] = on_b;
    }
    // A coupling's tendon force f acts on each of its joints as coefficient x f: the couple on
    // its first moving gear, and on a rack's slide a push along the line, which cfrc_int counts
    // in the slide's force and the exact method does not.
    for (size_t c = 0; c < s_.couplings.size(); ++c) {
      const SceneCoupling& coupling = s_.couplings[c];
      const double f = force(row_of(coupling_eq_[c]));
      out.gear_couple[static_cast<size_t>(coupling.source)] = coupling.on_first * f;
      if (coupling.slide < 0) continue;
      const SceneJoint& slide = s_.joints[static_cast<size_t>(coupling.slide)];
      out.joint_force[static_cast<size_t>(slide.source)] -=
          f * world_direction(d2, slide.a, slide.direction);
    }
    // A curved slot's: its tendon's pull on the pin.
    for (size_t k = 0; k < s_.arcs.size(); ++k)
      out.joint_force[static_cast<size_t>(s_.arcs[k].source)] = arc_force(d2, force, k);
    // A cam's contact: its normal force, along the contact frame's normal from geom1 to geom2, on
    // geom2's body (mj_rnePostConstraint); none while the spheres are apart.
    for (size_t c = 0; c < contact_geoms_.size(); ++c) {
      const auto [on_cam, on_follower] = contact_geoms_[c];
      for (int i = 0; i < d2->ncon; ++i) {
        const mjContact& con = d2->contact[i];
        const double sign = con.geom2 == on_follower && con.geom1 == on_cam   ? 1.0
                            : con.geom1 == on_follower && con.geom2 == on_cam ? -1.0
                                                                              : 0.0;
        if (sign == 0.0 || con.efc_address < 0) continue;
        mjtNum f[6];
        mj_contactForce(mm_, d2, i, f);
        out.joint_force[static_cast<size_t>(s_.contacts[c].source)] +=
            sign * f[0] * Eigen::Vector2d(con.frame[0], con.frame[1]);
      }
    }
    // Friction loss: its row's force along the joint's coordinate, which runs from a to b.
    for (const FrictionRow& f : friction_rows_)
      out.friction[static_cast<size_t>(f.joint)] = f.force(d2);
    // Back from the scene's unit of mass (Scene::mass_scale).
    for (double& f : out.friction) f /= s_.mass_scale;
    out.effort /= s_.mass_scale;
    for (double& e : out.other_efforts) e /= s_.mass_scale;
    for (Eigen::Vector2d& f : out.joint_force) f /= s_.mass_scale;
    for (double& c : out.couple) c /= s_.mass_scale;
    for (double& c : out.gear_couple) c /= s_.mass_scale;
  }

  static double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() * b.y() - a.y() * b.x();
  }
  Eigen::Vector2d world_direction(const mjData* d, int link, const Eigen::Vector2d& local) const {
    const mjtNum* r = d->xmat + 9 * body_[static_cast<size_t>(link)];
    return {r[0] * local.x() + r[1] * local.y(), r[3] * local.x() + r[4] * local.y()};
  }
  Eigen::Vector2d world_point(const mjData* d, int link, const Eigen::Vector2d& local) const {
    const mjtNum* p = d->xpos + 3 * body_[static_cast<size_t>(link)];
    return Eigen::Vector2d(p[0], p[1]) + world_direction(d, link, local);
  }

  const Mechanism& m_;
  const Scene& s_;
  const mjModel* mm_;
  bool centred_;
  DataPtr scratch_;
  std::vector<int> body_;         // per scene link: MuJoCo body id (world 0)
  std::vector<int> cut_eq_;       // per scene joint: its connect equality, -1 in the tree
  std::vector<int> coupling_eq_;  // per coupling: its tendon equality
  std::vector<int> arc_eq_;       // per curved slot: its tendon equality
  std::vector<int> driver_eq_;    // per driver: its equality (-1: none, forward dynamics)
  std::vector<int> driven_dof_;   // per driver: the driven tree joint's degree of freedom (-1: a
                                  // tendon driver)
  std::vector<FrictionRow> friction_rows_;          // per joint with friction
  std::vector<std::pair<int, int>> contact_geoms_;  // per contact: its geoms on cam and follower
};

// The forward evaluations one mj_step makes with `integrator` (MuJoCo 2.2's mj_step in
// engine_forward.c: one mj_forward, then Euler and implicit advance from it, while
// mj_RungeKutta(m, d, 4) evaluates three more stages with mj_forwardSkip).
long stages_per_step(const std::string& integrator) {
  return integrator == "RK4" ? 4 : 1;
}

// ---------------------------------------------------------------------------------------------
// Forward dynamics (a [dynamics] case; docs/engines.md, "Forward dynamics")

// The integrator-dependent choices of a dynamics run, resolved from the settings.
struct DynamicsChoices {
  // Euler and implicit keep the velocity half a step behind the positions (q_k+1 = q_k +
  // h v_k+1): started from v0 - h/2 a0 ("staggered", the leapfrog start) they are centred;
  // started from v0 ("exact") every later position lags by h/2 v0-ish, a first-order offset.
  bool staggered = true;
  // Samples from central differences of the poses on either side ("differences", second order;
  // for Euler they equal MuJoCo's own averaged velocity and its step's acceleration), or from
  // MuJoCo's state at the sample (positions and velocities as integrated, the acceleration and
  // forces of mj_forward there: "state", for RK4 whose velocity is not staggered).
  bool state_readout = false;
};

DynamicsChoices dynamics_choices(const Config& c) {
  const bool rk4 = c.integrator == "RK4";
  DynamicsChoices out;
  out.staggered = c.start == "auto" ? !rk4 : c.start == "staggered";
  out.state_readout = c.readout == "auto" ? rk4 : c.readout == "state";
  return out;
}

Prepared prepare_dynamics(const Mechanism& m, const Trajectory& reference,
                          const Settings& overrides) {
  Prepared p;
  p.config = parse_settings(overrides);
  const bool perturb = p.config.perturb_link != "none" && !p.config.perturb_link.empty();
  const Mechanism scene_mechanism = perturbed(m, p.config.perturb_link);
  p.span = usable_span(reference);
  p.dynamics =
      plan_dynamics(m, scene_mechanism, reference, wanted_step(reference, p.config, p.span),
                    InnerTimes::step_multiples, p.config.max_steps, perturb);
  p.grid = p.dynamics.grid;
  p.start = Start{p.dynamics.start.q, p.dynamics.start.qdot};
  p.scene = mujoco_scene::build_scene(scene_mechanism, p.start.q, p.config.cam_facets);
  p.options = mjcf_options(m, p.config, p.grid.dt);
  p.options.driven = false;
  p.mjcf = mujoco_scene::to_mjcf(m, p.scene, p.options);
  return p;
}

// Applies the loads of a dynamics run at every evaluation of the equations of motion (each RK4
// stage too, at its own time and state) through MuJoCo's control callback, which 2.2.2 calls after
// the position and velocity stages and before the applied forces are summed (mj_forwardSkip,
// engine_forward.c): it writes the mechanism's bodies' xfrc_applied, a wrench at each centre of
// mass, as the kinematic runs apply their loads (so cfrc_int counts them as external). The
// callback is global in MuJoCo: it finds its run through a thread-local pointer and does nothing
// outside a dynamics run with loads.
class LoadHook {
 public:
  LoadHook(const Mechanism& m, const Scene& s, const mjModel* mm)
      : loads_(m),
        mass_scale_(s.mass_scale),
        q_(Eigen::VectorXd::Zero(m.coordinate_count())),
        qdot_(Eigen::VectorXd::Zero(m.coordinate_count())) {
    for (const SceneLink& link : s.links)
      if (link.source >= 0 && !link.ground)
        bodies_.push_back(
            {m.moving_index(link.source), mj_name2id(mm, mjOBJ_BODY, link.name.c_str())});
  }
  bool any() const { return loads_.any(); }

  void apply(const mjModel* mm, mjData* d) {
    for (const auto& [k, body] : bodies_) {
      const mjtNum* mat = d->xmat + 9 * body;
      q_.segment<3>(3 * k) << d->xpos[3 * body], d->xpos[3 * body + 1], std::atan2(mat[3], mat[0]);
      mjtNum v[6];
      mj_objectVelocity(mm, d, mjOBJ_XBODY, body, v, 0);  // (angular, linear) at the origin
      qdot_.segment<3>(3 * k) << v[3], v[4], v[2];
    }
    const std::vector<BodyLoad>& on = loads_.at(d->time, q_, qdot_);
    for (const auto& [k, body] : bodies_) {
      mjtNum* x = d->xfrc_applied + 6 * body;
      const BodyLoad& load = on[static_cast<size_t>(k)];
      x[0] = load.force.x() * mass_scale_;  // in the scene's unit of mass
      x[1] = load.force.y() * mass_scale_;
      x[5] = load.moment * mass_scale_;
    }
  }

 private:
  DynamicsLoads loads_;
  double mass_scale_;
  Eigen::VectorXd q_, qdot_;
  std::vector<std::pair<int, int>> bodies_;  // (moving index, MuJoCo body id)
};

thread_local LoadHook* active_hook = nullptr;

void control_callback(const mjModel* m, mjData* d) {
  if (active_hook) active_hook->apply(m, d);
}

// Installs the callback (once per process) and makes `hook` this thread's for its lifetime.
class HookScope {
 public:
  explicit HookScope(LoadHook* hook) {
    static std::once_flag once;
    std::call_once(once, [] {
      if (mjcb_control && mjcb_control != control_callback)
        throw std::runtime_error("MuJoCo's control callback is already taken");
      mjcb_control = control_callback;
    });
    active_hook = hook;
  }
  ~HookScope() { active_hook = nullptr; }
  HookScope(const HookScope&) = delete;
  HookScope& operator=(const HookScope&) = delete;
};

// Velocities and accelerations of the mechanism's links at the state of `d` after mj_forward and
// mj_rnePostConstraint: each body frame origin's, by mj_objectVelocity and mj_objectAcceleration
// (which count gravity as an acceleration of the world, -g: added back).
void state_rates(const Mechanism& m, const Scene& s, const mjModel* mm, const mjData* d,
                 Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) {
  for (const SceneLink& link : s.links) {
    if (link.source < 0 || link.ground) continue;
    const int k = m.moving_index(link.source);
    const int body = mj_name2id(mm, mjOBJ_BODY, link.name.c_str());
    mjtNum v[6], a[6];
    mj_objectVelocity(mm, d, mjOBJ_XBODY, body, v, 0);
    mj_objectAcceleration(mm, d, mjOBJ_XBODY, body, a, 0);
    qdot.segment<3>(3 * k) << v[3], v[4], v[2];
    qddot.segment<3>(3 * k) << a[3] + m.gravity.x(), a[4] + m.gravity.y(), a[2];
  }
}

// mj_forward at a state that closes the chain exactly with consistent rates (a dynamics run's
// start) as MuJoCo's run holds its constraints. MuJoCo 2.2.2's reference acceleration is
// aref = -b J v - k r (mj_referenceConstraint): it has no J' v term, the part of the constraints'
// acceleration the rates make (a link's centripetal turn about a pin), and its rows are soft
// (J qacc = aref - R f). In a run the deadbeat softness takes both back from the residuals the
// steps leave (J v = h/2 J' v, r = h^2/2 J' v at steady state); at an exact start both residuals
// are zero, and qacc would hold the constraints' points unaccelerated against each other
// (fivebar_falling_fast_start: alpha.crank2 8.389 rad/s^2 against the exact 11.846;
// docs/dynamics.md, "The first instant"). Here J' v comes from J(q + s v) v along the rates (a
// 4-point central difference in s, error (s v)^4 with s v 1e-3 rad or size) and is subtracted from
// each equality row's aref before the acceleration stage runs again (mj_forwardSkip past the
// velocity stage keeps aref).
void forward_at_exact_state(const mjModel* mm, mjData* d, mjData* scratch, double size) {
  mj_forward(mm, d);
  const int nv = mm->nv, nefc = d->nefc;
  double rate = 0.0;  // the fastest coordinate's, angles by size
  for (int j = 0; j < mm->njnt; ++j) {
    const double v = std::abs(d->qvel[mm->jnt_dofadr[j]]);
    rate = std::max(rate, mm->jnt_type[j] == mjJNT_SLIDE ? v / size : v);
  }
  if (nefc == 0) return;
  const double s = rate > 0.0 ? 1e-3 / rate : 0.0;  // at rest J' v is 0
  std::vector<mjtNum> jv(static_cast<size_t>(nefc)), jdot_v(static_cast<size_t>(nefc), 0.0);
  for (const auto& [offset, weight] :
       {std::pair{1.0, 8.0}, {-1.0, -8.0}, {2.0, -1.0}, {-2.0, 1.0}}) {
    if (s == 0.0) break;
    std::copy(d->qpos, d->qpos + mm->nq, scratch->qpos);
    std::copy(d->qvel, d->qvel + nv, scratch->qvel);
    mj_integratePos(mm, scratch->qpos, d->qvel, offset * s);
    mj_fwdPosition(mm, scratch);
    if (scratch->nefc != nefc)
      throw std::runtime_error("MuJoCo: the constraint rows changed along the start's rates");
    mj_mulJacVec(mm, scratch, jv.data(), d->qvel);
    for (int i = 0; i < nefc; ++i)
      jdot_v[static_cast<size_t>(i)] += weight * jv[static_cast<size_t>(i)] / (12.0 * s);
  }
  std::vector<mjtNum> aref(d->efc_aref, d->efc_aref + nefc);
  for (int i = 0; i < nefc; ++i)
    if (d->efc_type[i] == mjCNSTR_EQUALITY)
      aref[static_cast<size_t>(i)] -= jdot_v[static_cast<size_t>(i)];
  std::copy(aref.begin(), aref.end(), d->efc_aref);
  mj_forwardSkip(mm, d, mjSTAGE_VEL, 0);
  // The rows are soft: J qacc = aref - R f, R about 1e-4 of the row's diagonal (solimp). In a run
  // the deadbeat stiffness takes that back from the position residual it leaves; at the start
  // aref takes R f of the last solve, twice (the bias falls by R over the diagonal a pass).
  for (int pass = 0; pass < 2; ++pass) {
    for (int i = 0; i < nefc; ++i)
      if (d->efc_type[i] == mjCNSTR_EQUALITY)
        d->efc_aref[i] = aref[static_cast<size_t>(i)] + d->efc_R[i] * d->efc_force[i];
    mj_forwardSkip(mm, d, mjSTAGE_VEL, 0);
  }
}

// ---------------------------------------------------------------------------------------------
// A kinematic run: prepare() plans it (plan_kinematic(): span, grid, start) and builds the scene;
// MujocoKinematicScene is its backend to the shared run loop (sim/kinematic_run.h), which steps,
// samples, reads forces and judges the statuses.

// What a run's trajectory holds before anything is read: the reference's samples.
void shape(Trajectory& out, const Mechanism& m, const Trajectory& reference, bool with_forces) {
  out.resize_as(m, reference, with_forces);
}

// The thresholds a kinematic run watches its steps and flags its samples by; the run diverges
// when a joint opens by the mechanism's size.
KinematicWatch kinematic_watch(const Config& c, const Scene& s, const Mechanism& m) {
  KinematicWatch w;
  w.gap =
      c.gap_threshold == "auto" ? 1e-4 * s.size : setting_number("gap_threshold", c.gap_threshold);
  w.divergence_gap = s.size;
  w.singular_rcond = singular_rcond(c, kSingularRcond);
  w.driver = c.driver_threshold == "auto" ? 1e-3 * driver_watch_unit(m)
                                          : setting_number("driver_threshold", c.driver_threshold);
  w.branch_distance = kBranchDistance;
  return w;
}

// Whether the scene has joint friction (frictionloss).
bool rough(const Scene& s) {
  return std::any_of(s.joints.begin(), s.joints.end(),
                     [](const SceneJoint& j) { return j.friction; });
}

// The values in force both runs print: the step, MuJoCo's solver options and the scene.
Settings step_settings(const Prepared& p) {
  Settings values = {
      {"dt", fmt::format("{:.9g}", p.grid.dt)},
      {"steps_per_sample", std::to_string(p.grid.steps_per_sample)},
      {"max_step_angle",
       p.config.dt == "auto" ? fmt::format("{:g}", p.config.max_step_angle) : "unused (dt given)"},
      {"integrator", p.options.integrator},
      {"solver", p.options.solver},
      {"iterations", std::to_string(p.options.iterations)},
      {"tolerance", fmt::format("{:g}", p.options.tolerance)},
      {"solref", numbers(p.options.solref)},
      {"solimp", numbers(p.options.solimp)},
      {"perturb_link", p.config.perturb_link},
      {"mass_model", "the definition's (Link::mass)"},
      {"max_steps", std::to_string(p.config.max_steps)},
  };
  if (rough(p.scene)) {
    values.push_back(friction_load_value(p.config.extrapolated_load));
    values.emplace_back("friction_solref", numbers(p.options.friction_solref));
  }
  if (!p.scene.contacts.empty()) {
    values.emplace_back("contact_solref", numbers(p.options.contact_solref));
    values.emplace_back("contact_solimp", numbers(p.options.contact_solimp));
    values.emplace_back("cam_facets", std::to_string(p.config.cam_facets));
  }
  return values;
}

// The settings record of a kinematic run: every setting in force, defaults included.
Settings kinematic_settings(const Prepared& p, const KinematicWatch& w, bool with_forces) {
  Settings values = step_settings(p);
  values.insert(
      values.end(),
      {
          {"driver_solref", numbers(p.options.driver_solref)},
          {"driver_solimp", numbers(p.options.driver_solimp)},
          {"driver_armature", fmt::format("{:.6g}", fmt::join(p.options.driver_armature, " "))},
          {"gap_threshold", fmt::format("{:.6g}", w.gap)},
          {"driver_threshold", fmt::format("{:.6g}", w.driver)},
          {"singular_rcond", fmt::format("{:g}", w.singular_rcond)},
          {"force_read", with_forces ? p.config.force_read
                                     : "none (a slide on the driver tendon's path would carry the "
                                       "driver's reaction)"},
          {"derivatives",
           "3-point central differences of step positions; 4-point one-sided at the first and "
           "last usable samples"},
      });
  return printed_settings(mujoco_settings(), RunKind::kinematic, values, rough(p.scene),
                          !p.scene.contacts.empty());
}

// The tree joints' rates of the state (q, qdot) into d->qvel: the scene starts on the exact
// configuration moving with the exact velocities.
void set_joint_rates(const Mechanism& m, const Scene& s, const mjModel* mm, mjData* d,
                     const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) {
  for (const SceneJoint& j : s.joints) {
    if (!j.in_tree) continue;
    const int id = mj_name2id(mm, mjOBJ_JOINT, j.name.c_str());
    d->qvel[mm->jnt_dofadr[id]] = joint_motion(m, s, j, q, qdot)(1);
  }
}

// Whether the constraint forces MuJoCo reads are the definition's reactions. A floating link's
// angle is driven through its tendon, whose torque MuJoCo applies across each hinge of the path
// from the ground: on the links between, the pairs cancel, and the hinges' forces are the
// definition's; a slide on that path would carry the driver's reaction moment in its couple, so
// then no forces are read (no bundled definition has one).
bool driver_reaction_readable(const Scene& s) {
  for (const DrivenCoordinate& driven : s.driven) {
    if (!driven.floating) continue;
    for (int j : driven.path)
      if (s.joints[static_cast<size_t>(j)].kind == SceneJoint::Kind::slide) return false;
  }
  return true;
}

// Build stage: MuJoCo's model and data at the exact start (the plan's), moving with the exact
// velocities, stepped for the shared run loop (sim/kinematic_run.h).
// Joint friction as frictionloss (docs/engines.md, "Joint friction"): each friction joint's row
// bounded per step by FrictionBounds.
class FrictionLoss {
 public:
  FrictionLoss(const Mechanism& m, const Scene& s, const mjModel* mm, ReadingTrend start,
               bool extrapolated)
      : mass_scale_(s.mass_scale),
        rows_(rows_of(s, mm)),
        bounds_(m, joints_of(rows_), std::move(start), extrapolated, 0) {}
  bool any() const { return bounds_.any(); }
  // Whether the step about to be taken must be read (its reactions are the next steps' load).
  bool reads() const { return bounds_.reads(); }
  // Before a step of h from the pose `pose` gives, read only when the bounds need it.
  void bound(mjModel* mm, const std::function<Eigen::VectorXd()>& pose, double h) {
    bounds_.bound(h, bounds_.reads_pose() ? pose() : Eigen::VectorXd(),
                  [&](size_t i, double limit) { rows_[i].bound(mm, limit * mass_scale_); });
  }
  // After the step of h from positions `before`, with its reading when reads() was true; the
  // friction's work over it [J].
  double after(const mjData* d, const std::vector<mjtNum>& before, const ForceReading* reading,
               double h) {
    return bounds_.settle(h, reading, [&](size_t i) {
      return FrictionBounds::Step{rows_[i].force(d) / mass_scale_, rows_[i].moved(d, before)};
    });
  }

 private:
  static std::vector<FrictionRow> rows_of(const Scene& s, const mjModel* mm) {
    std::vector<FrictionRow> rows;
    for (const SceneJoint& j : s.joints)
      if (j.friction) rows.push_back(friction_row(mm, j));
    return rows;
  }
  static std::vector<int> joints_of(const std::vector<FrictionRow>& rows) {
    std::vector<int> joints;
    for (const FrictionRow& r : rows) joints.push_back(r.joint);
    return joints;
  }
  double mass_scale_;
  std::vector<FrictionRow> rows_;
  FrictionBounds bounds_;
};

class MujocoKinematicScene final : public KinematicScene {
 public:
  MujocoKinematicScene(const Mechanism& m, const Prepared& p, ModelPtr loaded, bool with_forces,
                       ReadingTrend start)
      : p_(p),
        model_(std::move(loaded)),
        mm_(model_.get()),
        data_(mj_makeData(mm_)),
        d_(data_.get()),
        reader_(m, p.scene, mm_, p.start.q),
        friction_(m, p.scene, mm_, std::move(start), p.config.extrapolated_load),
        reading_(m.joints.size(), m.drivers.size()),
        stages_(stages_per_step(p.config.integrator)) {
    const Scene& s = p.scene;
    // A joint equality holds the driven joint's qpos, whichever way the joint runs against the
    // driver (DrivenCoordinate::sign); a tendon equality its length, the sum of the terms.
    for (size_t d = 0; d < s.driven.size(); ++d) {
      driver_eq_.push_back(mj_name2id(mm_, mjOBJ_EQUALITY, s.driver_names[d].c_str()));
      double coordinate0 = 0.0;
      for (const auto& [joint, coefficient] : s.driven[d].terms) {
        const int id = mj_name2id(mm_, mjOBJ_JOINT, s.joints[joint].name.c_str());
        coordinate0 +=
            (s.driven[d].floating ? coefficient : 1.0) * mm_->qpos0[mm_->jnt_qposadr[id]];
      }
      coordinate0_.push_back(coordinate0);
    }
    for (const SceneLink& link : s.links)
      if (link.source >= 0 && !link.ground)
        load_body_.push_back(mj_name2id(mm_, mjOBJ_BODY, link.name.c_str()));
    set_joint_rates(m, s, mm_, d_, p.start.q, p.start.qdot);
    mj_forward(mm_, d_);
    if (with_forces || friction_.any()) {
      forces_.emplace(m, s, mm_, p.config.force_read == "centred");
      qpos_before_.resize(static_cast<size_t>(mm_->nq));
    }
  }

  // Each driver equality holds its coordinate's change from qpos0 at eq_data[0].
  void drive(const std::vector<double>& driver_values) override {
    for (size_t d = 0; d < driver_eq_.size(); ++d) {
      const DrivenCoordinate& driven = p_.scene.driven[d];
      mm_->eq_data[mjNEQDATA * driver_eq_[d]] =
          driven.sign * (driver_values[d] - driven.offset) - coordinate0_[d];
    }
  }
  void apply(const std::vector<BodyLoad>& on) override {
    for (size_t b = 0; b < on.size(); ++b) {
      mjtNum* x = d_->xfrc_applied + 6 * load_body_[b];
      x[0] = on[b].force.x() * p_.scene.mass_scale;  // in the scene's unit of mass
      x[1] = on[b].force.y() * p_.scene.mass_scale;
      x[5] = on[b].moment * p_.scene.mass_scale;
    }
  }
  std::string step(double h, ForceReading* forces) override {
    set_step(h);
    const bool rough = friction_.any();
    if (forces || rough) std::copy(d_->qpos, d_->qpos + mm_->nq, qpos_before_.begin());
    if (rough)
      friction_.bound(
          mm_, [&] { return reader_.read(d_); }, h);
    mj_step(mm_, d_);
    ForceReading* into = forces ? forces : friction_.reads() ? &reading_ : nullptr;
    if (into) forces_->read(d_, qpos_before_, h, *into);
    if (rough) (void)friction_.after(d_, qpos_before_, into, h);
    mj_kinematics(mm_, d_);  // mj_step leaves xpos/xmat at the step's start
    evaluations_ += stages_;
    return d_->warning[mjWARN_BADQACC].number > 0 ? "MuJoCo's accelerations are not finite" : "";
  }
  void read_pose(Eigen::VectorXd& q) override { q = reader_.read(d_); }
  long evaluations() const override { return evaluations_; }

 private:
  // A step of a new length: the deadbeat softness follows it.
  void set_step(double h) {
    if (mm_->opt.timestep == h) return;
    mm_->opt.timestep = h;
    for (int e = 0; e < mm_->neq; ++e) {
      const bool driver = std::find(driver_eq_.begin(), driver_eq_.end(), e) != driver_eq_.end();
      const std::string& choice = driver ? p_.config.driver_solref : p_.config.solref;
      if (choice != "deadbeat") continue;
      mm_->eq_solref[mjNREF * e] = -1.0 / (h * h);
      mm_->eq_solref[mjNREF * e + 1] = -1.0 / h;
    }
    if (p_.config.contact_solref == "auto")
      for (int i = 0; i < mm_->npair; ++i) mm_->pair_solref[mjNREF * i] = 2.0 * h;
  }

  const Prepared& p_;
  ModelPtr model_;
  mjModel* mm_;
  DataPtr data_;
  mjData* d_;
  PoseReader reader_;
  FrictionLoss friction_;
  ForceReading reading_;  // scratch: a step's reading for the friction's load
  std::optional<ForceReader> forces_;
  std::vector<mjtNum> qpos_before_;
  std::vector<int> load_body_;       // per moving link: MuJoCo body id
  std::vector<int> driver_eq_;       // per driver: its equality
  std::vector<double> coordinate0_;  // per driver: its coordinate at qpos0
  long stages_, evaluations_ = 0;
};

// The states a dynamics run keeps for its state readout: the last kRing steps', by step mod kRing
// (a sample is read one step after its own).
constexpr long kRing = 16;

// ---------------------------------------------------------------------------------------------
// A dynamics run: prepare_dynamics() plans it (plan_dynamics()) and builds the scene;
// MujocoDynamicsScene is its backend to the shared run loop (sim/dynamics_run.h).

// A dynamics run's trajectory before anything is read: the reference's samples and an energy
// balance.
void shape_dynamics(Trajectory& out, const Mechanism& m, const Trajectory& reference,
                    bool with_forces) {
  out.resize_as(m, reference, with_forces, true);
}

// The thresholds and the scale a dynamics run flags and stops by; the run diverges when a joint
// opens by the mechanism's size. The energy scale is the energy the exact motion moves (a
// mechanism at rest in equilibrium moves none: then any change is judged against 1e-12 J).
DynamicsWatch dynamics_watch(const Mechanism& m, const Trajectory& reference, const Prepared& p) {
  DynamicsWatch w;
  w.gap = p.config.gap_threshold == "auto"
              ? 1e-4 * p.scene.size
              : setting_number("gap_threshold", p.config.gap_threshold);
  w.divergence_gap = p.scene.size;
  w.energy_scale = std::max(reference_energy_scale(m, reference), 1e-12);
  w.singular_rcond = singular_rcond(p.config, kDynamicsSingularRcond);
  w.energy_threshold = p.config.energy_threshold;
  w.divergence_energy = p.config.divergence_energy;
  return w;
}

// The settings record of a dynamics run.
Settings dynamics_settings(const Prepared& p, const DynamicsChoices& choice,
                           const DynamicsWatch& w) {
  Settings values = step_settings(p);
  values.insert(
      values.end(),
      {
          {"gap_threshold", fmt::format("{:.6g}", w.gap)},
          {"singular_rcond", fmt::format("{:g}", w.singular_rcond)},
          // The state readout takes MuJoCo's forces at the sampled state as they are.
          {"force_read", choice.state_readout ? "unused (state readout)" : p.config.force_read},
          {"driver", "none: the coordinate moves under the applied effort (forward dynamics)"},
          {"start", choice.staggered ? "staggered (v0 - h/2 a0)" : "exact (v0)"},
          {"readout", choice.state_readout ? "state (MuJoCo's velocity; mj_forward acceleration)"
                                           : "differences (3-point central of step positions)"},
          {"energy_threshold", fmt::format("{:g}", p.config.energy_threshold)},
          {"divergence_energy", fmt::format("{:g}", p.config.divergence_energy)},
          {"energy_scale", fmt::format("{:.6g} J", w.energy_scale)},
      });
  return printed_settings(mujoco_settings(), RunKind::dynamics, values, rough(p.scene),
                          !p.scene.contacts.empty());
}

// A dynamics run's scene for the shared run loop (sim/dynamics_run.h): MuJoCo's model at the
// exact start with the loads' callback; MuJoCo's own acceleration at the exact state sets the
// staggered velocity and the pose one step before the start (central differences at the first
// sample); the state of the last kRing steps kept for the state readout.
class MujocoDynamicsScene final : public DynamicsScene {
 public:
  MujocoDynamicsScene(const Mechanism& m, const Prepared& p, const DynamicsChoices& choice,
                      ModelPtr loaded, ReadingTrend start)
      : m_(m),
        p_(p),
        choice_(choice),
        model_(std::move(loaded)),
        mm_(model_.get()),
        data_(mj_makeData(mm_)),
        state_data_(mj_makeData(mm_)),
        scratch_(mj_makeData(mm_)),
        d_(data_.get()),
        sd_(state_data_.get()),
        hook_(m, p.scene, mm_),
        force_reader_(m, p.scene, mm_, p.config.force_read == "centred"),
        reader_(m, p.scene, mm_, p.start.q),
        friction_(m, p.scene, mm_, std::move(start), p.config.extrapolated_load),
        reading_(m.joints.size(), m.drivers.size()),
        qpos_before_(static_cast<size_t>(mm_->nq)),
        stages_(stages_per_step(p.config.integrator)) {
    const int nq = mm_->nq, nv = mm_->nv;
    const std::vector<double>& grid = p.grid.time;
    // The scene's joints map the definition's links.
    set_joint_rates(m, p.scene, mm_, d_, p.start.q, p.start.qdot);
    const double h0 = grid[1] - grid[0];
    d_->time = grid[0];
    scope_.emplace(hook_.any() ? &hook_ : nullptr);
    // The start's acceleration (the staggered start's half step back) with its friction.
    if (friction_.any())
      friction_.bound(
          mm_, [&] { return p.start.q; }, h0);
    forward_at_exact_state(mm_, d_, scratch_.get(), p.scene.size);
    std::vector<mjtNum> v0(d_->qvel, d_->qvel + nv), w(static_cast<size_t>(nv));
    for (int i = 0; i < nv; ++i) w[static_cast<size_t>(i)] = v0[i] - 0.5 * h0 * d_->qacc[i];
    if (choice.staggered) std::copy(w.begin(), w.end(), d_->qvel);
    std::copy(d_->qpos, d_->qpos + nq, sd_->qpos);
    const bool euler_like = p.config.integrator != "RK4";
    mj_integratePos(mm_, sd_->qpos, euler_like ? d_->qvel : w.data(), -h0);
    mj_kinematics(mm_, sd_);
    PoseReader before_reader(m, p.scene, mm_, p.start.q);
    before_start_ = before_reader.read(sd_);
    keep_state(0);
    ring_qvel_[0] = v0;  // the start's state is v0, whichever velocity the first step takes
  }

  bool evaluates_loads() const override { return true; }
  std::string step(double t0, double h, ForceReading* forces) override {
    set_step(h);
    d_->time = t0;
    const bool rough = friction_.any();
    if (forces || rough) std::copy(d_->qpos, d_->qpos + mm_->nq, qpos_before_.begin());
    if (rough)
      friction_.bound(
          mm_, [&] { return reader_.read(d_); }, h);
    mj_step(mm_, d_);
    ForceReading* into = forces ? forces : friction_.reads() ? &reading_ : nullptr;
    if (into) force_reader_.read(d_, qpos_before_, h, *into);
    if (rough) friction_work_ = friction_.after(d_, qpos_before_, into, h);
    mj_kinematics(mm_, d_);
    evaluations_ += stages_;
    keep_state(++taken_);
    return d_->warning[mjWARN_BADQACC].number > 0 ? "MuJoCo's accelerations are not finite" : "";
  }
  void read_pose(Eigen::VectorXd& q) override { q = reader_.read(d_); }
  bool pose_before_start(double /*h*/, Eigen::VectorXd& q) override {
    q = before_start_;
    return true;
  }
  bool reads_state() const override { return choice_.state_readout; }
  // Whichever the readout, the start is read from the state it was given: its differences would
  // take the first step's acceleration, at a state that has not yet the residuals MuJoCo reads
  // the velocity terms from (forward_at_exact_state).
  bool reads_start_state() const override { return true; }
  // MuJoCo's forces and rates at the state it integrated to step S (mj_forward there; at the
  // start with the velocity terms).
  void read_state(long S, double t, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot,
                  ForceReading& forces) override {
    const size_t k = static_cast<size_t>(S % kRing);
    std::copy(ring_qpos_[k].begin(), ring_qpos_[k].end(), sd_->qpos);
    std::copy(ring_qvel_[k].begin(), ring_qvel_[k].end(), sd_->qvel);
    sd_->time = t;
    if (S == 0)
      forward_at_exact_state(mm_, sd_, scratch_.get(), p_.scene.size);
    else
      mj_forward(mm_, sd_);
    force_reader_.read_state(sd_, forces);
    state_rates(m_, p_.scene, mm_, sd_, qdot, qddot);
  }
  long evaluations() const override { return evaluations_; }
  double friction_work() const override { return friction_work_; }

 private:
  void keep_state(long k) {
    ring_qpos_[static_cast<size_t>(k % kRing)].assign(d_->qpos, d_->qpos + mm_->nq);
    ring_qvel_[static_cast<size_t>(k % kRing)].assign(d_->qvel, d_->qvel + mm_->nv);
  }
  // A step of a new length: the deadbeat softness follows it.
  void set_step(double h) {
    if (mm_->opt.timestep == h) return;
    mm_->opt.timestep = h;
    if (p_.config.solref == "deadbeat")
      for (int e = 0; e < mm_->neq; ++e) {
        mm_->eq_solref[mjNREF * e] = -1.0 / (h * h);
        mm_->eq_solref[mjNREF * e + 1] = -1.0 / h;
      }
  }

  const Mechanism& m_;
  const Prepared& p_;
  const DynamicsChoices& choice_;
  ModelPtr model_;
  mjModel* mm_;
  DataPtr data_, state_data_, scratch_;
  mjData* d_;
  mjData* sd_;
  LoadHook hook_;
  std::optional<HookScope> scope_;  // declared after hook_: ends before it
  ForceReader force_reader_;
  PoseReader reader_;
  FrictionLoss friction_;
  ForceReading reading_;  // scratch: a step's reading for the friction's load
  std::vector<mjtNum> qpos_before_;
  double friction_work_ = 0.0;  // the friction loss rows' work over the last step [J]
  Eigen::VectorXd before_start_;
  std::array<std::vector<mjtNum>, kRing> ring_qpos_, ring_qvel_;  // per step, the last kRing
  long stages_, taken_ = 0, evaluations_ = 0;
};

// A dynamics run: plan, build, then the shared run loop.
EngineRun run_dynamics(const Mechanism& m, const Trajectory& reference, const Settings& overrides) {
  const Clock::time_point begin = Clock::now();
  EngineRun run;
  run.trajectory.method = "mujoco";
  shape_dynamics(run.trajectory, m, reference, false);
  Prepared p;
  ModelPtr model;
  try {
    p = prepare_dynamics(m, reference, overrides);
    model = load_model(p.mjcf);
  } catch (const std::exception& e) {
    run.settings = overrides;
    return failed_run(std::move(run), e.what());
  }
  const DynamicsChoices choice = dynamics_choices(p.config);
  const DynamicsWatch watch = dynamics_watch(m, reference, p);
  run.settings = dynamics_settings(p, choice, watch);
  MujocoDynamicsScene scene(m, p, choice, std::move(model),
                            reference_trend(m, reference, p.span.first, p.grid.time.front()));
  sim::run_dynamics(m, perturbed(m, p.config.perturb_link), reference, p.dynamics, watch, true,
                    scene, begin, run);
  return run;
}

class MujocoEngine final : public Engine {
 public:
  std::string name() const override { return "mujoco"; }
  const SettingSchema& settings_schema() const override { return mujoco_settings(); }

  bool supports(const Mechanism& mechanism, std::string* why) const override {
    return mujoco_scene::realisable(mechanism, why);
  }

  // Every name and every value, perturb_link's link among the mechanism's (the deadbeat
  // solref's step is checked when the scene is built).
  void check_settings(const Mechanism& m, const Settings& overrides) const override {
    try {
      const Config c = parse_settings(overrides);
      (void)perturbed(m, c.perturb_link);
      for (const auto& [name, text] :
           {std::pair<const char*, const std::string&>{"solref", c.solref},
            {"driver_solref", c.driver_solref}})
        (void)solref_of(name, text, 1.0);
      (void)solimp_of("solimp", c.solimp);
      (void)solimp_of("driver_solimp", c.driver_solimp);
      (void)two_step_solref("friction_solref", c.friction_solref, 1.0);
      (void)two_step_solref("contact_solref", c.contact_solref, 1.0);
      (void)solimp_of("contact_solimp", c.contact_solimp);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(e.what());
    }
  }

  // A kinematic run: plan, build, step, sample, read forces, then the statuses (the stages
  // above).
  EngineRun run(const Mechanism& m, const Trajectory& reference,
                const Settings& overrides) const override {
    const MessageCapture capture;
    EngineRun run;
    try {
      run = m.dynamics ? run_dynamics(m, reference, overrides)
                       : run_kinematic(m, reference, overrides);
    } catch (const std::runtime_error& e) {
      if (!std::string_view(e.what()).starts_with("MuJoCo error: ")) throw;
      run.trajectory.method = "mujoco";
      if (m.dynamics)
        shape_dynamics(run.trajectory, m, reference, false);
      else
        shape(run.trajectory, m, reference, false);
      run.settings = overrides;
      run = failed_run(std::move(run), e.what());
    }
    capture.note(run.message);
    return run;
  }

 private:
  EngineRun run_kinematic(const Mechanism& m, const Trajectory& reference,
                          const Settings& overrides) const {
    const Clock::time_point begin = Clock::now();
    EngineRun run;
    run.trajectory.method = "mujoco";
    shape(run.trajectory, m, reference, false);
    Prepared p;
    ModelPtr loaded;
    try {
      p = prepare(m, reference, overrides);
      loaded = load_model(p.mjcf);
    } catch (const std::exception& e) {
      run.settings = overrides;
      return failed_run(std::move(run), e.what());
    }
    const bool with_forces = driver_reaction_readable(p.scene);
    const KinematicWatch watch = kinematic_watch(p.config, p.scene, m);
    run.settings = kinematic_settings(p, watch, with_forces);
    MujocoKinematicScene scene(m, p, std::move(loaded), with_forces,
                               reference_trend(m, reference, p.span.first, p.grid.time.front()));
    sim::run_kinematic(m, perturbed(m, p.config.perturb_link), reference, p.plan, watch,
                       with_forces, scene, begin, run);
    return run;
  }
};

// The clock's drive outweighs the linkage's load on it by this factor's reciprocal, so the
// driver's speed (or swing) in the exported scene is the definition's to about this fraction.
constexpr double kClockLoad = 1e-4;

// The export's additions (scene.h, Standalone): the start's joint rates, bars, ground guides
// over the sliders' travel, and a clock that turns the driver at the definition's speed through
// a whole cycle, or swings it between the sweep's ends when the sweep is not a whole cycle.
mujoco_scene::Standalone standalone(const Mechanism& m, const Trajectory& reference,
                                    const Prepared& p, int start_row) {
  const Scene& s = p.scene;
  mujoco_scene::Standalone out;
  out.radius = 0.01 * s.size;
  out.rates.assign(s.joints.size(), 0.0);
  for (size_t j = 0; j < s.joints.size(); ++j)
    if (s.joints[j].in_tree)
      out.rates[j] = joint_motion(m, s, s.joints[j], p.start.q, p.start.qdot)(1);
  std::vector<int> usable_rows;
  for (int i = p.span.first; i <= p.span.last; ++i)
    if (has_position(reference.status[static_cast<size_t>(i)])) usable_rows.push_back(i);
  const std::vector<int> slides = m.slide_joints();
  for (size_t k = 0; k < slides.size(); ++k) {
    const Joint& j = m.joints[static_cast<size_t>(slides[k])];
    if (!m.links[static_cast<size_t>(j.link_a)].ground) continue;
    const Line& line = m.links[static_cast<size_t>(j.link_a)].lines[static_cast<size_t>(j.line)];
    double low = INFINITY, high = -INFINITY;
    for (int i : usable_rows) {
      low = std::min(low, reference.s(i, static_cast<Eigen::Index>(k)));
      high = std::max(high, reference.s(i, static_cast<Eigen::Index>(k)));
    }
    if (low <= high)
      out.guides.push_back({line.origin + (low - 3 * out.radius) * line.direction,
                            line.origin + (high + 3 * out.radius) * line.direction});
  }
  if (m.dynamics || !p.options.driven || usable_rows.empty()) return out;
  const Driver& driver = m.swept();  // the exported scene's clock turns one (mujoco_mjcf)

  double low = INFINITY, high = -INFINITY, peak_rate = 0.0;
  for (int i : usable_rows) {
    low = std::min(low, reference.along(i));
    high = std::max(high, reference.along(i));
    peak_rate = std::max(peak_rate, std::abs(driver.at_time(reference.time(i)).rate));
  }
  const double v0 = reference.along(start_row);
  const double rate0 = driver.at_time(reference.time(start_row)).rate;
  const bool turning =
      p.periodic && driver.law.kind == MotionLaw::Kind::constant_speed && rate0 != 0.0;
  // A swing stays a twentieth of the sweep clear of its ends, which are limits (toggles) where
  // the chain would take the clock's drive: it goes from the start, at rest, to as far towards
  // the farther end and back.
  const double margin = 0.05 * (high - low);
  const double far = v0 - low > high - v0 ? low + margin : high - margin;
  const auto in_swing = [&](double v) { return std::abs(v - v0) <= std::abs(far - v0) + 1e-12; };
  // The load the linkage can put on the clock: the peak driver effort where the clock takes it,
  // and at least its inertia at the driver's peak rate (angular, or over the size for a slider).
  double peak_effort = 0.0;
  if (reference.has_forces)
    for (int i : usable_rows)
      if (turning || in_swing(reference.along(i)))
        peak_effort =
            std::max(peak_effort, std::abs(reference.effort(i, m.axis().driver)) * s.mass_scale);
  const double arm = driver.angular() ? 1.0 : s.size;
  double inertia = 0.0;
  for (const SceneLink& link : s.links)
    if (!link.ground) inertia += link.mass * s.size * s.size + link.inertia;
  const auto load = [&](double rate) {
    return std::max(peak_effort, inertia * std::pow(rate / arm, 2) / arm);
  };
  mujoco_scene::Clock clock;
  if (turning) {
    // A servo: torque - damping x rate, at speed when rate = torque / damping; it spins up over
    // a twentieth of a turn's time (of the cycle, for a slider) from rest.
    const double period =
        driver.angular() ? 2.0 * std::numbers::pi / std::abs(rate0) : m.cycle_period();
    clock.damping = load(rate0) / (kClockLoad * std::abs(rate0));
    clock.torque = clock.damping * rate0;
    clock.inertia = clock.damping * period / 20.0;
    clock.rate = rate0;
  } else {
    // A spring about the swing's middle, as fast there as the definition's fastest rate; the
    // keyframe starts at rest, as the clock does.
    std::fill(out.rates.begin(), out.rates.end(), 0.0);
    const double centre = 0.5 * (far - v0), amplitude = std::abs(centre);
    if (amplitude > 0.0 && peak_rate > 0.0) {
      const double frequency = peak_rate / amplitude;
      clock.stiffness = load(peak_rate) / (kClockLoad * amplitude);
      clock.inertia = clock.stiffness / (frequency * frequency);
      clock.springref = centre;
    }
  }
  out.clock = clock;
  return out;
}

}  // namespace

std::unique_ptr<Engine> make_mujoco_engine() {
  return std::make_unique<MujocoEngine>();
}

std::string mujoco_mjcf(const Mechanism& mechanism, const Trajectory& reference,
                        const Settings& settings) {
  // The exported scene's clock turns one driver (scene.h, Clock).
  if (mechanism.axis().timed())
    throw std::runtime_error(fmt::format(
        "{} drivers: the exported scene's clock turns one driver, so a scene with several is not "
        "exported",
        mechanism.drivers.size()));
  Prepared p = mechanism.dynamics ? prepare_dynamics(mechanism, reference, settings)
                                  : prepare(mechanism, reference, settings);
  // The exported scene starts at the definition's start: the usable sample nearest it (a
  // sweep's samples fall on it), not before a run's pre-roll or at a range's end.
  int row = p.span.first;
  if (!mechanism.dynamics) {
    for (int i = p.span.first; i <= p.span.last; ++i)
      if (usable(reference.status[static_cast<size_t>(i)]) &&
          std::abs(reference.along(i) - mechanism.swept().start) <
              std::abs(reference.along(row) - mechanism.swept().start))
        row = i;
    const auto start = exact_start(mechanism, reference, row);
    if (!start) throw std::runtime_error("could not close the loops at the definition's start");
    p.start = *start;
    p.scene = mujoco_scene::build_scene(mechanism, p.start.q, p.config.cam_facets);
  }
  p.options.standalone = standalone(mechanism, reference, p, row);
  return mujoco_scene::to_mjcf(mechanism, p.scene, p.options);
}

}  // namespace crosslink::sim
