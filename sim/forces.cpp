#include "sim/forces.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "analytic/model/planar.h"
#include "analytic/physics/kinetostatics.h"
#include "analytic/reference/trust.h"
#include "sim/sampling.h"

namespace crosslink::sim {
namespace {

// Generalised forces (per body: force and moment about the frame origin) as each moving body's
// force and moment about its centre of mass, at pose q.
void body_loads(const Mechanism& m, const Eigen::VectorXd& q, const Eigen::VectorXd& generalised,
                std::vector<BodyLoad>& out) {
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const BodyMotion b = BodyMotion::of(k, q, nullptr, nullptr);
    BodyLoad& load = out[static_cast<size_t>(k)];
    load.force = generalised.segment<2>(3 * k);
    load.moment = generalised(3 * k + 2) - cross(b.turn(m.links[l].mass.com), load.force);
  }
}

}  // namespace

AppliedLoads::AppliedLoads(const Mechanism& m)
    : m_(m),
      state_(m),
      generalised_(Eigen::VectorXd::Zero(m.coordinate_count())),
      out_(static_cast<size_t>(m.moving_count())) {}

const std::vector<BodyLoad>& AppliedLoads::at(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                                              double driver_value) {
  state_.q = q;
  state_.qdot = qdot;
  if (!state_.axis.timed()) state_.swept().value = driver_value;  // what a load's table reads
  applied_loads(m_, state_, generalised_);
  body_loads(m_, q, generalised_, out_);
  return out_;
}

DynamicsLoads::DynamicsLoads(const Mechanism& m)
    : m_(m),
      solver_(m),
      kinetostatics_(solver_),
      state_(m),
      jacobian_(Eigen::MatrixXd::Zero(m.coordinate_count(), m.coordinate_count())),
      generalised_(Eigen::VectorXd::Zero(m.coordinate_count())),
      out_(static_cast<size_t>(m.moving_count())) {
  bool effort = false;
  if (m.dynamics)
    for (int d = 0; d < m.dynamics->coordinate_count(); ++d)
      for (const auto& [time, value] : m.dynamics->coordinate(d).effort)
        effort = effort || value != 0.0;
  any_ = effort || !m.loads.empty() || !m.springs.empty();
}

double DynamicsLoads::rate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, int d) {
  solver_.jacobian(q, jacobian_);
  return jacobian_.row(solver_.layout().driver_row(d)).dot(qdot);
}

void DynamicsLoads::measure(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                            KinematicState& state) {
  solver_.jacobian(q, jacobian_);
  for (int d = 0; d < state.driver_count(); ++d)
    state.drivers[static_cast<size_t>(d)] = {
        t, coordinate(q, d), jacobian_.row(solver_.layout().driver_row(d)).dot(qdot), 0.0};
}

void DynamicsLoads::set_coordinates(const Eigen::VectorXd& q) {
  for (int d = 0; d < state_.driver_count(); ++d)
    state_.drivers[static_cast<size_t>(d)].value = coordinate(q, d);
}

template <class F>
void DynamicsLoads::for_each_effort(double t, const Eigen::VectorXd& q, F&& f) {
  if (!m_.dynamics) return;
  bool jacobian = false;
  for (int d = 0; d < m_.dynamics->coordinate_count(); ++d) {
    const double effort = m_.dynamics->coordinate(d).effort_at(t);
    if (effort == 0.0) continue;
    if (!jacobian) solver_.jacobian(q, jacobian_);
    jacobian = true;
    f(effort, jacobian_.row(solver_.layout().driver_row(d)));
  }
}

const std::vector<BodyLoad>& DynamicsLoads::at(double t, const Eigen::VectorXd& q,
                                               const Eigen::VectorXd& qdot) {
  state_.q = q;
  state_.qdot = qdot;
  set_coordinates(q);
  applied_loads(m_, state_, generalised_);
  for_each_effort(
      t, q, [&](double effort, const auto& row) { generalised_ += effort * row.transpose(); });
  body_loads(m_, q, generalised_, out_);
  return out_;
}

double DynamicsLoads::kinetic(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) {
  state_.q = q;
  state_.qdot = qdot;
  return kinetostatics_.kinetic_energy(state_);
}

double DynamicsLoads::potential(const Eigen::VectorXd& q) {
  state_.q = q;
  return kinetostatics_.potential_energy(state_);
}

