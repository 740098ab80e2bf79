// MuJoCo engine: builds the scene (scene.h), loads it from a virtual file system, steps it at
// the reference's times with the driver enforced every step, watches the loop gap, and reads
// positions, velocities and accelerations at the sampled steps.
#include "sim/mujoco/mujoco_engine.h"
#include "sim/sampling.h"

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "analytic/newton.h"
#include "analytic/planar.h"
#include "sim/forces.h"
#include "sim/mujoco/scene.h"

namespace crosslink::sim {
namespace {

using mujoco_scene::DrivenJoint;
using mujoco_scene::MjcfOptions;
using mujoco_scene::Scene;
using mujoco_scene::SceneJoint;
using mujoco_scene::SceneLink;

// A run that could not be made: its reason, and every sample diverged (no engine value).
EngineRun failed(EngineRun run, std::string message) {
  run.ok = false;
  run.message = std::move(message);
  std::fill(run.trajectory.status.begin(), run.trajectory.status.end(), PoseStatus::diverged);
  return run;
}

// ---------------------------------------------------------------------------------------------
// Settings

const char* const kSolimp = "0.9999 0.9999 0.001 0.5 2";
// An equivalent driver's joint turning slower than this fraction of its peak rate is at its own
// dead point (measured on the polycentric hinge: 0.45 % gave 7 % of peak alpha, 0.76 % 0.1 %).
constexpr double kDeadRate = 0.01;
constexpr double kSingularRcond = 1e-6;
// Forward dynamics passes singular positions under its own momentum; within about 0.005 rad of
// one (IFToMM A02's change point: rcond 1.3e-4 and 3.7e-4) the soft constraint solve's
// acceleration is off by 2 to 8 % of its peak in the direction the chain gains there, at every
// step (measured; docs/engines.md, "Forward dynamics"), while from 6.7e-4 on it is within 1e-5.
constexpr double kDynamicsSingularRcond = 1e-3;
// Periodic sweeps: steps run before the first sample and after the last.
constexpr long kPreroll = 8;
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
  std::string gap_threshold = "auto", driver_threshold = "auto";
  std::string perturb_link = "none";
  std::string force_read = "centred";  // centred | raw (docs/engines.md, "Forces")
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

double parse_number(const std::string& name, const std::string& text) {
  try {
    size_t used = 0;
    const double value = std::stod(text, &used);
    if (used == text.size() && std::isfinite(value)) return value;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(fmt::format("setting {} = \"{}\": expected a number", name, text));
}

std::vector<double> parse_numbers(const std::string& name, const std::string& text) {
  std::istringstream in(text);
  std::vector<double> values;
  std::string word;
  while (in >> word) values.push_back(parse_number(name, word));
  return values;
}

Config parse_settings(const Settings& overrides) {
  Config c;
  const std::map<std::string, std::string*> text = {{"dt", &c.dt},
                                                    {"integrator", &c.integrator},
                                                    {"solver", &c.solver},
                                                    {"solref", &c.solref},
                                                    {"solimp", &c.solimp},
                                                    {"driver_solref", &c.driver_solref},
                                                    {"driver_solimp", &c.driver_solimp},
                                                    {"gap_threshold", &c.gap_threshold},
                                                    {"driver_threshold", &c.driver_threshold},
                                                    {"perturb_link", &c.perturb_link},
                                                    {"force_read", &c.force_read},
                                                    {"start", &c.start},
                                                    {"readout", &c.readout},
                                                    {"singular_rcond", &c.singular_rcond}};
  for (const auto& [name, value] : overrides) {
    if (auto it = text.find(name); it != text.end()) {
      *it->second = value;
    } else if (name == "iterations") {
      c.iterations = static_cast<int>(parse_number(name, value));
    } else if (name == "tolerance") {
      c.tolerance = parse_number(name, value);
    } else if (name == "max_step_angle") {
      c.max_step_angle = parse_number(name, value);
    } else if (name == "max_steps") {
      c.max_steps = parse_max_steps(value);
    } else if (name == "energy_threshold") {
      c.energy_threshold = parse_number(name, value);
    } else if (name == "divergence_energy") {
      c.divergence_energy = parse_number(name, value);
    } else {
      throw std::runtime_error(fmt::format(
          "unknown MuJoCo setting \"{}\" (known: dt, max_step_angle, integrator, solver, "
          "iterations, tolerance, solref, solimp, driver_solref, driver_solimp, gap_threshold, "
          "driver_threshold, perturb_link, force_read, max_steps, start, readout, "
          "energy_threshold, divergence_energy, singular_rcond)",
          name));
    }
  }
  for (const std::string* choice : {&c.integrator, &c.solver}) {
    const bool known = *choice == "Euler" || *choice == "RK4" || *choice == "implicit" ||
                       *choice == "Newton" || *choice == "CG" || *choice == "PGS";
    if (!known)
      throw std::runtime_error(fmt::format("unknown integrator or solver \"{}\"", *choice));
  }
  if (c.force_read != "centred" && c.force_read != "raw")
    throw std::runtime_error(
        fmt::format("setting force_read = \"{}\": expected centred or raw", c.force_read));
  if (c.start != "auto" && c.start != "staggered" && c.start != "exact")
    throw std::runtime_error(
        fmt::format("setting start = \"{}\": expected auto, staggered or exact", c.start));
  if (c.readout != "auto" && c.readout != "differences" && c.readout != "state")
    throw std::runtime_error(
        fmt::format("setting readout = \"{}\": expected auto, differences or state", c.readout));
  return c;
}

Eigen::Vector2d solref_of(const std::string& name, const std::string& text, double dt) {
  if (text == "deadbeat") return {-1.0 / (dt * dt), -1.0 / dt};
  const std::vector<double> v = parse_numbers(name, text);
  if (v.size() != 2) throw std::runtime_error(fmt::format("setting {}: expected 2 numbers", name));
  return {v[0], v[1]};
}

Eigen::Matrix<double, 5, 1> solimp_of(const std::string& name, const std::string& text) {
  std::vector<double> v = parse_numbers(name, text);
  const std::array<double, 5> defaults = {0.9, 0.95, 0.001, 0.5, 2.0};  // MuJoCo's
  if (v.size() < 3 || v.size() > 5)
    throw std::runtime_error(fmt::format("setting {}: expected 3 to 5 numbers", name));
  for (size_t i = v.size(); i < 5; ++i) v.push_back(defaults[i]);
  return Eigen::Map<const Eigen::Matrix<double, 5, 1>>(v.data());
}

// ---------------------------------------------------------------------------------------------
// The starting configuration and the time grid

// The reference's usable samples (PoseStatus::ok): the engine starts at the first and stops at
// the last; samples outside keep the reference's flag. Interior flagged samples (a change point
// on a sample) are run through.
struct Span {
  int first = -1, last = -1;
};

Span usable_span(const Trajectory& reference) {
  Span span;
  for (int i = 0; i < reference.samples(); ++i)
    if (usable(reference.status[static_cast<size_t>(i)])) {
      if (span.first < 0) span.first = i;
      span.last = i;
    }
  if (span.first < 0) throw std::runtime_error("the reference has no usable sample to start from");
  if (span.last == span.first)
    throw std::runtime_error("the reference has a single usable sample: nothing to run over");
  return span;
}

// Absolute coordinates and their rates at the reference's first usable sample, solved exactly.
struct Start {
  Eigen::VectorXd q, qdot;
};

// At time t (the first usable sample's, or before it for a periodic pre-roll); nullopt when the
// chain does not close there on a well-conditioned pose.
std::optional<Start> exact_start(const Mechanism& m, const Trajectory& reference, int first,
                                 double t) {
  KinematicState state(m);
  state.q = reference_coordinates(m, reference, first);
  state.driver = m.driver.at_time(t);
  state.driver.value = reference.driver(first) +
                       (state.driver.value - m.driver.at_time(reference.time(first)).value);
  const NewtonSolver solver(m);
  const SolveReport report = solver.solve(state);
  if (report.status != PoseStatus::ok) return std::nullopt;
  return Start{state.q, state.qdot};
}

// Step times over the usable span: each sample interval is split into equal steps no longer
// than the wanted step, so samples fall on step boundaries (a sweep's extra sample at a toggle
// makes one interval shorter than the others). The grid starts at the first usable sample and
// ends at the last: the engine is never driven outside them.
struct TimeGrid {
  std::vector<double> time;       // time at the end of forward step k (k = 0: the first sample)
  std::vector<long> sample_step;  // step of each sample; -1 outside the usable span
  double dt = 0.0;                // the longest step [s]
  long steps_per_sample = 1;      // in the longest interval
};

TimeGrid time_grid(const Trajectory& reference, const Config& c, const Span& span) {
  const int n = reference.samples();
  for (int i = 1; i < n; ++i)
    if (!(reference.time(i) > reference.time(i - 1)))
      throw std::runtime_error("the reference's times do not increase");
  double wanted = 0.0;
  if (c.dt == "auto") {
    // The fastest link of the reference sets the step: errors grow as (omega dt)^2.
    double fastest = 0.0;
    for (int i = span.first; i <= span.last; ++i)
      if (usable(reference.status[static_cast<size_t>(i)]))
        fastest = std::max(fastest, reference.omega.row(i).cwiseAbs().maxCoeff());
    wanted = fastest > 0.0 ? c.max_step_angle / fastest
                           : reference.time(span.first + 1) - reference.time(span.first);
  } else {
    wanted = parse_number("dt", c.dt);
    if (!(wanted > 0.0)) throw std::runtime_error("setting dt: must be positive");
  }
  // Steps per sample interval, counted (as doubles: they may be astronomical) before the grid
  // takes any memory.
  std::vector<double> per_interval;
  for (int i = span.first + 1; i <= span.last; ++i)
    per_interval.push_back(
        std::max(1.0, std::ceil((reference.time(i) - reference.time(i - 1)) / wanted - 1e-9)));
  check_steps(std::accumulate(per_interval.begin(), per_interval.end(), 0.0), wanted, c.max_steps);
  TimeGrid grid;
  grid.sample_step.assign(static_cast<size_t>(n), -1);
  grid.time.push_back(reference.time(span.first));
  grid.sample_step[static_cast<size_t>(span.first)] = 0;
  for (int i = span.first + 1; i <= span.last; ++i) {
    const double interval = reference.time(i) - reference.time(i - 1);
    const long steps = static_cast<long>(per_interval[static_cast<size_t>(i - span.first - 1)]);
    const double h = interval / static_cast<double>(steps);
    for (long k = 1; k <= steps; ++k)
      grid.time.push_back(k == steps ? reference.time(i)
                                     : reference.time(i - 1) + static_cast<double>(k) * h);
    grid.sample_step[static_cast<size_t>(i)] = static_cast<long>(grid.time.size()) - 1;
    if (h > grid.dt) {
      grid.dt = h;
      grid.steps_per_sample = steps;
    }
  }
  return grid;
}

// Target of the driven joint at time t.
class DriverLaw {
 public:
  DriverLaw(const Mechanism& m, const Trajectory& reference, const DrivenJoint& driven)
      : m_(m), reference_(reference), driven_(driven) {
    // Knots of an equivalent driver: the usable samples only (a flagged sample's rates may be
    // infinite or on another branch).
    for (int i = 0; i < reference.samples(); ++i)
      if (usable(reference.status[static_cast<size_t>(i)])) {
        knots_.push_back(i);
        knot_times_.push_back(reference.time(i));
      }
  }

  // The driven joint's rate at each reference sample (equivalent drivers; 0 where flagged).
  Eigen::VectorXd reference_rates() const {
    Eigen::VectorXd rate = Eigen::VectorXd::Zero(reference_.samples());
    for (int i : knots_) rate(i) = relative(i)(1);
    return rate;
  }

  double at(double t) const {
    if (!driven_.equivalent) return driven_.sign * (m_.driver.at_time(t).value - driven_.offset);
    // Quintic Hermite through the reference's angle, omega and alpha of the driven joint.
    const int n = static_cast<int>(knots_.size());
    const int k =
        std::clamp(static_cast<int>(std::upper_bound(knot_times_.begin(), knot_times_.end(), t) -
                                    knot_times_.begin()) -
                       1,
                   0, n - 2);
    const int i = knots_[static_cast<size_t>(k)], i1 = knots_[static_cast<size_t>(k + 1)];
    const double h = reference_.time(i1) - reference_.time(i);
    const double u = (t - reference_.time(i)) / h;
    const Eigen::Vector3d p0 = relative(i), p1 = relative(i1);
    const double y0 = p0(0), y1 = p1(0), v0 = p0(1) * h, v1 = p1(1) * h;
    const double a0 = p0(2) * h * h, a1 = p1(2) * h * h;
    const double u2 = u * u, u3 = u2 * u, u4 = u3 * u, u5 = u4 * u;
    const double h0 = 1 - 10 * u3 + 15 * u4 - 6 * u5, h1 = u - 6 * u3 + 8 * u4 - 3 * u5;
    const double h2 = 0.5 * (u2 - 3 * u3 + 3 * u4 - u5), h3 = 0.5 * (u3 - 2 * u4 + u5);
    const double h4 = -4 * u3 + 7 * u4 - 3 * u5, h5 = 10 * u3 - 15 * u4 + 6 * u5;
    return h0 * y0 + h1 * v0 + h2 * a0 + h3 * a1 + h4 * v1 + h5 * y1;
  }

 private:
  // (angle, omega, alpha) of link_b relative to link_a in reference sample i.
  Eigen::Vector3d relative(int i) const {
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    auto add = [&](int link, double sign) {
      if (link < 0) return;
      const int k = m_.moving_index(link);
      r += sign *
           Eigen::Vector3d(reference_.angle(i, k), reference_.omega(i, k), reference_.alpha(i, k));
    };
    add(driven_.link_b, 1.0);
    add(driven_.link_a, -1.0);
    return r;
  }

  const Mechanism& m_;
  const Trajectory& reference_;
  const DrivenJoint& driven_;
  std::vector<int> knots_;
  std::vector<double> knot_times_;
};

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
  o.gravity = m.gravity;
  return o;
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

// A scene link's motion: a mechanism link's, or a block's (its guide's rotation, at its pin).
BodyMotion motion_of(const Mechanism& m, const Scene& s, int link, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& qdot) {
  const SceneLink& sl = s.links[link];
  if (sl.source >= 0) return BodyMotion::of(m.moving_index(sl.source), q, &qdot, nullptr);
  BodyMotion block = motion_of(m, s, sl.guide, q, qdot);
  const BodyMotion pin = motion_of(m, s, sl.pin, q, qdot);
  block.r = pin.position(sl.pin_point);
  block.v = pin.velocity(sl.pin_point);
  return block;
}

// Value (qpos) of a scene joint and its rate, from the mechanism's absolute coordinates.
Eigen::Vector2d joint_motion(const Mechanism& m, const Scene& s, const SceneJoint& j,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) {
  const BodyMotion a = motion_of(m, s, j.a, q, qdot), b = motion_of(m, s, j.b, q, qdot);
  if (j.kind == SceneJoint::Kind::hinge) return {b.theta - a.theta, b.omega - a.omega};
  const Projection p = project(a, j.origin, j.direction, b, j.ub);
  return {p.value, p.rate};
}

// perturb_link "<link>:<factor>": the mechanism with that link's points and line origins
// scaled. The scene is then assembled for it, so the engine runs a valid but wrong linkage.
Mechanism perturbed(const Mechanism& m, const std::string& text) {
  if (text.empty() || text == "none") return m;
  const size_t colon = text.rfind(':');
  const int link = colon == std::string::npos ? -1 : m.find_link(text.substr(0, colon));
  const double factor =
      colon == std::string::npos ? 0.0 : parse_number("perturb_link", text.substr(colon + 1));
  if (link < 0 || m.links[link].ground || !(factor > 0.0))
    throw std::runtime_error(
        fmt::format("perturb_link \"{}\": expected \"<moving link>:<positive factor>\"", text));
  Mechanism out = m;
  for (Point& p : out.links[link].points) p.local *= factor;
  for (Line& l : out.links[link].lines) l.origin *= factor;
  return out;
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
};

Prepared prepare(const Mechanism& m, const Trajectory& reference, const Settings& overrides) {
  Prepared p;
  p.config = parse_settings(overrides);
  const Mechanism scene_mechanism = perturbed(m, p.config.perturb_link);
  p.span = usable_span(reference);
  p.grid = time_grid(reference, p.config, p.span);
  // A sweep over the whole cycle, usable throughout, is periodic: the run may start kPreroll
  // steps before the first sample and end kPreroll after the last (the end of the previous
  // cycle, the start of the next), so every sample has a central stencil clear of the start's
  // transient. Otherwise the run stays within the usable samples (one-sided at the ends).
  const int n = reference.samples();
  const double period = m.cycle_period();
  const double h0 = p.grid.time[1] - p.grid.time[0];
  const double h1 = p.grid.time.back() - p.grid.time[p.grid.time.size() - 2];
  const bool periodic =
      p.span.first == 0 && p.span.last == n - 1 && period > 0.0 && n > 1 &&
      reference.time(n - 1) - reference.time(0) + (reference.time(1) - reference.time(0)) >=
          period * (1.0 - 1e-9);
  std::optional<Start> start;
  if (periodic) {
    start = exact_start(scene_mechanism, reference, p.span.first,
                        reference.time(0) - static_cast<double>(kPreroll) * h0);
    if (start) {
      std::vector<double> time;
      for (long k = kPreroll; k >= 1; --k)
        time.push_back(reference.time(0) - static_cast<double>(k) * h0);
      time.insert(time.end(), p.grid.time.begin(), p.grid.time.end());
      for (long k = 1; k <= kPreroll; ++k)
        time.push_back(reference.time(n - 1) + static_cast<double>(k) * h1);
      p.grid.time = std::move(time);
      for (long& step : p.grid.sample_step)
        if (step >= 0) step += kPreroll;
      p.periodic = true;
    }
  }
  if (!start)
    start = exact_start(scene_mechanism, reference, p.span.first, reference.time(p.span.first));
  if (!start) throw std::runtime_error("could not close the loops at the first usable sample");
  p.start = *start;
  p.scene = mujoco_scene::build_scene(scene_mechanism, p.start.q, &reference);
  p.options = mjcf_options(m, p.config, p.grid.dt);
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

// Largest gap of any cut joint [m], from the bodies' world frames and the scene's points.
double loop_gap(const Scene& s, const std::vector<std::array<int, 2>>& cut_bodies,
                const mjData* d) {
  double gap = 0.0;
  for (size_t c = 0; c < s.cuts.size(); ++c) {
    const SceneJoint& j = s.joints[s.cuts[c]];
    Eigen::Vector3d p[2];
    const Eigen::Vector2d local[2] = {j.ua, j.ub};
    for (int side = 0; side < 2; ++side) {
      const int body = cut_bodies[c][side];
      const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> mat(d->xmat + 9 * body);
      p[side] = Eigen::Map<const Eigen::Vector3d>(d->xpos + 3 * body) +
                mat * Eigen::Vector3d(local[side].x(), local[side].y(), 0.0);
    }
    gap = std::max(gap, (p[0] - p[1]).norm());
  }
  return gap;
}

// ---------------------------------------------------------------------------------------------
// Reading forces

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
    driver_eq_ = mj_name2id(mm, mjOBJ_EQUALITY, "driver");
    for (const SceneJoint& j : s.joints)
      cut_eq_.push_back(j.in_tree ? -1 : mj_name2id(mm, mjOBJ_EQUALITY, j.name.c_str()));
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
    if (d2->ne != ne || d2->nefc != ne)
      throw std::runtime_error("MuJoCo: the constraint rows changed between step and read");
    Eigen::VectorXd force = Eigen::Map<const Eigen::VectorXd>(d->efc_force, ne);
    // No constraint row (forward dynamics of an open chain: no driver equality, no cut joint,
    // IFToMM A01's pendulum): nothing to centre, and Eigen's decomposition of an nv x 0 matrix
    // reads out of bounds.
    if (centred_ && ne > 0) {
      const Eigen::Map<const Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
          jacobian(d->efc_J, ne, nv);
      const Eigen::VectorXd bias = Eigen::Map<const Eigen::VectorXd>(d2->qfrc_bias, nv) -
                                   Eigen::Map<const Eigen::VectorXd>(d->qfrc_bias, nv);
      // Least squares: a connect's z row is zero in a planar scene.
      force += jacobian.transpose().completeOrthogonalDecomposition().solve(bias);
    }
    std::copy(force.data(), force.data() + ne, d2->efc_force);
    std::copy(d->qacc, d->qacc + nv, d2->qacc);
    mj_rnePostConstraint(mm_, d2);
    extract(d2, force, out);
  }

  // MuJoCo's own forces at the state of `forwarded`, on which mj_forward has just run (its
  // constraint forces and accelerations at its positions and velocities).
  void read_state(mjData* forwarded, ForceReading& out) {
    mj_rnePostConstraint(mm_, forwarded);
    extract(forwarded, Eigen::Map<const Eigen::VectorXd>(forwarded->efc_force, forwarded->ne), out);
  }

 private:
  // The reading from d2 (constraint rows, and cfrc_int after mj_rnePostConstraint) with the
  // equality forces `force`. Without a driver equality (forward dynamics) the effort is left at
  // zero: it is an applied load there, not a reaction.
  void extract(const mjData* d2, const Eigen::VectorXd& force, ForceReading& out) const {
    const int ne = d2->ne;
    out.set_zero();
    const auto row_of = [&](int eq) {
      for (int r = 0; r < ne; ++r)
        if (d2->efc_type[r] == mjCNSTR_EQUALITY && d2->efc_id[r] == eq) return r;
      throw std::runtime_error("MuJoCo: no constraint row for an equality");
    };
    out.effort = driver_eq_ >= 0 ? s_.driven.sign * force(row_of(driver_eq_)) : 0.0;
    for (size_t ji = 0; ji < s_.joints.size(); ++ji) {
      const SceneJoint& j = s_.joints[ji];
      const Joint& mj = m_.joints[static_cast<size_t>(j.source)];
      // A pin-in-slot's force is its pin's (the block between is massless to 1e-6).
      if (mj.type == JointType::pin_in_slot && j.kind == SceneJoint::Kind::slide) continue;
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
      if (driver_eq_ >= 0 && m_.driver.type == DriverType::slider && j.source == m_.driver.joint) {
        // The driver's axial force is the effort, not the joint's reaction.
        const Eigen::Vector2d u = world_direction(d2, j.a, j.direction);
        on_b -= out.effort * u;
      }
      out.joint_force[static_cast<size_t>(j.source)] = on_b;
    }
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
  std::vector<int> body_;    // per scene link: MuJoCo body id (world 0)
  std::vector<int> cut_eq_;  // per scene joint: its connect equality, -1 in the tree
  int driver_eq_ = -1;
};

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

// The exact initial state: the reference's first usable sample (its positions, velocities and
// accelerations are the exact reference's, to about 1e-10). With perturb_link the scene's chain
// is closed by Newton at the reference's coordinate and rate.
ReferenceState dynamics_start(const Mechanism& m, const Mechanism& scene_mechanism,
                              const Trajectory& reference, int first) {
  ReferenceState start = reference_state(m, reference, first);
  if (&m == &scene_mechanism) return start;
  DynamicsLoads balance(m);
  KinematicState state(scene_mechanism);
  state.q = start.q;
  state.driver = {reference.time(first), reference.driver(first), balance.rate(start.q, start.qdot),
                  0.0};
  const NewtonSolver solver(scene_mechanism);
  const SolveReport report = solver.solve(state);
  if (report.status != PoseStatus::ok)
    throw std::runtime_error("the perturbed chain does not close at the first sample: " +
                             report.message);
  start.q = state.q;
  start.qdot = state.qdot;
  return start;
}

Prepared prepare_dynamics(const Mechanism& m, const Trajectory& reference,
                          const Settings& overrides, ReferenceState* start_out = nullptr) {
  Prepared p;
  p.config = parse_settings(overrides);
  const bool perturb = p.config.perturb_link != "none" && !p.config.perturb_link.empty();
  const Mechanism perturbed_mechanism = perturb ? perturbed(m, p.config.perturb_link) : Mechanism();
  const Mechanism& scene_mechanism = perturb ? perturbed_mechanism : m;
  p.span = usable_span(reference);
  p.grid = time_grid(reference, p.config, p.span);
  // One step past the last sample, so that it has a central stencil too.
  const double h = p.grid.time.back() - p.grid.time[p.grid.time.size() - 2];
  p.grid.time.push_back(p.grid.time.back() + h);
  const ReferenceState start = dynamics_start(m, scene_mechanism, reference, p.span.first);
  p.start = Start{start.q, start.qdot};
  if (start_out) *start_out = start;
  p.scene = mujoco_scene::build_scene(scene_mechanism, start.q, &reference);
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
      x[0] = load.force.x();
      x[1] = load.force.y();
      x[5] = load.moment;
    }
  }

