#include "analytic/physics/kinetostatics.h"

#include "analytic/model/planar.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace crosslink {
namespace {

// A link's motion at the state. Not from the solver's cached cos and sin: engines fill states
// of their own (q only) to apply the same loads.
BodyMotion motion(const Mechanism& m, int link, const KinematicState& state) {
  return BodyMotion::of(m.moving_index(link), state.q, &state.qdot, &state.qddot);
}

// A slide joint at the state: its guide's and slider's motions, its line's direction and left
// normal in the world, and the slider's point (where the slide's forces act), local and world.
struct SlideAt {
  BodyMotion guide, slider;
  Eigen::Vector2d along, normal, local, point;
};
SlideAt slide_at(const Mechanism& m, const Joint& j, const KinematicState& state) {
  SlideAt s;
  s.guide = motion(m, j.link_a, state);
  s.slider = motion(m, j.link_b, state);
  const Eigen::Vector2d& direction =
      m.links[static_cast<size_t>(j.link_a)].lines[static_cast<size_t>(j.line)].direction;
  s.along = s.guide.turn(direction);
  s.normal = s.guide.turn(perp(direction));
  s.local = m.links[static_cast<size_t>(j.link_b)].points[static_cast<size_t>(j.point_b)].local;
  s.point = s.slider.position(s.local);
  return s;
}

}  // namespace

SpringState spring_state(const Mechanism& m, const Spring& s, const KinematicState& state) {
  const BodyMotion a = motion(m, s.link_a, state), b = motion(m, s.link_b, state);
  const Eigen::Vector2d d = a.position(s.local_a) - b.position(s.local_b);
  SpringState out;
  out.length = d.norm();
  if (out.length == 0.0) return out;
  out.towards_a = d / out.length;
  out.rate = out.towards_a.dot(a.velocity(s.local_a) - b.velocity(s.local_b));
  out.pull = s.stiffness * (out.length - s.free_length) + s.damping * out.rate;
  return out;
}

namespace {
// A force at a point of link `link` (offset from its frame origin in world axes) and a couple,
// added to the generalised force of the link's coordinates.
void add_at(const Mechanism& m, Eigen::VectorXd& out, int link, const Eigen::Vector2d& offset,
            const Eigen::Vector2d& force, double couple) {
  const int k = m.moving_index(link);
  if (k < 0) return;
  out.segment<2>(3 * k) += force;
  out(3 * k + 2) += cross(offset, force) + couple;
}
// The sum over the moving links of term(link, its motion at the state).
template <typename Term>
double over_moving_links(const Mechanism& m, const KinematicState& state, Term term) {
  double sum = 0.0;
  for (size_t l = 0; l < m.links.size(); ++l)
    if (!m.links[l].ground) sum += term(m.links[l], motion(m, static_cast<int>(l), state));
  return sum;
}
}  // namespace

bool ForceSample::finite() const {
  bool ok = effort.allFinite() && shaking.allFinite();
  for (const Eigen::Vector2d& f : joint_force) ok = ok && f.allFinite();
  for (size_t i = 0; i < normal.size(); ++i)
    ok = ok && std::isfinite(normal[i]) && std::isfinite(moment[i]);
  return ok;
}

void applied_loads(const Mechanism& m, const KinematicState& state, Eigen::VectorXd& out) {
  out.setZero();
  for (const Load& load : m.loads) {
    const Eigen::Vector2d value = load_value(load, state);
    if (load.kind == Load::Kind::torque) {
      add_at(m, out, load.link, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), value.x());
    } else {
      add_at(m, out, load.link, motion(m, load.link, state).turn(load.local), value, 0.0);
    }
  }
  for (const Spring& s : m.springs) {
    const SpringState ss = spring_state(m, s, state);
    const Eigen::Vector2d on_b = ss.pull * ss.towards_a;
    add_at(m, out, s.link_a, motion(m, s.link_a, state).turn(s.local_a), -on_b, 0.0);
    add_at(m, out, s.link_b, motion(m, s.link_b, state).turn(s.local_b), on_b, 0.0);
  }
}

namespace {
// The revolute joints at the point named `centre` from `link` to `carrier`, breadth first; each
// signed so that +1 adds a force passed from the gear's side to the carrier's to "the force of
// its first link on its second".
std::vector<std::pair<int, double>> centre_path(const Mechanism& m, int link, int carrier,
                                                const std::string& centre) {
  std::vector<int> via(m.links.size(), -2);  // the joint a link was reached by
  std::vector<int> queue = {link};
  via[static_cast<size_t>(link)] = -1;
  for (size_t next = 0; next < queue.size(); ++next) {
    const int x = queue[next];
    for (size_t ji = 0; ji < m.joints.size(); ++ji) {
      const Joint& j = m.joints[ji];
      if (j.type != JointType::revolute || m.links[j.link_a].points[j.point_a].name != centre)
        continue;
      const int y = j.link_a == x ? j.link_b : j.link_b == x ? j.link_a : -1;
      if (y < 0 || via[static_cast<size_t>(y)] != -2) continue;
      via[static_cast<size_t>(y)] = static_cast<int>(ji);
      queue.push_back(y);
    }
  }
  std::vector<std::pair<int, double>> path;
  for (int y = carrier; y != link && via[static_cast<size_t>(y)] >= 0;) {
    const Joint& j = m.joints[static_cast<size_t>(via[static_cast<size_t>(y)])];
    const int x = j.link_a == y ? j.link_b : j.link_a;  // one step nearer the gear
    path.emplace_back(via[static_cast<size_t>(y)], j.link_a == x ? 1.0 : -1.0);
    y = x;
  }
  return path;
}
}  // namespace