double DynamicsLoads::power(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) {
  if (!any_) return 0.0;
  state_.q = q;
  state_.qdot = qdot;
  set_coordinates(q);
  double power = kinetostatics_.load_power(state_);
  for_each_effort(t, q, [&](double effort, const auto& row) { power += effort * row.dot(qdot); });
  return power;
}

double reference_energy_scale(const Mechanism& m, const Trajectory& reference) {
  DynamicsLoads balance(m);
  double kinetic = 0.0, low = INFINITY, high = -INFINITY;
  for (int k = 0; k < reference.samples(); ++k) {
    if (!usable(reference.status[static_cast<size_t>(k)])) continue;
    const ReferenceState s = reference_state(m, reference, k);
    kinetic = std::max(kinetic, balance.kinetic(s.q, s.qdot));
    const double v = balance.potential(s.q);
    low = std::min(low, v);
    high = std::max(high, v);
  }
  return std::max(kinetic, high > low ? high - low : 0.0);
}

double driver_inertia(const Mechanism& m, const Trajectory& reference, int d) {
  DynamicsLoads energy(m);
  const NewtonSolver solver(m);
  KinematicState state(m);
  double inertia = 0.0;
  for (int k = 0; k < reference.samples(); ++k) {
    if (!usable(reference.status[static_cast<size_t>(k)])) continue;
    state.q = reference_coordinates(m, reference, k);
    for (int e = 0; e < state.driver_count(); ++e)
      state.drivers[static_cast<size_t>(e)] = {reference.time(k), reference.driver_values(k, e),
                                               e == d ? 1.0 : 0.0, 0.0};
    if (solver.solve_position(state).status != PoseStatus::ok) continue;
    solver.solve_velocity(state);
    inertia = std::max(inertia, 2.0 * energy.kinetic(state.q, state.qdot));
  }
  return inertia;
}

double auxiliary_mass(const Mechanism& m) {
  double lightest = std::numeric_limits<double>::infinity();
  for (const Link& link : m.links)
    if (!link.ground && link.mass.mass > 0.0) lightest = std::min(lightest, link.mass.mass);
  return 1e-6 * (std::isfinite(lightest) ? lightest : 1.0);
}

MassProperties scene_mass(const Mechanism& m, int link) {
  MassProperties mp = m.links[static_cast<size_t>(link)].mass;
  const double auxiliary = auxiliary_mass(m);
  mp.mass = std::max(mp.mass, auxiliary);
  mp.inertia = std::max(mp.inertia, auxiliary * 1e-2 * m.size() * m.size());
  return mp;
}

void ForceReading::set_zero() {
  effort = 0.0;
  std::fill(other_efforts.begin(), other_efforts.end(), 0.0);
  for (Eigen::Vector2d& f : joint_force) f.setZero();
  std::fill(couple.begin(), couple.end(), 0.0);
  std::fill(gear_couple.begin(), gear_couple.end(), 0.0);
  std::fill(friction.begin(), friction.end(), 0.0);
}

void ForceReading::add(double weight, const ForceReading& other) {
  effort += weight * other.effort;
  for (size_t d = 0; d < other_efforts.size(); ++d)
    other_efforts[d] += weight * other.other_efforts[d];
  for (size_t j = 0; j < joint_force.size(); ++j) {
    joint_force[j] += weight * other.joint_force[j];
    couple[j] += weight * other.couple[j];
    gear_couple[j] += weight * other.gear_couple[j];
    friction[j] += weight * other.friction[j];
  }
}

std::vector<GearPaths> gearings_of(const Mechanism& m) {
  std::vector<GearPaths> out;
  for (size_t ji = 0; ji < m.joints.size(); ++ji)
    if (m.joints[ji].is_gearing()) out.push_back(gear_paths(m, static_cast<int>(ji)));
  return out;
}

void move_tooth_forces(const Mechanism& m, const std::vector<GearPaths>& gearings,
                       const KinematicState& state, ForceReading& reading) {
  for (const GearPaths& g : gearings) {
    const Joint& j = m.joints[static_cast<size_t>(g.joint)];
    pass_tooth_force(
        m, g, state, reading.gear_couple[static_cast<size_t>(g.joint)], reading.joint_force,
        nullptr,
        j.type == JointType::rack_pinion ? &reading.couple[static_cast<size_t>(j.slide)] : nullptr);
  }
}