 private:
  DynamicsLoads loads_;
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

EngineRun run_dynamics(const Mechanism& m, const Trajectory& reference, const Settings& overrides) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point begin = Clock::now();
  const int samples = reference.samples();
  EngineRun run;
  run.trajectory.method = "mujoco";
  auto shape = [&](bool with_forces) {
    run.trajectory.resize(m, samples, with_forces);
    run.trajectory.add_energy();
    run.trajectory.time = reference.time;
    run.trajectory.driver = reference.driver;
  };
  shape(false);
  Prepared p;
  ReferenceState start;
  ModelPtr model;
  try {
    p = prepare_dynamics(m, reference, overrides, &start);
    model = load_model(p.mjcf);
  } catch (const std::exception& e) {
    run.settings = overrides;
    return failed(std::move(run), e.what());
  }
  const Scene& s = p.scene;
  const double size = s.size;
  const DynamicsChoices choice = dynamics_choices(p.config);
  const bool with_forces = true;
  shape(with_forces);
  const double gap_threshold = p.config.gap_threshold == "auto"
                                   ? 1e-4 * size
                                   : parse_number("gap_threshold", p.config.gap_threshold);
  // The energy the exact motion moves (a mechanism at rest in equilibrium moves none: then any
  // change is judged against 1e-12 J).
  const double energy_scale = std::max(reference_energy_scale(m, reference), 1e-12);
  const double singular_rcond = p.config.singular_rcond == "auto"
                                    ? kDynamicsSingularRcond
                                    : parse_number("singular_rcond", p.config.singular_rcond);
  run.settings = {
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
      {"gap_threshold", fmt::format("{:.6g}", gap_threshold)},
      {"perturb_link", p.config.perturb_link},
      {"mass_model", "the definition's (Link::mass)"},
      {"driver", "none: the coordinate moves under the applied effort (forward dynamics)"},
      {"start", choice.staggered ? "staggered (v0 - h/2 a0)" : "exact (v0)"},
      {"readout", choice.state_readout ? "state (MuJoCo's velocity; mj_forward acceleration)"
                                       : "differences (3-point central of step positions)"},
      {"energy_threshold", fmt::format("{:g}", p.config.energy_threshold)},
      {"divergence_energy", fmt::format("{:g}", p.config.divergence_energy)},
      {"energy_scale", fmt::format("{:.6g} J", energy_scale)},
      {"singular_rcond", fmt::format("{:g}", singular_rcond)},
  };