Kinetostatics::Kinetostatics(const NewtonSolver& solver)
    : solver_(solver),
      slide_joints_(solver.mechanism().slide_joints()),
      size_(solver.mechanism().size()) {
  const Mechanism& m = solver.mechanism();
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (!j.is_gearing()) continue;
    Gearing g;
    g.paths = gear_paths(m, static_cast<int>(ji));
    if (j.type == JointType::rack_pinion)
      g.slide = static_cast<int>(std::find(slide_joints_.begin(), slide_joints_.end(), j.slide) -
                                 slide_joints_.begin());
    gearings_.push_back(std::move(g));
  }
  friction_joints_ = m.friction_joints();
  for (size_t ji = 0; ji < m.joints.size(); ++ji)
    if (m.joints[ji].type == JointType::cam && !m.joints[ji].form_closed)
      pushing_cams_.push_back(static_cast<int>(ji));
}

GearPaths gear_paths(const Mechanism& m, int joint) {
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  const Link& carrier = m.links[static_cast<size_t>(j.carrier)];
  GearPaths g;
  g.joint = joint;
  g.path_a = centre_path(m, j.link_a, j.carrier, carrier.points[j.centre_a].name);
  if (j.type == JointType::gear)
    g.path_b = centre_path(m, j.link_b, j.carrier, carrier.points[j.centre_b].name);
  return g;
}

ToothForce tooth_force(const Mechanism& m, const GearPaths& g, const KinematicState& state) {
  const Joint& j = m.joints[static_cast<size_t>(g.joint)];
  const BodyMotion carrier = motion(m, j.carrier, state);
  const Link& c = m.links[static_cast<size_t>(j.carrier)];
  ToothForce t;
  t.pitch = carrier.position(pitch_point(m, j));
  // Of the first moving gear's mate on it: the tangential part's moment about its centre is the
  // couple; the separating part pushes a ring (the larger gear of an internal pair) outward,
  // every other gear inward.
  const bool first = m.moving_index(j.link_a) >= 0;
  const double radius = first ? j.radius_a : j.radius_b;
  const Eigen::Vector2d arm =
      t.pitch -
      carrier.position(c.points[static_cast<size_t>(first ? j.centre_a : j.centre_b)].local);
  const bool ring =
      j.type == JointType::gear && j.ratio < 0.0 && radius > (first ? j.radius_b : j.radius_a);
  const double on_a = first ? 1.0 : -1.0;
  t.tangential = on_a * perp(arm);
  t.separating = on_a * (ring ? arm : Eigen::Vector2d(-arm));
  t.tan_pressure = std::tan(j.pressure_angle);
  t.radius = radius;
  return t;
}

void pass_tooth_force(const Mechanism& m, const GearPaths& g, const KinematicState& state,
                      double couple, std::vector<Eigen::Vector2d>& joint_force,
                      double* slide_normal, double* slide_moment) {
  const Joint& j = m.joints[static_cast<size_t>(g.joint)];
  const ToothForce t = tooth_force(m, g, state);
  const Eigen::Vector2d on_a = t.at(couple);
  joint_force[static_cast<size_t>(g.joint)] = -on_a;  // of the first gear on the second
  for (const auto& [ji, sign] : g.path_a) joint_force[static_cast<size_t>(ji)] += sign * on_a;
  for (const auto& [ji, sign] : g.path_b) joint_force[static_cast<size_t>(ji)] -= sign * on_a;
  if (j.type != JointType::rack_pinion) return;
  // The rack: its row pushed it along the line at its slide's point; the teeth push at the pitch
  // point. The slide carries the normal part and the couple of the difference.
  const SlideAt slide = slide_at(m, m.joints[static_cast<size_t>(j.slide)], state);
  const Eigen::Vector2d on_rack = -on_a;
  joint_force[static_cast<size_t>(j.slide)] -= on_rack.dot(slide.normal) * slide.normal;
  if (slide_normal) *slide_normal -= on_rack.dot(slide.normal);
  if (slide_moment) *slide_moment -= cross(t.pitch - slide.point, on_rack);
}

std::pair<double, int> Kinetostatics::couple_per_multiplier(const Gearing& g,
                                                            const KinematicState& state) const {
  const Mechanism& m = solver_.mechanism();
  const Joint& j = m.joints[static_cast<size_t>(g.paths.joint)];
  const int row = solver_.layout().joint(g.paths.joint).first_row;
  const int k = m.moving_index(m.moving_index(j.link_a) >= 0 ? j.link_a : j.link_b);
  return {-solver_.jacobian_entry(state, row, 3 * k + 2), row};
}

