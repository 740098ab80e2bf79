#include "analytic/model/trajectory.h"

#include "analytic/model/fourbar.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace crosslink {
namespace {
int index_of(const std::vector<std::string>& names, std::string_view name) {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}
}  // namespace

std::string_view to_string(ParallelSingularity kind) {
  switch (kind) {
    case ParallelSingularity::none:
      return "none";
    case ParallelSingularity::direct:
      return "direct";
    case ParallelSingularity::inverse:
      return "inverse";
  }
  return "?";
}

std::string_view to_string(PoseStatus status) {
  switch (status) {
    case PoseStatus::ok:
      return "ok";
    case PoseStatus::singular:
      return "singular";
    case PoseStatus::no_convergence:
      return "no_convergence";
    case PoseStatus::cannot_assemble:
      return "cannot_assemble";
    case PoseStatus::branch_jump:
      return "branch_jump";
    case PoseStatus::loop_gap:
      return "loop_gap";
    case PoseStatus::diverged:
      return "diverged";
    case PoseStatus::not_finite:
      return "not_finite";
    case PoseStatus::not_reached:
      return "not_reached";
    case PoseStatus::exact_methods_disagree:
      return "exact_methods_disagree";
    case PoseStatus::friction_indeterminate:
      return "friction_indeterminate";
    case PoseStatus::self_locking:
      return "self_locking";
    case PoseStatus::contact_lost:
      return "contact_lost";
  }
  return "?";
}

std::string_view to_string(Quantity q) {
  switch (q) {
    case Quantity::position:
      return "position";
    case Quantity::angle:
      return "angle";
    case Quantity::velocity:
      return "velocity";
    case Quantity::acceleration:
      return "acceleration";
    case Quantity::jerk:
      return "jerk";
    case Quantity::force:
      return "force";
    case Quantity::torque:
      return "torque";
    case Quantity::energy:
      return "energy";
  }
  return "?";
}

void Trajectory::resize(const Mechanism& mechanism, int samples, bool with_forces) {
  link_names.clear();
  for (const Link& link : mechanism.links)
    if (!link.ground) link_names.push_back(link.name);
  point_names.clear();
  for (const Mechanism::NamedPoint& p : mechanism.named_points()) point_names.push_back(p.name);
  slider_names.clear();
  for (int j : mechanism.slide_joints()) slider_names.push_back(mechanism.joints[j].name);

  const auto links = static_cast<Eigen::Index>(link_names.size());
  const auto points = static_cast<Eigen::Index>(point_names.size());
  const auto sliders = static_cast<Eigen::Index>(slider_names.size());
  time.setZero(samples);
  for (Eigen::MatrixXd* m : {&angle, &omega, &alpha}) m->setZero(samples, links);
  for (Eigen::MatrixXd* m : {&x, &y, &vx, &vy, &ax, &ay}) m->setZero(samples, points);
  for (Eigen::MatrixXd* m : {&s, &sdot, &sddot}) m->setZero(samples, sliders);
  status.assign(static_cast<size_t>(samples), PoseStatus::ok);
  not_run.clear();
  rcond.setOnes(samples);
  loop_gap.setZero(samples);
  events.clear();
  stops.clear();
  held.clear();

  transmission.clear();
  if (const auto fb = four_bar(mechanism)) transmission = {fb->b, fb->c, fb->d};
  cams.clear();
  for (CamReading& reading : cam_readings(mechanism)) {
    CamChannel cam{std::move(reading)};
    // A named point of each moving link places its frame: the first of its points named.
    const auto anchor = [&](int moving, int& point, Eigen::Vector2d& local) {
      if (moving < 0) return true;
      const auto link =
          std::find_if(mechanism.links.begin(), mechanism.links.end(), [&](const Link& l) {
            return mechanism.moving_index(static_cast<int>(&l - mechanism.links.data())) == moving;
          });
      for (const Point& p : link->points) {
        point = index_of(point_names, p.name);
        local = p.local;
        if (point >= 0) return true;
      }
      return false;
    };
    if (anchor(cam.reading.rows.a, cam.cam_point, cam.cam_local) &&
        anchor(cam.reading.rows.b, cam.follower_point, cam.follower_local))
      cams.push_back(std::move(cam));
  }
  has_jerk = !cams.empty();
  jerk.setZero(samples, static_cast<Eigen::Index>(cams.size()));
  joint_names.clear();
  for (const Joint& j : mechanism.joints) joint_names.push_back(j.name);
  ground_name = mechanism.links[static_cast<size_t>(mechanism.ground())].name;
  axis = mechanism.axis();
  driver_names.clear();
  driver_sliders.clear();
  for (const Driver& d : mechanism.drivers) {
    driver_names.push_back(d.name);
    driver_sliders.push_back(!d.angular());
  }
  driver_values.setZero(samples, static_cast<Eigen::Index>(driver_names.size()));
  has_forces = with_forces;
  const int rows = with_forces ? samples : 0;
  const auto joints = static_cast<Eigen::Index>(joint_names.size());
  effort.setZero(rows, static_cast<Eigen::Index>(mechanism.drivers.size()));
  fx.setZero(rows, joints);
  fy.setZero(rows, joints);
  fn.setZero(rows, sliders);
  moment.setZero(rows, sliders);
  shaking.setZero(rows, 3);
  friction_names.clear();
  friction_sliding.clear();
  for (int j : mechanism.friction_joints()) {
    friction_names.push_back(mechanism.joints[static_cast<size_t>(j)].name);
    friction_sliding.push_back(mechanism.joints[static_cast<size_t>(j)].is_slide());
  }
  friction.setZero(rows, static_cast<Eigen::Index>(friction_names.size()));
  has_energy = false;
  energy.resize(0, 4);
}