  mjModel* mm = model.get();
  DataPtr data(mj_makeData(mm)), state_data(mj_makeData(mm));
  mjData* d = data.get();
  const int nq = mm->nq, nv = mm->nv;
  std::vector<std::array<int, 2>> cut_bodies;
  for (int c : s.cuts) {
    const SceneJoint& j = s.joints[c];
    auto body = [&](int link) {
      return s.links[link].ground ? 0 : mj_name2id(mm, mjOBJ_BODY, s.links[link].name.c_str());
    };
    cut_bodies.push_back({body(j.a), body(j.b)});
  }
  const Mechanism& scene_mechanism = m;  // the scene's joints map the definition's links
  for (const SceneJoint& j : s.joints) {
    if (!j.in_tree) continue;
    const int id = mj_name2id(mm, mjOBJ_JOINT, j.name.c_str());
    d->qvel[mm->jnt_dofadr[id]] = joint_motion(scene_mechanism, s, j, start.q, start.qdot)(1);
  }
  const std::vector<double>& grid = p.grid.time;
  const long last_step = static_cast<long>(grid.size()) - 1;
  const double h0 = grid[1] - grid[0];
  d->time = grid[0];

  // The loads, and the start: MuJoCo's own acceleration at the exact state sets the staggered
  // velocity and the pose one step before the start (central differences at the first sample).
  LoadHook hook(m, s, mm);
  const HookScope scope(hook.any() ? &hook : nullptr);
  ForceReader force_reader(m, s, mm, p.config.force_read == "centred");
  DynamicsLoads balance(m);
  mj_forward(mm, d);
  std::vector<mjtNum> v0(d->qvel, d->qvel + nv), w(static_cast<size_t>(nv));
  for (int i = 0; i < nv; ++i) w[static_cast<size_t>(i)] = v0[i] - 0.5 * h0 * d->qacc[i];
  if (choice.staggered) std::copy(w.begin(), w.end(), d->qvel);
  mjData* sd = state_data.get();
  std::copy(d->qpos, d->qpos + nq, sd->qpos);
  const bool euler_like = p.config.integrator != "RK4";
  mj_integratePos(mm, sd->qpos, euler_like ? d->qvel : w.data(), -h0);
  mj_kinematics(mm, sd);
  PoseReader before_reader(m, s, mm, start.q);
  const Eigen::VectorXd before_start = before_reader.read(sd);