void Kinetostatics::add_tooth_force(const Gearing& g, const KinematicState& state,
                                    ForceSample& out) const {
  const Mechanism& m = solver_.mechanism();
  const auto [per_multiplier, row] = couple_per_multiplier(g, state);
  const bool rack = g.slide >= 0;
  pass_tooth_force(m, g.paths, state, per_multiplier * out.lambda(row), out.joint_force,
                   rack ? &out.normal[static_cast<size_t>(g.slide)] : nullptr,
                   rack ? &out.moment[static_cast<size_t>(g.slide)] : nullptr);
}

Kinetostatics::ToothShare Kinetostatics::tooth_share(const Gearing& g, const KinematicState& state,
                                                     int joint) const {
  const Mechanism& m = solver_.mechanism();
  double sign = 0.0;
  for (const auto& [ji, s] : g.paths.path_a)
    if (ji == joint) sign += s;
  for (const auto& [ji, s] : g.paths.path_b)
    if (ji == joint) sign -= s;
  const bool slide = g.slide >= 0 && m.joints[static_cast<size_t>(g.paths.joint)].slide == joint;
  ToothShare out;
  if (sign == 0.0 && !slide) return out;
  out.any = true;
  const ToothForce t = tooth_force(m, g.paths, state);
  const double per_couple = 1.0 / (t.radius * t.radius);
  const Eigen::Vector2d odd = per_couple * t.tangential,
                        even = per_couple * t.tan_pressure * t.separating;
  out.odd.on_b = sign * odd;
  out.even.on_b = sign * even;
  if (!slide) return out;
  // As pass_tooth_force: the rack's slide takes the tooth force's normal part and the couple of
  // its offset from the slide's point.
  const SlideAt at = slide_at(m, m.joints[static_cast<size_t>(joint)], state);
  for (const auto& [share, f] : {std::pair{&out.odd, odd}, std::pair{&out.even, even}}) {
    share->on_b += f.dot(at.normal) * at.normal;
    share->normal += f.dot(at.normal);
    share->moment += cross(t.pitch - at.point, f);
  }
  return out;
}

ForceSample Kinetostatics::make_sample() const {
  const Mechanism& m = solver_.mechanism();
  ForceSample s;
  s.effort.setZero(static_cast<Eigen::Index>(m.drivers.size()));
  s.joint_force.assign(m.joints.size(), Eigen::Vector2d::Zero());
  s.normal.assign(slide_joints_.size(), 0.0);
  s.moment.assign(slide_joints_.size(), 0.0);
  s.generalised.setZero(m.coordinate_count());
  s.lambda.setZero(m.coordinate_count());
  s.friction.assign(friction_joints_.size(), 0.0);
  s.unit_lambda.setZero(m.coordinate_count(), static_cast<Eigen::Index>(friction_joints_.size()));
  return s;
}

void Kinetostatics::generalised_forces(const KinematicState& state, Eigen::VectorXd& out,
                                       bool inertia) const {
  const Mechanism& m = solver_.mechanism();
  applied_loads(m, state, out);
  for (size_t l = 0; l < m.links.size(); ++l) {
    const Link& link = m.links[l];
    if (link.ground) continue;
    const BodyMotion b = motion(m, static_cast<int>(l), state);
    const MassProperties& mp = link.mass;
    // Gravity and d'Alembert's inertia force at the centre of mass, and the inertia couple.
    const Eigen::Vector2d force =
        inertia ? Eigen::Vector2d(mp.mass * (m.gravity - b.acceleration(mp.com)))
                : Eigen::Vector2d(mp.mass * m.gravity);
    add_at(m, out, static_cast<int>(l), b.turn(mp.com), force,
           inertia ? -mp.inertia * b.alpha : 0.0);
  }
}

Kinetostatics::Reaction Kinetostatics::reaction(const KinematicState& state, int joint,
                                                const Eigen::VectorXd& lambda) const {
  const Mechanism& m = solver_.mechanism();
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  const ConstraintRows& rows_of = solver_.layout().joint(joint);
  const int row = rows_of.first_row, rows = rows_of.rows();
  // The generalised constraint force -Phi_q^T lambda of this joint's rows on a moving link: force
  // and moment about its frame origin; through the moving side (both are moving, or the ground
  // is one of them).
  const bool from_b = rows_of.b >= 0;
  const int k = from_b ? rows_of.b : rows_of.a;
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  for (int r = row; r < row + rows; ++r)
    for (int i = 0; i < 3; ++i) g(i) -= solver_.jacobian_entry(state, r, 3 * k + i) * lambda(r);
  Reaction out;
  out.on_b = from_b ? Eigen::Vector2d(g.head<2>()) : Eigen::Vector2d(-g.head<2>());
  if (!j.is_slide()) return out;
  const SlideAt s = slide_at(m, j, state);
  out.normal = out.on_b.dot(s.normal);
  // The couple on the slider about its point: the moment left once the force at the point is
  // taken out (on the guide it is the opposite).
  out.moment = from_b ? g(2) - cross(s.point - s.slider.r, out.on_b)
                      : -(g(2) - cross(s.point - s.guide.r, -out.on_b));
  return out;
}