void write_forces(const Mechanism& m, const KinematicState& state, const ForceReading& engine,
                  Trajectory& out, int row) {
  const bool gearing =
      std::any_of(m.joints.begin(), m.joints.end(), [](const Joint& j) { return j.is_gearing(); });
  std::optional<ForceReading> moved;
  if (gearing) {
    moved = engine;
    move_tooth_forces(m, gearings_of(m), state, *moved);
  }
  const ForceReading& reading = moved ? *moved : engine;
  const int ground = m.ground();
  auto motion = [&](int link) {
    return BodyMotion::of(m.moving_index(link), state.q, &state.qdot, nullptr);
  };
  for (int d = 0; d < static_cast<int>(m.drivers.size()); ++d)
    out.effort(row, d) = reading.effort_of(d);
  Eigen::Vector3d shaking = Eigen::Vector3d::Zero();
  auto on_ground = [&](const Eigen::Vector2d& at, const Eigen::Vector2d& force, double couple) {
    shaking.head<2>() += force;
    shaking(2) += cross(at, force) + couple;
  };
  Eigen::Index slide = 0, rough = 0;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    const Eigen::Vector2d& f = reading.joint_force[ji];
    // A pin's friction moment acts on its second link and the opposite one on its first.
    double friction_moment = 0.0;
    if (j.friction) {
      out.friction(row, rough++) = reading.friction[ji];
      if (!j.is_slide()) friction_moment = reading.friction[ji];
    }
    out.fx(row, static_cast<Eigen::Index>(ji)) = f.x();
    out.fy(row, static_cast<Eigen::Index>(ji)) = f.y();
    const BodyMotion a = motion(j.link_a), b = motion(j.link_b);
    // Where the force acts: a gearing's pitch point, a cam's contact, else the joint's point.
    const auto point = [&]() -> Eigen::Vector2d {
      if (j.is_gearing()) return motion(j.carrier).position(pitch_point(m, j));
      if (j.type == JointType::cam) return cam_contact(m, j, a, b).point;
      return b.position(m.links[j.link_b].points[j.point_b].local);
    };
    if (j.is_slide()) {
      const Line& line = m.links[j.link_a].lines[j.line];
      out.fn(row, slide) = f.dot(a.turn(perp(line.direction)));
      out.moment(row, slide) = reading.couple[ji];
      ++slide;
    }
    // The ground is the first link (it receives -f and the opposite couple) or the second.
    if (j.link_a == ground) on_ground(point(), -f, -reading.couple[ji] - friction_moment);
    if (j.link_b == ground) on_ground(point(), f, reading.couple[ji] + friction_moment);
  }
  // Each driver's reaction on the ground.
  for (int di = 0; di < static_cast<int>(m.drivers.size()); ++di) {
    const Driver& d = m.drivers[static_cast<size_t>(di)];
    const double effort = reading.effort_of(di);
    if (d.type == DriverType::link_angle) {
      on_ground(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -effort);
      continue;
    }
    const Joint& j = m.joints[static_cast<size_t>(d.joint)];
    const int sign = j.link_a == ground ? -1 : j.link_b == ground ? 1 : 0;
    if (sign != 0 && d.type == DriverType::joint_angle) {
      on_ground(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), sign * effort);
    } else if (sign != 0) {
      const BodyMotion a = motion(j.link_a), b = motion(j.link_b);
      const Line& line = m.links[j.link_a].lines[j.line];
      on_ground(b.position(m.links[j.link_b].points[j.point_b].local),
                sign * effort * a.turn(line.direction), 0.0);
    }
  }
  // Springs anchored on the ground pull it towards their other end.
  for (const Spring& s : m.springs) {
    const SpringState ss = spring_state(m, s, state);
    const Eigen::Vector2d on_b = ss.pull * ss.towards_a;
    if (s.link_a == ground) on_ground(motion(s.link_a).position(s.local_a), -on_b, 0.0);
    if (s.link_b == ground) on_ground(motion(s.link_b).position(s.local_b), on_b, 0.0);
  }
  out.shaking.row(row) = shaking.transpose();
}