  // Per step (ring of the last kRing): poses, the state (for the state readout), the work done
  // so far and the power at the step.
  constexpr long kRing = 16;
  PoseReader reader(m, s, mm, start.q);
  std::array<Eigen::VectorXd, kRing> ring;
  std::array<std::vector<mjtNum>, kRing> ring_qpos, ring_qvel;
  std::array<double, kRing> ring_work{}, ring_power{};
  auto slot = [](long k) { return static_cast<size_t>(((k % kRing) + kRing) % kRing); };
  auto pose = [&](long k) -> const Eigen::VectorXd& {
    return k < 0 ? before_start : ring[slot(k)];
  };
  auto keep_state = [&](long k) {
    ring_qpos[slot(k)].assign(d->qpos, d->qpos + nq);
    ring_qvel[slot(k)].assign(d->qvel, d->qvel + nv);
  };
  ring[slot(0)] = reader.read(d);
  keep_state(0);
  // The sample on each step (-1: none).
  std::vector<int> sample_of(static_cast<size_t>(last_step + 1), -1);
  for (int i = p.span.first; i <= p.span.last; ++i)
    sample_of[static_cast<size_t>(p.grid.sample_step[static_cast<size_t>(i)])] = i;

  const NewtonSolver writer(m);
  KinematicState state(m), probe(m);
  ForceReading reading(m.joints.size());
  std::vector<mjtNum> qpos_before(static_cast<size_t>(nq));
  Eigen::VectorXd gaps = Eigen::VectorXd::Zero(samples);
  std::vector<bool> recorded(static_cast<size_t>(samples), false);
  Eigen::MatrixXd sample_q = Eigen::MatrixXd::Zero(m.coordinate_count(), samples);
  const double initial_energy = balance.kinetic(start.q, start.qdot) + balance.potential(start.q);
  int drift_at = -1;
  std::string stopped;
  int interval = p.span.first;