void Kinetostatics::solve(KinematicState& state, ForceSample& out) const {
  solve(state, out, state, false);
}

void Kinetostatics::solve(KinematicState& state, ForceSample& out, const KinematicState& moving,
                          bool at_rest, const FrictionPhase* phase) const {
  generalised_forces(state, out.generalised);
  solver_.multipliers(state, out.generalised, out.lambda);
  out.status = PoseStatus::ok;
  if (!friction_joints_.empty() && !solve_friction(state, out, moving, at_rest, phase)) return;
  write_forces(state, out);
  // A force-closed cam's contact only pushes: where the motion needs a pull the follower leaves.
  const Mechanism& m = solver_.mechanism();
  for (const int ji : pushing_cams_) {
    const Joint& j = m.joints[static_cast<size_t>(ji)];
    const double push = out.joint_force[static_cast<size_t>(ji)].dot(
        cam_contact(solver_.layout().joint(ji), motion(m, j.link_a, state),
                    motion(m, j.link_b, state))
            .normal);
    if (push < 0.0 && (out.status == PoseStatus::ok || push < out.pull)) {
      out.status = PoseStatus::contact_lost;
      out.cause = ji;
      out.pull = push;
    }
  }
}

void Kinetostatics::solve_held(KinematicState& state, ForceSample& out, double effort) const {
  generalised_forces(state, out.generalised);
  solver_.multipliers(state, out.generalised, out.lambda);
  out.status = PoseStatus::ok;
  std::fill(out.friction.begin(), out.friction.end(), 0.0);
  const ConstraintLayout& layout = solver_.layout();
  if (friction_joints_.size() != 1 || layout.driver_count() != 1) {
    out.status = PoseStatus::friction_indeterminate;
    out.cause = friction_joints_.empty() ? -1 : friction_joints_.back();
    return;
  }
  // Lambda = lambda_0 + x Lambda_1 (Lambda_1 a unit friction of -1): the driver's row gives x.
  const Eigen::Index row = layout.driver_row(0);
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(out.lambda.size()), column(out.lambda.size());
  add_unit_friction(state, 0, 1.0, unit);
  solver_.multipliers(state, unit, column);
  const double per_unit = column(row);
  if (!(std::abs(per_unit) > 0.0)) {  // the friction does not act along the coordinate
    out.status = PoseStatus::friction_indeterminate;
    out.cause = friction_joints_.front();
    return;
  }
  const double x = -(effort + out.lambda(row)) / per_unit;
  out.lambda += x * column;
  out.friction[0] = -x;
  write_forces(state, out);
}

void Kinetostatics::write_forces(KinematicState& state, ForceSample& out) const {
  const Mechanism& m = solver_.mechanism();
  const Eigen::VectorXd& lambda = out.lambda;
  const ConstraintLayout& layout = solver_.layout();
  // A driver's equation is coordinate - d(t) = 0: its effort along the coordinate is -lambda.
  for (int d = 0; d < layout.driver_count(); ++d) out.effort(d) = -lambda(layout.driver_row(d));

  size_t slide = 0;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (j.is_gearing()) continue;  // add_tooth_force, once the others' reactions are known
    const Reaction r = reaction(state, static_cast<int>(ji), lambda);
    out.joint_force[ji] = r.on_b;
    if (!j.is_slide()) continue;
    out.normal[slide] = r.normal;
    out.moment[slide] = r.moment;
    ++slide;
  }
  // A slide's friction force acts along its line at the slider's point: part of the force of
  // the guide on the slider.
  for (size_t f = 0; f < friction_joints_.size(); ++f)
    if (friction_joint(f).is_slide())
      out.joint_force[static_cast<size_t>(friction_joints_[f])] +=
          out.friction[f] * slide_at(m, friction_joint(f), state).along;
  for (const Gearing& g : gearings_) add_tooth_force(g, state, out);

  // On the ground: applied gravity and loads less the rate of the moving links' momentum.
  Eigen::Vector3d shaking = Eigen::Vector3d::Zero();
  auto add = [&](const Eigen::Vector2d& at, const Eigen::Vector2d& force, double couple) {
    shaking.head<2>() += force;
    shaking(2) += cross(at, force) + couple;
  };
  for (size_t l = 0; l < m.links.size(); ++l) {
    const Link& link = m.links[l];
    if (link.ground) continue;
    const BodyMotion b = motion(m, static_cast<int>(l), state);
    const MassProperties& mp = link.mass;
    add(b.position(mp.com), mp.mass * (m.gravity - b.acceleration(mp.com)), -mp.inertia * b.alpha);
  }
  for (const Load& load : m.loads) {
    const Eigen::Vector2d value = load_value(load, state);
    if (load.kind == Load::Kind::torque)
      add(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), value.x());
    else
      add(motion(m, load.link, state).position(load.local), value, 0.0);
  }
  out.shaking = shaking;
}