ForceReading reference_reading(const Mechanism& m, const Trajectory& reference, int row) {
  ForceReading out(m.joints.size(), m.drivers.size());
  if (!reference.has_forces || row < 0 || row >= reference.samples()) return out;
  Eigen::Index slide = 0, rough = 0;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const auto j = static_cast<Eigen::Index>(ji);
    out.joint_force[ji] = {reference.fx(row, j), reference.fy(row, j)};
    if (m.joints[ji].is_slide()) out.couple[ji] = reference.moment(row, slide++);
    if (m.joints[ji].friction) out.friction[ji] = reference.friction(row, rough++);
  }
  for (int d = 0; d < static_cast<int>(m.drivers.size()); ++d)
    out.effort_of(d) = reference.effort(row, d);
  return out;
}

ReadingTrend reference_trend(const Mechanism& m, const Trajectory& reference, int first, double t) {
  ReadingTrend out{reference_reading(m, reference, first),
                   ForceReading(m.joints.size(), m.drivers.size())};
  if (first + 1 < reference.samples() && usable(reference.status[static_cast<size_t>(first + 1)])) {
    out.rate.add(1.0, reference_reading(m, reference, first + 1));
    out.rate.add(-1.0, out.at);
    const double dt = reference.time(first + 1) - reference.time(first);
    ForceReading per_second(m.joints.size(), m.drivers.size());
    per_second.add(dt > 0.0 ? 1.0 / dt : 0.0, out.rate);
    out.rate = per_second;
  }
  out.at.add(t - reference.time(first), out.rate);
  return out;
}

FrictionLoads::FrictionLoads(const Mechanism& m, ReadingTrend start, bool extrapolated,
                             int transients)
    : m_(m),
      last_(std::move(start.at)),
      rate_(std::move(start.rate)),
      load_(last_),
      extrapolated_(extrapolated),
      transients_(transients) {
  // The reference's forces are the teeth's already; an engine's gear couples are moved onto them.
  if (std::ranges::any_of(m.joints, [](const Joint& j) { return j.friction.has_value(); }))
    gearings_ = gearings_of(m);
  if (!gearings_.empty()) {
    pose_.emplace(m);
    moved_ = last_;
  }
}

const ForceReading& FrictionLoads::next(double h) {
  load_ = last_;
  if (extrapolated_) load_.add(h, rate_);
  return load_;
}

void FrictionLoads::record(const ForceReading* reading, double h, const Eigen::VectorXd& q) {
  ++steps_;
  if (!reading) {  // the start's trend goes on
    last_.add(h, rate_);
    return;
  }
  if (geared()) {
    pose_->q = q;
    moved_ = *reading;
    move_tooth_forces(m_, gearings_, *pose_, moved_);
    reading = &moved_;
  }
  if (h > 0.0) {  // else it replaces a reading at the same instant, whose rate stands
    rate_.set_zero();
    rate_.add(1.0 / h, *reading);
    rate_.add(-1.0 / h, last_);
  }
  last_ = *reading;
}

double friction_limit(const Mechanism& m, int joint, const Eigen::VectorXd& q,
                      const ForceReading& load, bool held) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  const JointFriction& f = *j.friction;
  if (!f.load_dependent()) return f.limit(!j.is_slide(), 0.0, held);
  const Eigen::Vector2d& r = load.joint_force[static_cast<size_t>(joint)];
  if (!j.is_slide()) return f.limit(true, f.load(true, r.norm()), held);
  const BodyMotion guide = BodyMotion::of(m.moving_index(j.link_a), q, nullptr, nullptr);
  const Eigen::Vector2d u = guide.turn(m.links[j.link_a].lines[j.line].direction);
  const double normal = r.dot(perp(u));
  return f.limit(false, f.load(false, normal, load.couple[static_cast<size_t>(joint)]), held);
}

bool friction_held(double friction, double limit) {
  return std::abs(friction) < (1.0 - 1e-6) * limit;
}

FrictionBounds::FrictionBounds(const Mechanism& m, std::vector<int> joints, ReadingTrend start,
                               bool extrapolated, int transients)
    : m_(m), loads_(m, std::move(start), extrapolated, transients) {
  for (int ji : joints) {
    const Joint& j = m.joints[static_cast<size_t>(ji)];
    joints_.push_back({ji});
    loaded_ |= j.friction->load_dependent();
    slide_loaded_ |= j.friction->load_dependent() && j.is_slide();
  }
}