  // Records sample i on step S (called once step S + 1 is taken).
  auto record = [&](int i, long S) {
    const double t = grid[static_cast<size_t>(S)];
    state.q = pose(S);
    if (choice.state_readout) {
      std::copy(ring_qpos[slot(S)].begin(), ring_qpos[slot(S)].end(), sd->qpos);
      std::copy(ring_qvel[slot(S)].begin(), ring_qvel[slot(S)].end(), sd->qvel);
      sd->time = t;
      mj_forward(mm, sd);
      force_reader.read_state(sd, reading);
      state_rates(m, s, mm, sd, state.qdot, state.qddot);
    } else {
      const double hb = t - (S > 0 ? grid[static_cast<size_t>(S - 1)] : t - h0);
      const double ha = grid[static_cast<size_t>(S + 1)] - t;
      const auto wts = stencil_weights(0.0, {-hb, 0.0, ha});
      state.qdot = wts[1][0] * pose(S - 1) + wts[1][1] * pose(S) + wts[1][2] * pose(S + 1);
      state.qddot = wts[2][0] * pose(S - 1) + wts[2][1] * pose(S) + wts[2][2] * pose(S + 1);
    }
    const double coordinate = balance.coordinate(state.q);
    state.driver = {t, coordinate, balance.rate(state.q, state.qdot), 0.0};
    writer.write_sample(state, SolveReport{}, run.trajectory, i);
    run.trajectory.driver(i) = coordinate;
    reading.effort = m.dynamics->effort_at(t);
    write_forces(m, state, reading, run.trajectory, i);
    const double kinetic = balance.kinetic(state.q, state.qdot);
    const double potential = balance.potential(state.q);
    const double work = ring_work[slot(S)];
    const double error = kinetic + potential - work - initial_energy;
    run.trajectory.energy.row(i) << kinetic, potential, work, error;
    recorded[static_cast<size_t>(i)] = true;
    sample_q.col(i) = state.q;
    if (drift_at < 0 && std::abs(error) > p.config.energy_threshold * energy_scale) drift_at = i;
    if (!(std::abs(error) <= p.config.divergence_energy * energy_scale))
      stopped = fmt::format(
          "diverged at t = {:.6g} s: the energy balance is off by {:.3g} J, {:.3g} times the "
          "energy the exact motion moves ({:.3g} J)",
          t, error, std::abs(error) / energy_scale, energy_scale);
  };

  const Clock::time_point stepping = Clock::now();
  const double cpu_start = thread_cpu_seconds();
  long steps_taken = 0;
  for (long step = 1; step <= last_step && stopped.empty(); ++step) {
    const double t0 = grid[static_cast<size_t>(step - 1)];
    const double h = grid[static_cast<size_t>(step)] - t0;
    if (mm->opt.timestep != h) {
      mm->opt.timestep = h;
      if (p.config.solref == "deadbeat")
        for (int e = 0; e < mm->neq; ++e) {
          mm->eq_solref[mjNREF * e] = -1.0 / (h * h);
          mm->eq_solref[mjNREF * e + 1] = -1.0 / h;
        }
    }
    d->time = t0;
    const int leaving = sample_of[static_cast<size_t>(step - 1)];
    const bool read = leaving >= 0 && !choice.state_readout;
    if (read) std::copy(d->qpos, d->qpos + nq, qpos_before.begin());
    mj_step(mm, d);
    if (read) force_reader.read(d, qpos_before, h, reading);
    mj_kinematics(mm, d);
    ++steps_taken;
    while (interval < p.span.last && step > p.grid.sample_step[static_cast<size_t>(interval)])
      ++interval;
    const double gap = loop_gap(s, cut_bodies, d);
    gaps(interval) = std::max(gaps(interval), gap);
    ring[slot(step)] = reader.read(d);
    keep_state(step);
    if (!ring[slot(step)].allFinite() || !std::isfinite(gap) || gap > size ||
        d->warning[mjWARN_BADQACC].number > 0) {
      stopped = fmt::format("diverged at t = {:.6g} s (loop gap {:.3g} m)",
                            grid[static_cast<size_t>(step)], gap);
      break;
    }
    // The work up to the step before: the power there from the poses on either side.
    const long k = step - 1;
    if (balance.any()) {
      const double hb =
          grid[static_cast<size_t>(k)] - (k > 0 ? grid[static_cast<size_t>(k - 1)] : grid[0] - h0);
      const auto wts = stencil_weights(0.0, {-hb, 0.0, h});
      const Eigen::VectorXd velocity =
          wts[1][0] * pose(k - 1) + wts[1][1] * pose(k) + wts[1][2] * pose(k + 1);
      ring_power[slot(k)] = balance.power(grid[static_cast<size_t>(k)], pose(k), velocity);
      ring_work[slot(k)] = k == 0 ? 0.0
                                  : ring_work[slot(k - 1)] +
                                        0.5 * hb * (ring_power[slot(k - 1)] + ring_power[slot(k)]);
    }
    if (leaving >= 0) record(leaving, k);
  }
  const double stepping_seconds = std::chrono::duration<double>(Clock::now() - stepping).count();
  const double stepping_cpu = thread_cpu_seconds() - cpu_start;

  // Statuses: outside the usable span the reference's flag; unreached samples diverged; a sample
  // the reference flags keeps that flag (run through); then the gap and the conditioning.
  Trajectory& out = run.trajectory;
  out.loop_gap = gaps;
  int flagged = 0, copied = 0, first_lost = -1, near_singular = 0;
  for (int i = 0; i < samples; ++i) {
    const auto row = static_cast<size_t>(i);
    const PoseStatus ref_status = reference.status[row];
    if (i < p.span.first || i > p.span.last) {
      out.status[row] = ref_status;
      out.rcond(i) = reference.rcond(i);
      continue;
    }
    if (!recorded[row]) {
      out.status[row] = PoseStatus::diverged;
      if (first_lost < 0) first_lost = i;
      continue;
    }
    probe.q = sample_q.col(i);
    probe.driver.value = out.driver(i);
    out.rcond(i) = writer.solve_position(probe).rcond;
    if (!usable(ref_status)) {
      out.status[row] = ref_status;
      ++copied;
    } else if (gaps(i) > gap_threshold) {
      out.status[row] = PoseStatus::loop_gap;
      ++flagged;
    } else if (out.rcond(i) < singular_rcond) {
      out.status[row] = PoseStatus::singular;
      ++near_singular;
    }
  }
  auto note = [&](const std::string& text) {
    run.message = run.message.empty() ? text : run.message + "; " + text;
  };
  if (!stopped.empty()) {
    run.ok = false;
    note(stopped);
    out.events.push_back(
        {first_lost >= 0 ? reference.driver(first_lost) : 0.0, PoseStatus::diverged, stopped});
  }
  if (drift_at >= 0) {
    const std::string text = fmt::format(
        "energy drift: the balance is off by more than {:g} of the energy scale ({:.3g} J) from "
        "t = {:.6g} s (sample {}); worst {:.3g} J",
        p.config.energy_threshold, energy_scale, reference.time(drift_at), drift_at,
        out.energy.col(3).cwiseAbs().maxCoeff());
    note(text);
    out.events.push_back({reference.driver(drift_at), PoseStatus::ok, text});
  }
  if (p.span.first > 0 || p.span.last < samples - 1)
    note(fmt::format("run over the reference's usable samples {} .. {} (t = {:.6g} .. {:.6g} s)",
                     p.span.first, p.span.last, reference.time(p.span.first),
                     reference.time(p.span.last)));
  if (copied > 0) note(fmt::format("{} samples keep the reference's flag (run through)", copied));
  if (near_singular > 0)
    note(
        fmt::format("{} samples flagged singular (constraint Jacobian rcond below {:g} at the "
                    "engine's configuration: next to a singular position)",
                    near_singular, singular_rcond));
  if (flagged > 0) {
    note(fmt::format("{} samples flagged loop_gap (largest gap {:.3g} m > threshold {:.3g} m)",
                     flagged, gaps.maxCoeff(), gap_threshold));
    for (int i = 0; i < samples; ++i)
      if (out.status[static_cast<size_t>(i)] == PoseStatus::loop_gap &&
          (i == 0 || out.status[static_cast<size_t>(i - 1)] != PoseStatus::loop_gap))
        out.events.push_back(
            {reference.driver(i), PoseStatus::loop_gap, fmt::format("loop gap {:.3g} m", gaps(i))});
  }
  run.cost.steps = steps_taken;
  run.cost.simulated_seconds = grid[static_cast<size_t>(steps_taken)] - grid.front();
  if (run.cost.simulated_seconds > 0.0) {
    run.cost.wall_seconds_per_cycle = stepping_seconds / run.cost.simulated_seconds;
    run.cost.cpu_seconds_per_cycle = stepping_cpu / run.cost.simulated_seconds;
  }
  run.cost.wall_seconds = std::chrono::duration<double>(Clock::now() - begin).count();
  return run;
}

class MujocoEngine final : public Engine {
 public:
  std::string name() const override { return "mujoco"; }

