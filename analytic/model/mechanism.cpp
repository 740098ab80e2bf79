#include "analytic/model/mechanism.h"

#include "analytic/model/planar.h"
#include "analytic/model/spline.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace crosslink {

std::string SourceLocation::str() const {
  if (line <= 0) return file;
  return fmt::format("{}:{}:{}", file, line, column);
}

std::string Diagnostic::str() const {
  return fmt::format("{}: error: {}", where.str(), message);
}

namespace {
std::string join_diagnostics(const std::vector<Diagnostic>& diagnostics) {
  std::string text;
  for (const Diagnostic& d : diagnostics) {
    if (!text.empty()) text += '\n';
    text += d.str();
  }
  return text;
}
}  // namespace

DefinitionError::DefinitionError(std::vector<Diagnostic> diagnostics)
    : std::runtime_error(join_diagnostics(diagnostics)), diagnostics_(std::move(diagnostics)) {}

int Link::find_point(std::string_view name) const {
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].name == name) return static_cast<int>(i);
  return -1;
}

int Link::find_line(std::string_view name) const {
  for (size_t i = 0; i < lines.size(); ++i)
    if (lines[i].name == name) return static_cast<int>(i);
  return -1;
}

std::string_view to_string(JointType type) {
  switch (type) {
    case JointType::revolute:
      return "revolute";
    case JointType::prismatic:
      return "prismatic";
    case JointType::pin_in_slot:
      return "pin_in_slot";
    case JointType::pin_in_arc:
      return "pin_in_arc";
    case JointType::pin_in_spline:
      return "pin_in_spline";
    case JointType::cam:
      return "cam";
    case JointType::gear:
      return "gear";
    case JointType::rack_pinion:
      return "rack_pinion";
  }
  return "?";
}

std::string_view to_string(DriverType type) {
  switch (type) {
    case DriverType::joint_angle:
      return "joint_angle";
    case DriverType::slider:
      return "slider";
    case DriverType::link_angle:
      return "link_angle";
  }
  return "?";
}

std::string_view to_string(MotionLaw::Kind kind) {
  switch (kind) {
    case MotionLaw::Kind::constant_speed:
      return "speed";
    case MotionLaw::Kind::constant_acceleration:
      return "acceleration";
    case MotionLaw::Kind::polynomial:
      return "polynomial";
    case MotionLaw::Kind::table:
      return "table";
  }
  return "?";
}

DriverState Driver::at_time(double t) const {
  DriverState s;
  s.time = t;
  switch (law.kind) {
    case MotionLaw::Kind::constant_speed:
      s.value = start + law.speed * t;
      s.rate = law.speed;
      break;
    case MotionLaw::Kind::constant_acceleration:
      s.value = start + (law.speed + 0.5 * law.acceleration * t) * t;
      s.rate = law.speed + law.acceleration * t;
      s.accel = law.acceleration;
      break;
    case MotionLaw::Kind::polynomial: {
      // q = start + sum_k c_k t^k (k from 1): Horner for the value and its derivatives.
      const std::vector<double>& c = law.coefficients;
      double value = 0.0, rate = 0.0, accel = 0.0, jerk = 0.0;
      for (size_t i = c.size(); i-- > 0;) {
        const double k = static_cast<double>(i + 1);
        value = value * t + c[i];
        rate = rate * t + k * c[i];
        if (i >= 1) accel = accel * t + k * (k - 1.0) * c[i];
        if (i >= 2) jerk = jerk * t + k * (k - 1.0) * (k - 2.0) * c[i];
      }
      s.value = start + value * t;
      s.rate = rate;
      s.accel = accel;
      s.jerk = jerk;
      break;
    }
    case MotionLaw::Kind::table: {
      const SplinePoint p = NaturalSpline(law.table_time, law.table_value).at(t);
      s.value = p.y;
      s.rate = p.dy;
      s.accel = p.ddy;
      s.jerk = p.dddy;
      break;
    }
  }
  return s;
}

int Mechanism::ground() const {
  for (size_t i = 0; i < links.size(); ++i)
    if (links[i].ground) return static_cast<int>(i);
  return -1;
}

int Mechanism::find_link(std::string_view name) const {
  for (size_t i = 0; i < links.size(); ++i)
    if (links[i].name == name) return static_cast<int>(i);
  return -1;
}

int Mechanism::find_joint(std::string_view name) const {
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  return -1;
}

int Mechanism::moving_index(int link) const {
  const int g = ground();
  if (link == g) return -1;
  return link < g ? link : link - 1;
}