void Trajectory::drop_jerk() {
  has_jerk = false;
  jerk.setZero(samples(), 0);
}

void Trajectory::add_energy() {
  has_energy = true;
  energy.setZero(samples(), 4);
}

double Trajectory::energy_scale() const {
  if (!has_energy) return 0.0;
  double kinetic = 0.0, work = 0.0;
  double low = INFINITY, high = -INFINITY;
  for (int k = 0; k < samples(); ++k) {
    if (!usable(status[static_cast<size_t>(k)])) continue;
    kinetic = std::max(kinetic, std::abs(energy(k, 0)));
    low = std::min(low, energy(k, 1));
    high = std::max(high, energy(k, 1));
    work = std::max(work, std::abs(energy(k, 2)));
  }
  return std::max({kinetic, high > low ? high - low : 0.0, work});
}

void Trajectory::resize_as(const Mechanism& mechanism, const Trajectory& reference,
                           bool with_forces, bool energy) {
  resize(mechanism, reference.samples(), with_forces);
  drop_jerk();
  if (energy) add_energy();
  time = reference.time;
  driver_values = reference.driver_values;
}

bool Trajectory::beside_singular(int row) const {
  auto singular_at = [&](int k) {
    return k >= 0 && k < samples() && status[static_cast<size_t>(k)] == PoseStatus::singular;
  };
  return singular_at(row - 1) || singular_at(row + 1);
}

bool Trajectory::beside_stop(int row) const {
  const int first = std::max(row - 1, 0), last = std::min(row + 1, samples() - 1);
  if (std::any_of(stops.begin(), stops.end(),
                  [&](double t) { return t > time(first) && t < time(last); }))
    return true;
  // A sweep's: a friction that changes side between the neighbours, or stops on one.
  if (!has_forces) return false;
  for (Eigen::Index f = 0; f < friction.cols(); ++f) {
    const auto side = [&](int k) {
      return status[static_cast<size_t>(k)] == PoseStatus::ok
                 ? (friction(k, f) > 0.0) - (friction(k, f) < 0.0)
                 : 0;
    };
    if (side(first) * side(last) < 0 ||
        status[static_cast<size_t>(first)] == PoseStatus::friction_indeterminate ||
        status[static_cast<size_t>(last)] == PoseStatus::friction_indeterminate)
      return true;
  }
  return false;
}