  bool supports(const Mechanism& mechanism, std::string* why) const override {
    return mujoco_scene::realisable(mechanism, why);
  }

  // Every name and every value that does not depend on the mechanism (dt's positivity and the
  // deadbeat solref's step are checked when the scene is built).
  void check_settings(const Settings& overrides) const override {
    try {
      const Config c = parse_settings(overrides);
      for (const auto& [name, text] : {std::pair<const char*, const std::string&>{"dt", c.dt},
                                       {"gap_threshold", c.gap_threshold},
                                       {"driver_threshold", c.driver_threshold},
                                       {"singular_rcond", c.singular_rcond}})
        if (text != "auto") (void)parse_number(name, text);
      for (const auto& [name, text] :
           {std::pair<const char*, const std::string&>{"solref", c.solref},
            {"driver_solref", c.driver_solref}})
        (void)solref_of(name, text, 1.0);
      (void)solimp_of("solimp", c.solimp);
      (void)solimp_of("driver_solimp", c.driver_solimp);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(e.what());
    }
  }

  EngineRun run(const Mechanism& m, const Trajectory& reference,
                const Settings& overrides) const override {
    if (m.dynamics) return run_dynamics(m, reference, overrides);
    using Clock = std::chrono::steady_clock;
    const Clock::time_point begin = Clock::now();
    EngineRun run;
    run.trajectory.method = "mujoco";
    run.trajectory.resize(m, reference.samples());
    run.trajectory.time = reference.time;
    run.trajectory.driver = reference.driver;
    Prepared p;
    ModelPtr model;
    try {
      p = prepare(m, reference, overrides);
      model = load_model(p.mjcf);
    } catch (const std::exception& e) {
      run.settings = overrides;
      return failed(std::move(run), e.what());
    }
    const Scene& s = p.scene;
    const double size = s.size;
    // Forces are the definition's only when the scene drives the definition's driver.
    const bool with_forces = !s.driven.equivalent;
    run.trajectory.resize(m, reference.samples(), with_forces);
    run.trajectory.time = reference.time;
    run.trajectory.driver = reference.driver;
    const double gap_threshold = p.config.gap_threshold == "auto"
                                     ? 1e-4 * size
                                     : parse_number("gap_threshold", p.config.gap_threshold);
    const bool angular_joint = s.joints[s.driven.joint].kind == SceneJoint::Kind::hinge;
    const double kinematic_singular_rcond =
        p.config.singular_rcond == "auto" ? kSingularRcond
                                          : parse_number("singular_rcond", p.config.singular_rcond);
    const double driver_threshold =
        p.config.driver_threshold == "auto"
            ? (angular_joint ? 1e-3 : 1e-3 * size)
            : parse_number("driver_threshold", p.config.driver_threshold);
    run.settings = {
        {"dt", fmt::format("{:.9g}", p.grid.dt)},
        {"steps_per_sample", std::to_string(p.grid.steps_per_sample)},
        {"max_step_angle", p.config.dt == "auto" ? fmt::format("{:g}", p.config.max_step_angle)
                                                 : "unused (dt given)"},
        {"integrator", p.options.integrator},
        {"solver", p.options.solver},
        {"iterations", std::to_string(p.options.iterations)},
        {"tolerance", fmt::format("{:g}", p.options.tolerance)},
        {"solref", numbers(p.options.solref)},
        {"solimp", numbers(p.options.solimp)},
        {"driver_solref", numbers(p.options.driver_solref)},
        {"driver_solimp", numbers(p.options.driver_solimp)},
        {"gap_threshold", fmt::format("{:.6g}", gap_threshold)},
        {"driver_threshold", fmt::format("{:.6g}", driver_threshold)},
        {"singular_rcond", fmt::format("{:g}", kinematic_singular_rcond)},
        {"perturb_link", p.config.perturb_link},
        {"mass_model", "the definition's (Link::mass)"},
        {"force_read",
         with_forces ? p.config.force_read : "none (equivalent driver: another joint is driven)"},
        {"derivatives",
         "3-point central differences of step positions; 4-point one-sided at the first and "
         "last usable samples"},
    };

    // The scene's joints, the cut joints' bodies and the driver equality.
    mjModel* mm = model.get();
    DataPtr data(mj_makeData(mm));
    mjData* d = data.get();
    const int driver_eq = mj_name2id(mm, mjOBJ_EQUALITY, "driver");
    const SceneJoint& driven = s.joints[s.driven.joint];
    const int driven_id = mj_name2id(mm, mjOBJ_JOINT, driven.name.c_str());
    const int driven_qpos = mm->jnt_qposadr[driven_id];
    std::vector<std::array<int, 2>> cut_bodies;
    for (int c : s.cuts) {
      const SceneJoint& j = s.joints[c];
      auto body = [&](int link) {
        return s.links[link].ground ? 0 : mj_name2id(mm, mjOBJ_BODY, s.links[link].name.c_str());
      };
      cut_bodies.push_back({body(j.a), body(j.b)});
    }
    // Start at rest on the exact configuration, moving with the exact velocities.
    for (const SceneJoint& j : s.joints) {
      if (!j.in_tree) continue;
      const int id = mj_name2id(mm, mjOBJ_JOINT, j.name.c_str());
      d->qvel[mm->jnt_dofadr[id]] = joint_motion(m, s, j, p.start.q, p.start.qdot)(1);
    }
    if (s.driven.equivalent)
      run.message = fmt::format(
          "the driver ({}) is not a joint MuJoCo can drive; equivalent driver: joint {} follows "
          "the exact trajectory of its angle (quintic Hermite through the reference samples); "
          "samples are mapped by the definition's driver; forces not read (the scene's driver "
          "acts at another joint than the definition's)",
          to_string(m.driver.type), driven.name);
    mj_forward(mm, d);
    ForceReader force_reader(m, s, mm, p.config.force_read == "centred");
    AppliedLoads loads(m);
    std::vector<int> load_body;  // per moving link: MuJoCo body id
    for (const SceneLink& link : s.links)
      if (link.source >= 0 && !link.ground)
        load_body.push_back(mj_name2id(mm, mjOBJ_BODY, link.name.c_str()));

    // Step and sample. The run starts at step 0, the exact first usable sample, and steps
    // forward to the last usable sample, never beyond (outside them the reference is at or past
    // an assembly limit). Step k ends at grid.time[k]; sample i is step S_i, read with 3-point
    // central differences over steps S_i - 1 .. S_i + 1 where those steps exist, else (the first
    // and last samples, or a sample on step 1) with one-sided 4-point differences over the
    // nearest steps. Step 0 is never in a stencil: the exact start lacks the O(dt^2) curvature
    // residual every later step has (docs/engines.md), so a stencil through it would see that
    // residual as an acceleration; the first sample is extrapolated from steps 1..4.
    const DriverLaw law(m, reference, s.driven);
    const NewtonSolver writer(m);
    KinematicState state(m), probe(m);
    const int samples = reference.samples();
    const Span span = p.span;
    Eigen::MatrixXd sample_q = Eigen::MatrixXd::Zero(m.coordinate_count(), samples);
    const std::vector<double>& grid = p.grid.time;
    const long last_step = static_cast<long>(grid.size()) - 1;
    const double qpos0 = mm->qpos0[driven_qpos];
    // Each sample's stencil (steps), fixed before stepping.
    std::vector<std::vector<long>> stencil(static_cast<size_t>(samples));
    const long usable_steps = last_step;  // steps 1 .. last_step (step 0 is the start)
    if (usable_steps < 3) {
      return failed(std::move(run),
                    fmt::format("only {} steps between the first and last usable samples: too few "
                                "for differences",
                                usable_steps));
    }
    for (int i = span.first; i <= span.last; ++i) {
      const long at = p.grid.sample_step[static_cast<size_t>(i)];
      std::vector<long>& st = stencil[static_cast<size_t>(i)];
      if (at - 1 >= 1 && at + 1 <= last_step) {
        st = {at - 1, at, at + 1};
      } else {
        const long count = std::min(4L, usable_steps);
        const long from = std::clamp(at - count / 2, 1L, last_step - count + 1);
        for (long k = from; k < from + count; ++k) st.push_back(k);
      }
    }
    // Each sample's force stencil (forces of the poses a step leaves), and the poses to read.
    std::vector<ForceStencil> force_stencil_of(static_cast<size_t>(samples));
    std::vector<bool> read_forces(static_cast<size_t>(last_step + 1), false);
    if (with_forces)
      for (int i = span.first; i <= span.last; ++i) {
        ForceStencil& fs = force_stencil_of[static_cast<size_t>(i)];
        fs = force_stencil(reference.time(i), last_step, grid);
        for (long k : fs.steps) read_forces[static_cast<size_t>(k)] = true;
      }
    // The step that completes a sample: its last pose, and the step after its last force pose.
    auto complete_at = [&](int i) {
      const ForceStencil& fs = force_stencil_of[static_cast<size_t>(i)];
      long at = stencil[static_cast<size_t>(i)].back();
      for (long k : fs.steps) at = std::max(at, k + 1);
      return at;
    };
    const double driver_offset =
        reference.driver(span.first) - m.driver.at_time(reference.time(span.first)).value;
    // A step of a new length: the deadbeat softness follows it.
    auto set_step = [&](double h) {
      if (mm->opt.timestep == h) return;
      mm->opt.timestep = h;
      for (int e = 0; e < mm->neq; ++e) {
        const std::string& choice = e == driver_eq ? p.config.driver_solref : p.config.solref;
        if (choice != "deadbeat") continue;
        mm->eq_solref[mjNREF * e] = -1.0 / (h * h);
        mm->eq_solref[mjNREF * e + 1] = -1.0 / h;
      }
    };
    PoseReader reader(m, s, mm, p.start.q);
    constexpr long kRing = 16;  // poses of the last steps, by step mod kRing
    std::array<Eigen::VectorXd, kRing> ring;
    Eigen::VectorXd gaps = Eigen::VectorXd::Zero(samples);
    std::vector<bool> recorded(static_cast<size_t>(samples), false);
    auto pose = [&](long k) -> Eigen::VectorXd& { return ring[static_cast<size_t>(k % kRing)]; };
    pose(0) = reader.read(d);
    std::vector<double> times;
    std::array<ForceReading, kRing> readings;
    readings.fill(ForceReading(m.joints.size()));
    auto reading = [&](long k) -> ForceReading& {
      return readings[static_cast<size_t>(k % kRing)];
    };
    ForceReading combined(m.joints.size());
    std::vector<mjtNum> qpos_before(static_cast<size_t>(mm->nq));
    Eigen::VectorXd velocity(m.coordinate_count());
    // The definition's loads and springs on the bodies at pose k, at its velocity: a one-sided
    // difference of the last poses (the exact velocity at the start).
    auto apply_loads = [&](long k) {
      if (!loads.any()) return;
      const double t = grid[static_cast<size_t>(k)];
      if (k == 0) {
        velocity = p.start.qdot;
      } else {
        times.clear();
        for (long n = std::max(0L, k - 2); n <= k; ++n)
          times.push_back(grid[static_cast<size_t>(n)]);
        const auto w = stencil_weights(t, times);
        velocity.setZero();
        for (size_t n = 0; n < times.size(); ++n)
          velocity +=
              w[1][n] * pose(k - static_cast<long>(times.size()) + 1 + static_cast<long>(n));
      }
      const std::vector<BodyLoad>& on =
          loads.at(pose(k), velocity, m.driver.at_time(t).value + driver_offset);
      for (size_t b = 0; b < on.size(); ++b) {
        mjtNum* x = d->xfrc_applied + 6 * load_body[b];
        x[0] = on[b].force.x();
        x[1] = on[b].force.y();
        x[5] = on[b].moment;
      }
    };

    const Clock::time_point stepping = Clock::now();
    const double cpu_start = thread_cpu_seconds();
    long steps_taken = 0;
    int interval = span.first;  // the sample whose interval (S_i-1, S_i] holds the current step
    int pending = span.first;   // the next sample to record
    bool failed = false;
    for (long step = 1; step <= last_step; ++step) {
      const double t = grid[static_cast<size_t>(step)];
      set_step(t - grid[static_cast<size_t>(step - 1)]);
      const double target = law.at(t);
      // The driver equality holds qpos - qpos0 = eq_data[0]: aim at the end of this step.
      mm->eq_data[mjNEQDATA * driver_eq] = target - qpos0;
      apply_loads(step - 1);
      const bool read = read_forces[static_cast<size_t>(step - 1)];
      if (read) std::copy(d->qpos, d->qpos + mm->nq, qpos_before.begin());
      mj_step(mm, d);
      if (read) force_reader.read(d, qpos_before, mm->opt.timestep, reading(step - 1));
      mj_kinematics(mm, d);  // mj_step leaves xpos/xmat at the step's start
      ++steps_taken;
      // Watch: the gap, in the sample interval the step belongs to; NaN; the driver.
      while (interval < span.last && step > p.grid.sample_step[static_cast<size_t>(interval)])
        ++interval;
      const double gap = loop_gap(s, cut_bodies, d);
      gaps(interval) = std::max(gaps(interval), gap);
      pose(step) = reader.read(d);
      const double driver_error = std::abs(d->qpos[driven_qpos] - target);
      if (!pose(step).allFinite() || !std::isfinite(gap) || gap > size ||
          d->warning[mjWARN_BADQACC].number > 0) {
        run.ok = false;
        run.message = fmt::format("diverged at t = {:.6g} s (loop gap {:.3g} m){}", t, gap,
                                  run.message.empty() ? "" : "; " + run.message);
        failed = true;
        break;
      }
      if (driver_error > driver_threshold) {
        run.ok = false;
        run.message = fmt::format(
            "lost the driver at t = {:.6g} s: joint {} is {:.3g} from its target (loop gap "
            "{:.3g} m){}",
            t, driven.name, driver_error, gap, run.message.empty() ? "" : "; " + run.message);
        failed = true;
        break;
      }
      // The samples whose stencils this step completes.
      while (pending <= span.last && complete_at(pending) <= step) {
        const int i = pending++;
        const std::vector<long>& st = stencil[static_cast<size_t>(i)];
        times.clear();
        for (long k : st) times.push_back(grid[static_cast<size_t>(k)]);
        const auto w = stencil_weights(reference.time(i), times);
        state.q.setZero();
        state.qdot.setZero();
        state.qddot.setZero();
        for (size_t n = 0; n < st.size(); ++n) {
          state.q += w[0][n] * pose(st[n]);
          state.qdot += w[1][n] * pose(st[n]);
          state.qddot += w[2][n] * pose(st[n]);
        }
        state.driver = m.driver.at_time(reference.time(i));
        state.driver.value = reference.driver(i);
        writer.write_sample(state, SolveReport{}, run.trajectory, i);
        if (with_forces) {
          const ForceStencil& fs = force_stencil_of[static_cast<size_t>(i)];
          combined.set_zero();
          for (size_t n = 0; n < fs.steps.size(); ++n)
            combined.add(fs.weights[n], reading(fs.steps[n]));
          write_forces(m, state, combined, run.trajectory, i);
        }
        recorded[static_cast<size_t>(i)] = true;
        sample_q.col(i) = state.q;
      }
    }
    const double stepping_seconds = std::chrono::duration<double>(Clock::now() - stepping).count();
    const double stepping_cpu = thread_cpu_seconds() - cpu_start;

    // Statuses: outside the usable span the reference's flag (no engine value); inside, an
    // unreached sample is diverged, a sample the reference flags keeps that flag (the engine ran
    // through it), then the gap watch, the conditioning and the branch check.
    Trajectory& out = run.trajectory;
    out.loop_gap = gaps;
    int flagged = 0, singular = 0, jumped = 0, copied = 0;
    int first_lost = -1;
    for (int i = 0; i < samples; ++i) {
      const auto row = static_cast<size_t>(i);
      const PoseStatus ref_status = reference.status[row];
      if (i < span.first || i > span.last) {
        out.status[row] = ref_status;
        out.rcond(i) = reference.rcond(i);
        out.events.push_back({reference.driver(i), ref_status,
                              "outside the reference's usable samples: not run, the reference's "
                              "flag kept"});
        continue;
      }
      if (!recorded[row]) {
        out.status[row] = PoseStatus::diverged;
        if (first_lost < 0) first_lost = i;
        continue;
      }
      // Conditioning of the definition's constraints at the engine's configuration: MuJoCo
      // passes change points and toggles silently (Newton from there, on a scratch state).
      probe.q = sample_q.col(i);
      probe.driver = m.driver.at_time(reference.time(i));
      probe.driver.value = reference.driver(i);
      const SolveReport projected = writer.solve_position(probe);
      out.rcond(i) = projected.rcond;
      if (!usable(ref_status)) {
        out.status[row] = ref_status;
        out.events.push_back({reference.driver(i), ref_status,
                              "the reference flags this sample: run through, the flag kept"});
        ++copied;
        continue;
      }
      if (gaps(i) > gap_threshold) {
        out.status[row] = PoseStatus::loop_gap;
        ++flagged;
        continue;
      }
      if (out.rcond(i) < kinematic_singular_rcond) {
        out.status[row] = PoseStatus::singular;
        out.events.push_back({reference.driver(i), PoseStatus::singular,
                              fmt::format("the constraint Jacobian at the engine's configuration "
                                          "is singular (rcond {:.2g})",
                                          out.rcond(i))});
        ++singular;
        continue;
      }
      // Branch: the engine's configuration closed exactly (Newton on the definition from it)
      // must be the reference's. Another solution of the same equations is another assembly
      // mode: the engine took the other branch at a change point. A model error (a wrong
      // link) does not move the closed configuration and stays a reported difference.
      if (projected.status == PoseStatus::ok) {
        const double off =
            configuration_distance(probe.q, reference_coordinates(m, reference, i), size);
        if (off > kBranchDistance) {
          out.status[row] = PoseStatus::branch_jump;
          if (jumped == 0)
            out.events.push_back(
                {reference.driver(i), PoseStatus::branch_jump,
                 fmt::format("the engine closes the loops on another assembly mode than the "
                             "reference (closed configuration {:.3g} of the size or rad away)",
                             off)});
          ++jumped;
        }
      }
    }
    // An equivalent driver's own dead points: where its joint's rate vanishes, the chain driven
    // by that joint is singular and MuJoCo's soft solve is poorly conditioned.
    int dead = 0;
    if (s.driven.equivalent) {
      const Eigen::VectorXd rate = law.reference_rates();
      const double peak = rate.cwiseAbs().maxCoeff();
      for (int i = span.first; i <= span.last; ++i) {
        const auto row = static_cast<size_t>(i);
        if (out.status[row] != PoseStatus::ok || std::abs(rate(i)) >= kDeadRate * peak) continue;
        out.status[row] = PoseStatus::singular;
        out.events.push_back({reference.driver(i), PoseStatus::singular,
                              fmt::format("equivalent driver: joint {} turns at {:.2g} % of its "
                                          "peak rate (its own dead point)",
                                          driven.name, 100.0 * std::abs(rate(i)) / peak)});
        ++dead;
      }
    }
    auto note = [&](const std::string& text) {
      run.message = run.message.empty() ? text : run.message + "; " + text;
    };
    if (failed && first_lost >= 0)
      out.events.push_back({reference.driver(first_lost), PoseStatus::diverged, run.message});
    const int outside = span.first + (samples - 1 - span.last);
    if (outside > 0)
      note(fmt::format(
          "run over the reference's usable samples {} .. {} ({:.6g} .. {:.6g}); the {} samples "
          "outside (flagged by the reference: {}) keep its flag and carry no engine value",
          span.first, span.last, reference.driver(span.first), reference.driver(span.last), outside,
          to_string(reference.status[static_cast<size_t>(span.first > 0 ? 0 : samples - 1)])));
    if (copied > 0)
      note(
          fmt::format("{} samples inside the run keep the reference's flag (run through)", copied));
    if (dead > 0)
      note(fmt::format("{} samples flagged singular at the equivalent driver's dead point", dead));
    if (jumped > 0)
      note(fmt::format("{} samples flagged branch_jump (the engine is on another assembly mode)",
                       jumped));
    if (flagged > 0) {
      note(fmt::format("{} samples flagged loop_gap (largest gap {:.3g} m > threshold {:.3g} m)",
                       flagged, gaps.maxCoeff(), gap_threshold));
      for (int i = 0; i < samples; ++i)
        if (out.status[static_cast<size_t>(i)] == PoseStatus::loop_gap &&
            (i == 0 || out.status[static_cast<size_t>(i - 1)] != PoseStatus::loop_gap))
          out.events.push_back({reference.driver(i), PoseStatus::loop_gap,
                                fmt::format("loop gap {:.3g} m", gaps(i))});
    }
    (void)singular;

    run.cost.steps = steps_taken;
    run.cost.simulated_seconds = grid.back() - grid.front();
    const double cycle = m.cycle_period() > 0.0 ? m.cycle_period() : run.cost.simulated_seconds;
    if (run.cost.simulated_seconds > 0.0) {
      run.cost.wall_seconds_per_cycle = stepping_seconds * cycle / run.cost.simulated_seconds;
      run.cost.cpu_seconds_per_cycle = stepping_cpu * cycle / run.cost.simulated_seconds;
    }
    run.cost.wall_seconds = std::chrono::duration<double>(Clock::now() - begin).count();
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

  double low = INFINITY, high = -INFINITY, peak_rate = 0.0;
  for (int i : usable_rows) {
    low = std::min(low, reference.driver(i));
    high = std::max(high, reference.driver(i));
    peak_rate = std::max(peak_rate, std::abs(m.driver.at_time(reference.time(i)).rate));
  }
  const double v0 = reference.driver(start_row);
  const double rate0 = m.driver.at_time(reference.time(start_row)).rate;
  const bool turning =
      p.periodic && m.driver.law.kind == MotionLaw::Kind::constant_speed && rate0 != 0.0;
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
      if (turning || in_swing(reference.driver(i)))
        peak_effort = std::max(peak_effort, std::abs(reference.effort(i)));
  const double arm = m.driver.angular() ? 1.0 : s.size;
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
        m.driver.angular() ? 2.0 * std::numbers::pi / std::abs(rate0) : m.cycle_period();
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
  Prepared p = mechanism.dynamics ? prepare_dynamics(mechanism, reference, settings)
                                  : prepare(mechanism, reference, settings);
  // The exported scene starts at the definition's start: the usable sample nearest it (a
  // sweep's samples fall on it), not before a run's pre-roll or at a range's end.
  int row = p.span.first;
  if (!mechanism.dynamics) {
    for (int i = p.span.first; i <= p.span.last; ++i)
      if (usable(reference.status[static_cast<size_t>(i)]) &&
          std::abs(reference.driver(i) - mechanism.driver.start) <
              std::abs(reference.driver(row) - mechanism.driver.start))
        row = i;
    const auto start = exact_start(mechanism, reference, row, reference.time(row));
    if (!start) throw std::runtime_error("could not close the loops at the definition's start");
    p.start = *start;
    p.scene = mujoco_scene::build_scene(mechanism, p.start.q, &reference);
  }
  p.options.standalone = standalone(mechanism, reference, p, row);
  return mujoco_scene::to_mjcf(mechanism, p.scene, p.options);
}

}  // namespace crosslink::sim