namespace {

// Relative rates at or below this fraction of the drivers' are no motion: their sign is round-off.
constexpr double kStoppedRate = 1e-9;
// Newton on the friction magnitudes: the residual it stops at, relative to the largest magnitude,
// and the iterations it may take (each contracts by the friction gain at least).
constexpr double kFrictionResidual = 1e-14;
constexpr int kFrictionIterations = 200;

Kinetostatics::Reaction plus(Kinetostatics::Reaction r, double x,
                             const Kinetostatics::Reaction& d) {
  r.on_b += x * d.on_b;
  r.normal += x * d.normal;
  r.moment += x * d.moment;
  return r;
}

}  // namespace

double Kinetostatics::relative_rate(const KinematicState& state, int f) const {
  const Mechanism& m = solver_.mechanism();
  const Joint& j = friction_joint(static_cast<size_t>(f));
  if (!j.is_slide()) return motion(m, j.link_b, state).omega - motion(m, j.link_a, state).omega;
  const SlideAt s = slide_at(m, j, state);
  // The guide's material point under the slider's.
  const Eigen::Vector2d on_guide = s.guide.v + s.guide.omega * perp(s.point - s.guide.r);
  return s.along.dot(s.slider.velocity(s.local) - on_guide);
}

double Kinetostatics::rest_rate(const KinematicState& moving, int f) const {
  const Mechanism& m = solver_.mechanism();
  // The drivers' rate, as an angular rate: relative rates are judged against it.
  double rate = 0.0;
  for (size_t d = 0; d < m.drivers.size(); ++d) {
    const double r = std::abs(moving.drivers[d].rate);
    rate = std::max(rate, m.drivers[d].angular() ? r : r / size_);
  }
  return kStoppedRate * rate * (friction_joint(static_cast<size_t>(f)).is_slide() ? size_ : 1.0);
}

double Kinetostatics::relative_acceleration(const KinematicState& state, int f) const {
  const Mechanism& m = solver_.mechanism();
  const Joint& j = friction_joint(static_cast<size_t>(f));
  if (!j.is_slide()) return motion(m, j.link_b, state).alpha - motion(m, j.link_a, state).alpha;
  // d/dt of along . (v_P - v_G), G the guide's point under the slider's P: the line turns with
  // the guide, and G follows P across the guide.
  const SlideAt s = slide_at(m, j, state);
  const BodyMotion& g = s.guide;
  const Eigen::Vector2d v = s.slider.velocity(s.local), arm = s.point - g.r;
  const Eigen::Vector2d on_guide = g.v + g.omega * perp(arm);
  const Eigen::Vector2d a_on_guide = g.a + g.alpha * perp(arm) + g.omega * perp(v - g.v);
  return g.omega * perp(s.along).dot(v - on_guide) +
         s.along.dot(s.slider.acceleration(s.local) - a_on_guide);
}

double Kinetostatics::friction_limit(int f, const ForceSample& forces, bool at_rest) const {
  const Joint& j = friction_joint(static_cast<size_t>(f));
  const JointFriction& law = *j.friction;
  const auto ji = static_cast<size_t>(friction_joints_[static_cast<size_t>(f)]);
  if (!j.is_slide()) return law.limit(true, forces.joint_force[ji].norm(), at_rest);
  const auto slide = static_cast<size_t>(std::find(slide_joints_.begin(), slide_joints_.end(),
                                                   friction_joints_[static_cast<size_t>(f)]) -
                                         slide_joints_.begin());
  return law.limit(false, law.load(false, forces.normal[slide], forces.moment[slide]), at_rest);
}

double Kinetostatics::friction_load(int f, const Reaction& r) const {
  const Joint& j = friction_joint(static_cast<size_t>(f));
  return j.is_slide() ? j.friction->load(false, r.normal, r.moment) : r.on_b.norm();
}

double Kinetostatics::friction_load_slope(int f, const Reaction& r, const Reaction& d) const {
  const Joint& j = friction_joint(static_cast<size_t>(f));
  if (!j.is_slide()) {
    const double load = r.on_b.norm();
    return load > 0.0 ? r.on_b.dot(d.on_b) / load : d.on_b.norm();
  }
  const double length = j.friction->length;
  if (length > 0.0 && 2.0 * std::abs(r.moment) / length > std::abs(r.normal))
    return 2.0 * (r.moment > 0.0 ? d.moment : -d.moment) / length;
  return r.normal > 0.0 ? d.normal : r.normal < 0.0 ? -d.normal : std::abs(d.normal);
}

void Kinetostatics::add_unit_friction(const KinematicState& state, int f, double sign,
                                      Eigen::VectorXd& g) const {
  const Mechanism& m = solver_.mechanism();
  const Joint& j = friction_joint(static_cast<size_t>(f));
  if (!j.is_slide()) {
    add_at(m, g, j.link_b, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -sign);
    add_at(m, g, j.link_a, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), sign);
    return;
  }
  // Along the line at the slider's point: on the slider against its motion, on the guide back.
  const SlideAt s = slide_at(m, j, state);
  const Eigen::Vector2d along = sign * s.along;
  add_at(m, g, j.link_b, s.point - s.slider.r, -along, 0.0);
  add_at(m, g, j.link_a, s.point - s.guide.r, along, 0.0);
}