bool Trajectory::flag_non_finite(int row) {
  bool finite = true;
  auto clean = [&](double& value) {
    if (std::isfinite(value)) return;
    finite = false;
    value = 0.0;
  };
  clean(time(row));
  clean(rcond(row));
  clean(loop_gap(row));
  for (Eigen::MatrixXd* m : {&angle, &omega, &alpha, &x, &y, &vx, &vy, &ax, &ay, &s, &sdot, &sddot,
                             &driver_values, &jerk})
    for (Eigen::Index c = 0; c < m->cols(); ++c) clean((*m)(row, c));
  if (has_energy)
    for (Eigen::Index c = 0; c < energy.cols(); ++c) clean(energy(row, c));
  PoseStatus& st = status[static_cast<size_t>(row)];
  if (finite || (st != PoseStatus::ok && st != PoseStatus::singular)) return false;
  st = PoseStatus::not_finite;
  return true;
}

int Trajectory::flag_non_finite() {
  int flagged = 0;
  for (int row = 0; row < samples(); ++row) flagged += flag_non_finite(row);
  // One event, at the first sample flagged now or by the solver as it wrote it.
  const auto first = std::find(status.begin(), status.end(), PoseStatus::not_finite);
  const bool told = std::any_of(events.begin(), events.end(),
                                [](const Event& e) { return e.kind == PoseStatus::not_finite; });
  if (first != status.end() && !told)
    events.push_back({along(static_cast<int>(first - status.begin())), PoseStatus::not_finite,
                      "a value is not a finite number here (an overflow on extreme input): "
                      "the sample is flagged"});
  return flagged;
}

namespace {
constexpr std::array<std::string_view, 3> kLinkChannels = {"angle", "omega", "alpha"};
constexpr std::array<std::string_view, 8> kPointChannels = {"x", "y",  "vx", "vy",
                                                            "v", "ax", "ay", "a"};
constexpr std::array<std::string_view, 3> kSliderChannels = {"s", "sdot", "sddot"};
constexpr std::array<std::string_view, 3> kJointChannels = {"fx", "fy", "f"};
constexpr std::array<std::string_view, 2> kSlideForceChannels = {"fn", "moment"};
constexpr std::array<std::string_view, 3> kShakingChannels = {"shaking_fx", "shaking_fy",
                                                              "shaking_moment"};
constexpr std::array<std::string_view, 4> kEnergyChannels = {"kinetic", "potential", "work",
                                                             "error"};

}  // namespace

CamReading::Pose Trajectory::CamChannel::at(const Trajectory& t, int row) const {
  // A link's frame: its angle, and its origin where its named point puts it.
  const auto frame = [&](int link, int point, const Eigen::Vector2d& local) {
    BodyMotion m;
    if (link < 0) return m;
    m.theta = t.angle(row, link);
    m.rotation = Eigen::Rotation2Dd(m.theta).toRotationMatrix();
    m.r = Eigen::Vector2d(t.x(row, point), t.y(row, point)) - m.rotation * local;
    return m;
  };
  return reading.at(frame(reading.rows.a, cam_point, cam_local),
                    frame(reading.rows.b, follower_point, follower_local));
}

std::vector<std::string> Trajectory::channel_names() const {
  std::vector<std::string> names;
  for (const std::string& link : link_names)
    for (std::string_view c : kLinkChannels) names.push_back(std::string(c) + "." + link);
  for (const std::string& point : point_names)
    for (std::string_view c : kPointChannels) names.push_back(std::string(c) + "." + point);
  for (const std::string& slider : slider_names)
    for (std::string_view c : kSliderChannels) names.push_back(std::string(c) + "." + slider);
  const size_t named = axis.timed() ? driver_names.size() : 0;  // drivers naming channels
  for (size_t d = 0; d < named; ++d)
    names.push_back((driver_sliders[d] ? "s." : "angle.") + driver_names[d]);
  if (!transmission.empty()) names.push_back("mu." + transmission[1]);
  for (const CamChannel& cam : cams) names.push_back("phi." + cam.reading.joint);
  if (has_jerk)
    for (const CamChannel& cam : cams) names.push_back(cam.reading.jerk_channel());
  if (has_forces) {
    if (!axis.timed()) names.push_back(swept_slider() ? "force.driver" : "torque.driver");
    for (size_t d = 0; d < named; ++d)
      names.push_back((driver_sliders[d] ? "force." : "torque.") + driver_names[d]);
    for (const std::string& joint : joint_names)
      for (std::string_view c : kJointChannels) names.push_back(std::string(c) + "." + joint);
    for (const std::string& slider : slider_names)
      for (std::string_view c : kSlideForceChannels) names.push_back(std::string(c) + "." + slider);
    for (size_t f = 0; f < friction_names.size(); ++f)
      names.push_back((friction_sliding[f] ? "friction_force." : "friction_moment.") +
                      friction_names[f]);
    for (std::string_view c : kShakingChannels) names.push_back(std::string(c) + "." + ground_name);
  }
  if (has_energy)
    for (std::string_view c : kEnergyChannels) names.push_back("energy." + std::string(c));
  return names;
}