void FrictionBounds::bound(double h, const Eigen::VectorXd& q,
                           const std::function<void(size_t, double)>& set) {
  static const ForceReading kNone;  // a load-independent friction reads no load
  if (loaded_ && loads_.geared()) pose_ = q;
  const ForceReading& load = loaded_ ? loads_.next(h) : kNone;
  for (size_t i = 0; i < joints_.size(); ++i) {
    Rough& r = joints_[i];
    r.limit = friction_limit(m_, r.joint, q, load, r.held);
    set(i, r.limit);
  }
}

double FrictionBounds::settle(double h, const ForceReading* reading,
                              const std::function<Step(size_t)>& stepped) {
  double work = 0.0;
  for (size_t i = 0; i < joints_.size(); ++i) {
    const Step s = stepped(i);
    joints_[i].held = friction_held(s.friction, joints_[i].limit);
    work += s.friction * s.moved;
  }
  if (loaded_) loads_.record(reading, h, pose_);
  return work;
}

ForceStencil force_stencil(double t, long last_step, const std::vector<double>& step_time) {
  ForceStencil s;
  const long first_clean = 2, last_clean = last_step - 1;
  if (last_clean < first_clean) return s;
  // The clean step nearest to t.
  const long k =
      std::lower_bound(step_time.begin(), step_time.begin() + last_step + 1, t) - step_time.begin();
  long nearest = std::clamp(k, first_clean, last_clean);
  if (nearest > first_clean &&
      t - step_time[static_cast<size_t>(nearest - 1)] < step_time[static_cast<size_t>(nearest)] - t)
    --nearest;
  const double h = step_time[static_cast<size_t>(nearest)] -
                   step_time[static_cast<size_t>(std::max(0L, nearest - 1))];
  if (std::abs(step_time[static_cast<size_t>(nearest)] - t) <= 1e-9 * h) {
    s.steps = {nearest};
    s.weights = {1.0};
    return s;
  }
  const long count = std::min(3L, last_clean - first_clean + 1);
  const long from = std::clamp(nearest - count / 2, first_clean, last_clean - count + 1);
  std::vector<double> times;
  for (long n = from; n < from + count; ++n) {
    s.steps.push_back(n);
    times.push_back(step_time[static_cast<size_t>(n)]);
  }
  s.weights = stencil_weights(t, times)[0];
  return s;
}

void combine_readings(const ForceStencil& stencil,
                      const std::function<const ForceReading&(long step)>& reading,
                      ForceReading& out) {
  out.set_zero();
  for (size_t n = 0; n < stencil.steps.size(); ++n)
    out.add(stencil.weights[n], reading(stencil.steps[n]));
}

}  // namespace crosslink::sim