bool Kinetostatics::solve_friction(KinematicState& state, ForceSample& out,
                                   const KinematicState& moving, bool at_rest,
                                   const FrictionPhase* phase) const {
  const auto k = static_cast<Eigen::Index>(friction_joints_.size());
  // g_j: the friction circle mu r (pin) or mu (slide), sliding or at its static limit.
  const auto gain = [&](Eigen::Index f) {
    const Joint& j = friction_joint(static_cast<size_t>(f));
    return j.friction->load_gain(!j.is_slide(), at_rest);
  };
  // A held joint's friction is given: x_f = -its value, with a unit friction of sign +1.
  const auto is_held = [&](Eigen::Index f) {
    return phase && phase->direction[static_cast<size_t>(f)] == 0;
  };
  std::vector<double> sign(static_cast<size_t>(k));
  Eigen::VectorXd unit(out.lambda.size()), column(out.lambda.size());
  for (Eigen::Index f = 0; f < k; ++f) {
    const int ji = friction_joints_[static_cast<size_t>(f)];
    const double w = relative_rate(moving, static_cast<int>(f));
    if (!phase && !(std::abs(w) > rest_rate(moving, static_cast<int>(f)))) {
      out.status = PoseStatus::friction_indeterminate;
      out.cause = ji;
      return false;
    }
    sign[static_cast<size_t>(f)] = phase
                                       ? (phase->direction[static_cast<size_t>(f)] < 0 ? -1.0 : 1.0)
                                   : w > 0.0 ? 1.0
                                             : -1.0;
    unit.setZero();
    add_unit_friction(state, static_cast<int>(f), sign[static_cast<size_t>(f)], unit);
    solver_.multipliers(state, unit, column);
    out.unit_lambda.col(f) = column;
  }
  // Each friction joint's reaction at the frictionless multipliers (A) and per unit of each
  // friction (B).
  std::vector<Reaction> at_zero(static_cast<size_t>(k));
  std::vector<Reaction> per_unit(static_cast<size_t>(k * k));
  for (Eigen::Index f = 0; f < k; ++f) {
    const int ji = friction_joints_[static_cast<size_t>(f)];
    at_zero[static_cast<size_t>(f)] = reaction(state, ji, out.lambda);
    for (Eigen::Index i = 0; i < k; ++i) {
      column = out.unit_lambda.col(i);
      per_unit[static_cast<size_t>(f * k + i)] = reaction(state, ji, column);
    }
  }
  // A gear's bearing or a rack's slide also carries the tooth force (add_tooth_force): c P +
  // |c| Q in its gearing's couple c = c_0 + sum_i x_i c_i, which is linear in the multipliers.
  // P joins A and B; |c| Q, the separating force, is the reaction's second kink.
  struct Mesh {
    Eigen::Index f;
    Reaction separating;       // Q
    double c0;                 // c at x = 0
    Eigen::VectorXd per_unit;  // c_i
  };
  std::vector<Mesh> meshes;
  for (const Gearing& g : gearings_) {
    const auto [per_multiplier, row] = couple_per_multiplier(g, state);
    for (Eigen::Index f = 0; f < k; ++f) {
      const ToothShare share = tooth_share(g, state, friction_joints_[static_cast<size_t>(f)]);
      if (!share.any) continue;
      Mesh mesh{f, share.even, per_multiplier * out.lambda(row),
                per_multiplier * out.unit_lambda.row(row).transpose()};
      at_zero[static_cast<size_t>(f)] = plus(at_zero[static_cast<size_t>(f)], mesh.c0, share.odd);
      for (Eigen::Index i = 0; i < k; ++i)
        per_unit[static_cast<size_t>(f * k + i)] =
            plus(per_unit[static_cast<size_t>(f * k + i)], mesh.per_unit(i), share.odd);
      meshes.push_back(std::move(mesh));
    }
  }
  // The change of joint f's reaction per unit of friction i, with each of its meshes' couples
  // growing in magnitude when it grows (`side` +1) or shrinking (-1), one bit of `sides` each.
  const auto change = [&](Eigen::Index f, Eigen::Index i, const auto& side) {
    Reaction d = per_unit[static_cast<size_t>(f * k + i)];
    for (size_t n = 0; n < meshes.size(); ++n)
      if (meshes[n].f == f) d = plus(d, side(n) * meshes[n].per_unit(i), meshes[n].separating);
    return d;
  };
  // The friction gain's bound |d f_j / d f_i| <= g_j h_j(B_ji), h a norm, over either side of
  // each mesh's kink.
  Eigen::MatrixXd bound = Eigen::MatrixXd::Zero(k, k);
  for (Eigen::Index f = 0; f < k; ++f) {
    if (is_held(f)) continue;  // a given value: no slope
    std::vector<size_t> own;
    for (size_t n = 0; n < meshes.size(); ++n)
      if (meshes[n].f == f) own.push_back(n);
    for (Eigen::Index i = 0; i < k; ++i)
      for (size_t sides = 0; sides < (size_t{1} << own.size()); ++sides) {
        const auto side = [&](size_t n) {
          const size_t bit =
              static_cast<size_t>(std::find(own.begin(), own.end(), n) - own.begin());
          return (sides >> bit & 1U) ? -1.0 : 1.0;
        };
        bound(f, i) =
            std::max(bound(f, i), gain(f) * friction_load(static_cast<int>(f), change(f, i, side)));
      }
  }
  // The gain: the spectral radius of that non-negative bound, the least Lipschitz constant of
  // the map over every weighting of the magnitudes (Perron-Frobenius): moments and forces have
  // different units, so no one norm serves.
  out.gain = bound.eigenvalues().cwiseAbs().maxCoeff();
  if (out.gain >= 1.0) {
    out.status = PoseStatus::self_locking;
    Eigen::Index row = 0;
    bound.rowwise().sum().maxCoeff(&row);
    out.cause = friction_joints_[static_cast<size_t>(row)];
    return false;
  }
  const auto couple_at = [&](const Eigen::VectorXd& x, const Mesh& mesh) {
    return mesh.c0 + mesh.per_unit.dot(x);
  };
  const auto reaction_at = [&](const Eigen::VectorXd& x, Eigen::Index f) {
    Reaction r = at_zero[static_cast<size_t>(f)];
    for (Eigen::Index i = 0; i < k; ++i)
      r = plus(r, x(i), per_unit[static_cast<size_t>(f * k + i)]);
    for (const Mesh& mesh : meshes)
      if (mesh.f == f) r = plus(r, std::abs(couple_at(x, mesh)), mesh.separating);
    return r;
  };
  // The magnitudes the reactions at x give: x is the solution where they are x.
  const auto image = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    for (Eigen::Index f = 0; f < k; ++f)
      y(f) = is_held(f) ? -phase->holding(f)
                        : gain(f) * friction_load(static_cast<int>(f), reaction_at(x, f)) +
                              friction_joint(static_cast<size_t>(f)).friction->constant;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(k), y(k), trial(k), trial_image(k);
  image(x, y);
  x = y;
  Eigen::MatrixXd slope(k, k);
  bool converged = false;
  for (int it = 0; it < kFrictionIterations && !converged; ++it) {
    image(x, y);
    const double residual = (x - y).lpNorm<Eigen::Infinity>();
    if (residual <= kFrictionResidual * x.lpNorm<Eigen::Infinity>() || residual == 0.0) {
      converged = true;
      break;
    }
    // Newton: (I - d image / dx) step = image(x) - x.
    const auto side = [&](size_t n) { return couple_at(x, meshes[n]) < 0.0 ? -1.0 : 1.0; };
    for (Eigen::Index f = 0; f < k; ++f) {
      const Reaction r = reaction_at(x, f);
      for (Eigen::Index i = 0; i < k; ++i)
        slope(f, i) = (f == i ? 1.0 : 0.0) -
                      (is_held(f) ? 0.0
                                  : gain(f) * friction_load_slope(static_cast<int>(f), r,
                                                                  change(f, i, side)));
    }
    trial = x + slope.partialPivLu().solve(y - x);
    image(trial, trial_image);
    // Where Newton does not reduce the residual (a kink of |R| or of max), the fixed-point step,
    // a contraction by the gain.
    x = trial.allFinite() && (trial - trial_image).lpNorm<Eigen::Infinity>() < residual ? trial : y;
  }
  if (!converged) {
    out.status = PoseStatus::no_convergence;
    return false;
  }
  for (Eigen::Index f = 0; f < k; ++f) {
    out.lambda += x(f) * out.unit_lambda.col(f);
    out.friction[static_cast<size_t>(f)] = -sign[static_cast<size_t>(f)] * x(f);
  }
  return true;
}