double Mechanism::size() const {
  // The drawing is not the linkage: a link drawn 1e6 m from where it assembles (the solver
  // brings it back) made the size, and with it every tolerance, default mass and engine scale,
  // 1e6 m. So the size is the drawn extent of the links drawn in place only, those reached from
  // the ground through links whose drawn points come within the linkage's span of each other,
  // the span being the sum of the links' own extents (each link's largest distance between two
  // of its points or lines' origins, whatever its pose): two points of an assembled chain are
  // never farther apart. A link drawn away counts by its own extent. An assembled drawing keeps
  // its extent. (Joints are not read here: the loader asks for the size before it reads them.)
  const size_t n = links.size();
  std::vector<std::vector<Eigen::Vector2d>> drawn(n);
  double span = 0.0, longest = 0.0;
  for (size_t l = 0; l < n; ++l) {
    const Link& link = links[l];
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    double theta = 0.0;
    if (link.pose) {
      origin = link.pose->head<2>();
      theta = (*link.pose)(2);
    }
    const Eigen::Rotation2Dd rotation(theta);
    std::vector<Eigen::Vector2d> local;
    for (const Point& p : link.points) {
      local.push_back(p.local);
      drawn[l].push_back(origin + rotation * p.local);
    }
    for (const Line& line : link.lines) local.push_back(line.origin);
    double extent = 0.0;
    for (size_t i = 0; i < local.size(); ++i)
      for (size_t j = i + 1; j < local.size(); ++j)
        extent = std::max(extent, (local[i] - local[j]).norm());
    span += extent;
    longest = std::max(longest, extent);
  }
  // Breadth first from the ground (the first link without one).
  std::vector<char> in_place(n, 0);
  std::vector<size_t> queue;
  const int g = ground();
  if (n > 0) {
    queue.push_back(g >= 0 ? static_cast<size_t>(g) : 0);
    in_place[queue.front()] = 1;
  }
  for (size_t next = 0; next < queue.size(); ++next)
    for (size_t l = 0; l < n; ++l) {
      if (in_place[l]) continue;
      bool near = false;
      for (const Eigen::Vector2d& a : drawn[queue[next]])
        for (const Eigen::Vector2d& b : drawn[l]) near = near || (a - b).norm() <= span;
      if (near) {
        in_place[l] = 1;
        queue.push_back(l);
      }
    }
  std::vector<Eigen::Vector2d> placed;
  for (const size_t l : queue) placed.insert(placed.end(), drawn[l].begin(), drawn[l].end());
  double largest = longest;
  for (size_t i = 0; i < placed.size(); ++i)
    for (size_t j = i + 1; j < placed.size(); ++j)
      largest = std::max(largest, (placed[i] - placed[j]).norm());
  if (span > 0.0) largest = std::min(largest, span);
  return largest > 0.0 ? largest : 1.0;
}

std::vector<int> Mechanism::slide_joints() const {
  std::vector<int> slides;
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].is_slide()) slides.push_back(static_cast<int>(i));
  return slides;
}

std::vector<int> Mechanism::friction_joints() const {
  std::vector<int> out;
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].friction) out.push_back(static_cast<int>(i));
  return out;
}

Eigen::Vector2d pitch_point(const Mechanism& m, const Joint& j) {
  const Link& carrier = m.links[static_cast<size_t>(j.carrier)];
  const Eigen::Vector2d a = carrier.points[static_cast<size_t>(j.centre_a)].local;
  if (j.type == JointType::rack_pinion) {  // toward the rack's line, a pitch radius from the centre
    const Joint& slide = m.joints[static_cast<size_t>(j.slide)];
    const Eigen::Vector2d normal = perp(carrier.lines[static_cast<size_t>(slide.line)].direction);
    return a - (j.ratio > 0.0 ? j.radius_a : -j.radius_a) * normal;
  }
  const Eigen::Vector2d b = carrier.points[static_cast<size_t>(j.centre_b)].local;
  const Eigen::Vector2d ab = (b - a).normalized();
  if (j.ratio > 0.0) return a + j.radius_a * ab;  // external: between the centres
  // Internal: on the far side of the pinion's centre from the ring's.
  if (j.radius_a < j.radius_b) return a - j.radius_a * ab;
  return b + j.radius_b * ab;
}

std::vector<Mechanism::NamedPoint> Mechanism::named_points() const {
  std::vector<NamedPoint> named;
  for (size_t l = 0; l < links.size(); ++l)
    for (size_t p = 0; p < links[l].points.size(); ++p) {
      const std::string& name = links[l].points[p].name;
      const bool seen = std::any_of(named.begin(), named.end(),
                                    [&](const NamedPoint& n) { return n.name == name; });
      if (!seen) named.push_back({name, static_cast<int>(l), static_cast<int>(p)});
    }
  return named;
}