std::optional<Eigen::VectorXd> Trajectory::channel(std::string_view name) const {
  return rows_of(name, 0, samples());
}

std::optional<double> Trajectory::sample(std::string_view name, int row) const {
  if (row < 0 || row >= samples()) return std::nullopt;
  const std::optional<Eigen::VectorXd> one = rows_of(name, row, 1);
  return one ? std::optional<double>((*one)(0)) : std::nullopt;
}

const double* Trajectory::stored(std::string_view name) const {
  const auto col = [](const Eigen::MatrixXd& m, Eigen::Index c) { return m.col(c).data(); };
  const size_t dot = name.find('.');
  if (dot == std::string_view::npos) return nullptr;
  const std::string_view kind = name.substr(0, dot), object = name.substr(dot + 1);
  if (const int l = index_of(link_names, object); l >= 0) {
    if (kind == "angle") return col(angle, l);
    if (kind == "omega") return col(omega, l);
    if (kind == "alpha") return col(alpha, l);
  }
  if (const int p = index_of(point_names, object); p >= 0) {
    if (kind == "x") return col(x, p);
    if (kind == "y") return col(y, p);
    if (kind == "vx") return col(vx, p);
    if (kind == "vy") return col(vy, p);
    if (kind == "ax") return col(ax, p);
    if (kind == "ay") return col(ay, p);
  }
  if (const int j = index_of(slider_names, object); j >= 0) {
    if (kind == "s") return col(s, j);
    if (kind == "sdot") return col(sdot, j);
    if (kind == "sddot") return col(sddot, j);
  }
  if (has_jerk)
    for (size_t c = 0; c < cams.size(); ++c)
      if (cams[c].reading.jerk_channel() == name) return col(jerk, static_cast<Eigen::Index>(c));
  if (const int d = axis.timed() ? index_of(driver_names, object) : -1; d >= 0) {
    const bool slider = driver_sliders[static_cast<size_t>(d)] != 0;
    if (kind == (slider ? "s" : "angle")) return col(driver_values, d);
    if (has_forces && kind == (slider ? "force" : "torque")) return col(effort, d);
  }
  if (const int f = has_forces ? index_of(friction_names, object) : -1; f >= 0)
    if (kind == (friction_sliding[static_cast<size_t>(f)] ? "friction_force" : "friction_moment"))
      return col(friction, f);
  if (kind == "energy") {
    if (!has_energy) return nullptr;
    for (size_t c = 0; c < kEnergyChannels.size(); ++c)
      if (object == kEnergyChannels[c]) return col(energy, static_cast<Eigen::Index>(c));
    return nullptr;
  }
  if (!has_forces) return nullptr;
  // The one driver's effort (several drivers' are named by driver, above).
  if (!axis.timed() && object == "driver" && kind == (swept_slider() ? "force" : "torque"))
    return col(effort, axis.driver);
  if (const int j = index_of(joint_names, object); j >= 0) {
    if (kind == "fx") return col(fx, j);
    if (kind == "fy") return col(fy, j);
  }
  if (const int j = index_of(slider_names, object); j >= 0) {
    if (kind == "fn") return col(fn, j);
    if (kind == "moment") return col(moment, j);
  }
  if (object == ground_name)
    for (size_t c = 0; c < kShakingChannels.size(); ++c)
      if (kind == kShakingChannels[c]) return col(shaking, static_cast<Eigen::Index>(c));
  return nullptr;
}