double Kinetostatics::friction_power(const KinematicState& state, const ForceSample& forces) const {
  double power = 0.0;
  for (size_t f = 0; f < friction_joints_.size(); ++f)
    power += forces.friction[f] * relative_rate(state, static_cast<int>(f));
  return power;
}

std::string ForceSample::why(const Mechanism& m) const {
  const std::string joint =
      cause >= 0 ? "joint '" + m.joints[static_cast<size_t>(cause)].name + "'" : "a joint";
  switch (status) {
    case PoseStatus::friction_indeterminate:
      return "friction indeterminate: " + joint +
             " has no relative motion, so its friction may be anything inside its cone";
    case PoseStatus::self_locking:
      return fmt::format(
          "self-locking: the friction gain is {:.3g}, largest through {} (1 or more: the "
          "reactions may be held by the friction they cause), so the motion does not determine "
          "the forces",
          gain, joint);
    case PoseStatus::no_convergence:
      return "the friction magnitudes did not converge";
    case PoseStatus::contact_lost:
      return fmt::format(
          "contact lost: the follower leaves cam '{}', whose contact only pushes: the motion needs "
          "a pull of {:.4g} N there (the follower jumps; a stiffer or more preloaded spring, a "
          "slower cam or a groove, closure = \"form\", keeps it on)",
          m.joints[static_cast<size_t>(cause)].name, -pull);
    default:
      return "";
  }
}