namespace crosslink::sim {

ForceAgreement force_agreement(const Mechanism& m, const Trajectory& exact,
                               const Trajectory& engine) {
  ForceAgreement a;
  if (!exact.has_forces || !engine.has_forces) return a;
  std::vector<int> rows;
  const double force_rcond = kForceConditioning * typical_rcond(exact);
  for (int i = 0; i < exact.samples(); ++i)
    if (untrusted(exact, i, force_rcond).empty() && usable(engine.status[static_cast<size_t>(i)]))
      rows.push_back(i);
  a.compared = static_cast<int>(rows.size());
  if (rows.empty()) return a;
  auto worst = [&](auto difference, auto value) {
    double error = 0.0, peak = 0.0;
    for (int i : rows) {
      error = std::max(error, difference(i));
      peak = std::max(peak, value(i));
    }
    return std::pair{error, peak};
  };
  auto ratio = [](std::pair<double, double> e) {
    return e.second > 0.0 ? e.first / e.second : 0.0;
  };
  const auto slides = m.slide_joints();
  // The effort's scale: its peak, or where it is zero by design (a parallelogram at constant
  // speed without gravity) the largest reaction, times the size for a torque.
  double reaction_peak = 0.0;
  for (int i : rows)
    for (Eigen::Index j = 0; j < exact.fx.cols(); ++j)
      reaction_peak = std::max(reaction_peak, std::hypot(exact.fx(i, j), exact.fy(i, j)));
  // Every driver's effort, each against its own scale.
  for (Eigen::Index e = 0; e < exact.effort.cols(); ++e) {
    auto [effort_error, effort_peak] =
        worst([&](int i) { return std::abs(engine.effort(i, e) - exact.effort(i, e)); },
              [&](int i) { return std::abs(exact.effort(i, e)); });
    const double arm = m.drivers[static_cast<size_t>(e)].angular() ? m.size() : 1.0;
    effort_peak = std::max(effort_peak, 1e-3 * reaction_peak * arm);
    a.effort = std::max(a.effort, ratio({effort_error, effort_peak}));
  }
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const auto c = static_cast<Eigen::Index>(j);
    auto force = [&](const Trajectory& t, int i) {
      return Eigen::Vector2d(t.fx(i, c), t.fy(i, c));
    };
    const auto e = worst([&](int i) { return (force(engine, i) - force(exact, i)).norm(); },
                         [&](int i) { return force(exact, i).norm(); });
    if (ratio(e) > a.reaction) {
      a.reaction = ratio(e);
      a.worst_joint = m.joints[j].name;
    }
    const auto s = std::find(slides.begin(), slides.end(), static_cast<int>(j));
    if (m.joints[j].type != JointType::prismatic || s == slides.end()) continue;
    const auto k = static_cast<Eigen::Index>(s - slides.begin());
    const auto ce = worst([&](int i) { return std::abs(engine.moment(i, k) - exact.moment(i, k)); },
                          [&](int i) { return force(exact, i).norm() * m.size(); });
    a.couple = std::max(a.couple, ratio(ce));
  }
  a.shaking = ratio(worst(
      [&](int i) {
        return (engine.shaking.row(i).head<2>() - exact.shaking.row(i).head<2>()).norm();
      },
      [&](int i) { return exact.shaking.row(i).head<2>().norm(); }));
  return a;
}

GearingAgreement gearing_agreement(const Mechanism& m, const Trajectory& exact,
                                   const Trajectory& engine, int joint) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  // Each link's angle difference, taken to the nearest turn (an engine may wrap its angles), so
  // the coupling's difference is that of the differences.
  const auto turned = [&](int i, int link) {
    const int k = m.moving_index(link);
    if (k < 0) return 0.0;  // the ground
    const double d = engine.angle(i, k) - exact.angle(i, k);
    return d - 2.0 * std::numbers::pi * std::round(d / (2.0 * std::numbers::pi));
  };
  const auto slides = m.slide_joints();
  const auto rack =
      static_cast<Eigen::Index>(std::find(slides.begin(), slides.end(), j.slide) - slides.begin());
  const auto difference = [&](int i) {
    const double pinion = turned(i, j.link_a) - turned(i, j.carrier);
    return j.type == JointType::gear
               ? pinion + j.ratio * (turned(i, j.link_b) - turned(i, j.carrier))
               : engine.s(i, rack) - exact.s(i, rack) - j.ratio * pinion;
  };
  GearingAgreement a;
  double error = 0.0, peak = 0.0;
  const bool forces = exact.has_forces && engine.has_forces;
  const auto c = static_cast<Eigen::Index>(joint);
  for (int i = 0; i < exact.samples(); ++i) {
    if (!usable(engine.status[static_cast<size_t>(i)])) continue;
    ++a.compared;
    a.drift = std::max(a.drift, std::abs(difference(i)));
    if (!forces) continue;
    const Eigen::Vector2d f(exact.fx(i, c), exact.fy(i, c));
    error = std::max(error, (Eigen::Vector2d(engine.fx(i, c), engine.fy(i, c)) - f).norm());
    peak = std::max(peak, f.norm());
  }
  if (!forces) return a;
  // A mesh force zero by design (a sun that turns at constant speed, unloaded) against 1e-3 of
  // the largest reaction, as force_agreement scales an effort.
  double reaction_peak = 0.0;
  for (int i = 0; i < exact.samples(); ++i)
    for (Eigen::Index k = 0; k < exact.fx.cols(); ++k)
      reaction_peak = std::max(reaction_peak, std::hypot(exact.fx(i, k), exact.fy(i, k)));
  peak = std::max(peak, 1e-3 * reaction_peak);
  if (peak > 0.0) a.mesh = error / peak;
  return a;
}

}  // namespace crosslink::sim