std::optional<Eigen::VectorXd> Trajectory::rows_of(std::string_view name, int first,
                                                   int count) const {
  if (const double* column = stored(name))  // a sample's value costs one element, not a column
    return Eigen::Map<const Eigen::VectorXd>(column + first, count);
  // The channels computed from stored ones: magnitudes, the transmission and pressure angles.
  const auto norm = [&](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, Eigen::Index c) {
    return Eigen::VectorXd((a.col(c).segment(first, count).array().square() +
                            b.col(c).segment(first, count).array().square())
                               .sqrt());
  };
  const size_t dot = name.find('.');
  if (dot == std::string_view::npos) return std::nullopt;
  const std::string_view kind = name.substr(0, dot), object = name.substr(dot + 1);
  if (const int p = index_of(point_names, object); p >= 0) {
    if (kind == "v") return norm(vx, vy, p);
    if (kind == "a") return norm(ax, ay, p);
  }
  if (kind == "mu" && !transmission.empty() && object == transmission[1]) {
    const int b = index_of(point_names, transmission[0]),
              c = index_of(point_names, transmission[1]),
              d = index_of(point_names, transmission[2]);
    if (b < 0 || c < 0 || d < 0) return std::nullopt;
    Eigen::VectorXd mu(count);
    for (int r = first; r < first + count; ++r)
      mu(r - first) = interior_angle({x(r, c), y(r, c)}, {x(r, b), y(r, b)}, {x(r, d), y(r, d)});
    return mu;
  }
  if (kind == "phi")
    for (const CamChannel& cam : cams) {
      if (cam.reading.joint != object) continue;
      Eigen::VectorXd phi(count);
      for (int r = first; r < first + count; ++r) phi(r - first) = cam.at(*this, r).pressure_angle;
      return phi;
    }
  if (const int j = has_forces ? index_of(joint_names, object) : -1; j >= 0)
    if (kind == "f") return norm(fx, fy, j);
  return std::nullopt;
}

Quantity Trajectory::quantity_of(std::string_view channel) {
  const std::string_view kind = channel.substr(0, channel.find('.'));
  if (kind == "angle" || kind == "mu" || kind == "phi") return Quantity::angle;
  if (kind == "omega" || kind == "vx" || kind == "vy" || kind == "v" || kind == "sdot")
    return Quantity::velocity;
  if (kind == "alpha" || kind == "ax" || kind == "ay" || kind == "a" || kind == "sddot")
    return Quantity::acceleration;
  if (kind == "jerk" || kind == "angular_jerk") return Quantity::jerk;
  if (kind == "fx" || kind == "fy" || kind == "f" || kind == "fn" || kind == "force" ||
      kind == "shaking_fx" || kind == "shaking_fy" || kind == "friction_force")
    return Quantity::force;
  if (kind == "torque" || kind == "moment" || kind == "shaking_moment" || kind == "friction_moment")
    return Quantity::torque;
  if (kind == "energy") return Quantity::energy;
  return Quantity::position;
}

bool Trajectory::angular(std::string_view channel) {
  const std::string_view kind = channel.substr(0, channel.find('.'));
  return quantity_of(channel) == Quantity::angle || kind == "omega" || kind == "alpha" ||
         kind == "angular_jerk";
}

Trajectory::Unit Trajectory::unit_in(const Units& units, std::string_view channel) {
  const std::string& L = units.length_name;
  const bool turn = angular(channel);
  switch (quantity_of(channel)) {
    case Quantity::position:
      return {units.length, L};
    case Quantity::angle:
      return {units.angle, units.angle_name};
    case Quantity::velocity:
      return turn ? Unit{1.0, "rad/s"} : Unit{units.length, L + "/s"};
    case Quantity::acceleration:
      return turn ? Unit{1.0, "rad/s^2"} : Unit{units.length, L + "/s^2"};
    case Quantity::jerk:
      return turn ? Unit{1.0, "rad/s^3"} : Unit{units.length, L + "/s^3"};
    case Quantity::force:
      return {units.force, units.force_name};
    case Quantity::torque:
      return {units.force * units.length, units.force_name + " " + L};
    case Quantity::energy:
      return {1.0, "J"};
  }
  return {};
}

}  // namespace crosslink