std::optional<double> Kinetostatics::power_balance(const KinematicState& state,
                                                   const ForceSample* forces) const {
  if (state.axis.timed() || state.swept().rate == 0.0) return std::nullopt;
  return input_power(state, forces) / state.swept().rate;
}

double Kinetostatics::input_power(const KinematicState& state, const ForceSample* forces) const {
  const Mechanism& m = solver_.mechanism();
  if (!friction_joints_.empty() && !forces)
    throw std::logic_error("input_power: joint friction needs the forces at the state");
  double power = forces && !friction_joints_.empty() ? -friction_power(state, *forces) : 0.0;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const Link& link = m.links[l];
    if (link.ground) continue;
    const BodyMotion b = motion(m, static_cast<int>(l), state);
    const MassProperties& mp = link.mass;
    const Eigen::Vector2d v = b.velocity(mp.com);
    // d/dt of kinetic energy, and of the potential energy of gravity.
    power += mp.mass * v.dot(b.acceleration(mp.com)) + mp.inertia * b.omega * b.alpha;
    power -= mp.mass * m.gravity.dot(v);
  }
  // d/dt of the springs' energy.
  for (const Spring& s : m.springs) {
    const SpringState ss = spring_state(m, s, state);
    power += s.stiffness * (ss.length - s.free_length) * ss.rate;
  }
  return power - load_power(state);
}

double Kinetostatics::kinetic_energy(const KinematicState& state) const {
  return over_moving_links(solver_.mechanism(), state, [](const Link& link, const BodyMotion& b) {
    return 0.5 * (link.mass.mass * b.velocity(link.mass.com).squaredNorm() +
                  link.mass.inertia * b.omega * b.omega);
  });
}

double Kinetostatics::kinetic_energy_rate(const KinematicState& state) const {
  return over_moving_links(solver_.mechanism(), state, [](const Link& link, const BodyMotion& b) {
    return link.mass.mass * b.velocity(link.mass.com).dot(b.acceleration(link.mass.com)) +
           link.mass.inertia * b.omega * b.alpha;
  });
}

double Kinetostatics::inertia_product(const KinematicState& state, const Eigen::VectorXd& a,
                                      const Eigen::VectorXd& b) const {
  const Mechanism& m = solver_.mechanism();
  double sum = 0.0;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const Link& link = m.links[l];
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const BodyMotion ba = BodyMotion::of(k, state.q, &a, nullptr),
                     bb = BodyMotion::of(k, state.q, &b, nullptr);
    sum += link.mass.mass * ba.velocity(link.mass.com).dot(bb.velocity(link.mass.com)) +
           link.mass.inertia * ba.omega * bb.omega;
  }
  return sum;
}

double Kinetostatics::potential_energy(const KinematicState& state) const {
  const Mechanism& m = solver_.mechanism();
  double energy = over_moving_links(m, state, [&](const Link& link, const BodyMotion& b) {
    return -link.mass.mass * m.gravity.dot(b.position(link.mass.com));
  });
  for (const Spring& s : m.springs) {
    const double stretch = spring_state(m, s, state).length - s.free_length;
    energy += 0.5 * s.stiffness * stretch * stretch;
  }
  return energy;
}

double Kinetostatics::load_power(const KinematicState& state) const {
  const Mechanism& m = solver_.mechanism();
  double power = 0.0;
  for (const Load& load : m.loads) {
    const Eigen::Vector2d value = load_value(load, state);
    const BodyMotion b = motion(m, load.link, state);
    power +=
        load.kind == Load::Kind::torque ? value.x() * b.omega : value.dot(b.velocity(load.local));
  }
  for (const Spring& s : m.springs) {
    const double rate = spring_state(m, s, state).rate;
    power -= s.damping * rate * rate;
  }
  return power;
}

void Kinetostatics::write_sample(const ForceSample& sample, Trajectory& out, int row) const {
  out.effort.row(row) = sample.effort.transpose();
  for (size_t j = 0; j < sample.joint_force.size(); ++j) {
    out.fx(row, static_cast<Eigen::Index>(j)) = sample.joint_force[j].x();
    out.fy(row, static_cast<Eigen::Index>(j)) = sample.joint_force[j].y();
  }
  for (size_t s = 0; s < sample.normal.size(); ++s) {
    out.fn(row, static_cast<Eigen::Index>(s)) = sample.normal[s];
    out.moment(row, static_cast<Eigen::Index>(s)) = sample.moment[s];
  }
  out.shaking.row(row) = sample.shaking.transpose();
  for (size_t f = 0; f < sample.friction.size(); ++f)
    out.friction(row, static_cast<Eigen::Index>(f)) = sample.friction[f];
}

}  // namespace crosslink