double Driver::cycle() const {
  if (law.duration > 0.0) return law.duration;
  const double speed = std::abs(law.speed);
  if (law.kind != MotionLaw::Kind::constant_speed || speed == 0.0) return 0.0;
  if (angular()) return 2.0 * std::numbers::pi / speed;
  return range ? std::abs(range->second - range->first) / speed : 0.0;
}

const Driver& Mechanism::swept() const {
  const SweepAxis a = axis();
  if (a.timed()) throw std::logic_error("the sweep runs in time: no driver's value is its axis");
  return drivers[static_cast<size_t>(a.driver)];
}

double Mechanism::cycle_period() const {
  if (axis().timed()) {
    double longest = 0.0;
    for (const Driver& d : drivers) longest = std::max(longest, d.cycle());
    return longest;
  }
  // The swept driver's: a law in time's duration; at constant speed one turn, or a slider's
  // range (a duration given with a constant speed bounds its own law only, Driver::cycle()).
  const Driver& d = swept();
  if (d.law.kind != MotionLaw::Kind::constant_speed) return d.law.duration;
  const double speed = std::abs(d.law.speed);
  if (speed == 0.0) return 0.0;
  if (d.angular()) return 2.0 * std::numbers::pi / speed;
  return d.range ? std::abs(d.range->second - d.range->first) / speed : 0.0;
}

std::string Mobility::explain() const {
  return fmt::format("M = 3(n-1) - 2 j1 - j2 = 3({}-1) - 2*{} - {} = {}", links, full_joints,
                     half_joints, mobility);
}

Mobility mobility(const Mechanism& mechanism) {
  Mobility m;
  m.links = static_cast<int>(mechanism.links.size());
  for (const Joint& j : mechanism.joints) (j.dof() == 1 ? m.full_joints : m.half_joints) += 1;
  m.mobility = 3 * (m.links - 1) - 2 * m.full_joints - m.half_joints;
  return m;
}

}  // namespace crosslink

namespace crosslink {

MassProperties default_mass_properties(const Link& link, double size) {
  double length = 0.0;
  Eigen::Vector2d from = Eigen::Vector2d::Zero(), to = Eigen::Vector2d::Zero();
  if (!link.points.empty()) from = to = link.points.front().local;
  for (size_t i = 0; i < link.points.size(); ++i)
    for (size_t k = i + 1; k < link.points.size(); ++k)
      if ((link.points[i].local - link.points[k].local).norm() > length) {
        length = (link.points[i].local - link.points[k].local).norm();
        from = link.points[i].local;
        to = link.points[k].local;
      }
  const double l = std::max(length, 0.05 * size), w = 0.1 * l;
  MassProperties mp;
  mp.mass = l / size;
  mp.com = 0.5 * (from + to);
  mp.inertia = mp.mass * (l * l + w * w) / 12.0;
  mp.assumed = true;
  return mp;
}

Eigen::Vector2d Load::force_at(double driver) const {
  const auto value = [](const Eigen::Vector3d& row) { return Eigen::Vector2d(row(1), row(2)); };
  if (!table || rows.size() == 1) return value(rows.front());
  double d = driver;
  const double first = rows.front()(0);
  if (over_turns)
    d = first + std::fmod(std::fmod(d - first, 2.0 * std::numbers::pi) + 2.0 * std::numbers::pi,
                          2.0 * std::numbers::pi);
  if (d <= first) return value(rows.front());
  for (size_t i = 1; i < rows.size(); ++i)
    if (d <= rows[i](0)) {
      const double u = (d - rows[i - 1](0)) / (rows[i](0) - rows[i - 1](0));
      return (1.0 - u) * value(rows[i - 1]) + u * value(rows[i]);
    }
  return value(rows.back());
}

double FreeCoordinate::effort_at(double t) const {
  if (effort.empty()) return 0.0;
  if (t <= effort.front().first) return effort.front().second;
  for (size_t i = 1; i < effort.size(); ++i)
    if (t <= effort[i].first) {
      const double u = (t - effort[i - 1].first) / (effort[i].first - effort[i - 1].first);
      return (1.0 - u) * effort[i - 1].second + u * effort[i].second;
    }
  return effort.back().second;
}

bool Mechanism::drawn() const {
  return std::any_of(links.begin(), links.end(),
                     [](const Link& l) { return l.pose_where.line > 0; });
}

std::string BranchChoice::text() const {
  std::string points;
  for (const std::string& n : names) points += (points.empty() ? "" : " -> ") + n;
  return fmt::format("{} turns {}", points, counter_clockwise ? "counter-clockwise" : "clockwise");
}

}  // namespace crosslink
