#include "analytic/model/fourbar.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace crosslink {

std::string_view to_string(Grashof g) {
  switch (g) {
    case Grashof::grashof:
      return "Grashof";
    case Grashof::change_point:
      return "change point";
    case Grashof::non_grashof:
      return "non-Grashof";
  }
  return "?";
}

std::optional<FourBar> four_bar(const Mechanism& m) {
  if (m.links.size() != 4 || m.joints.size() != 4) return std::nullopt;
  for (const Joint& j : m.joints)
    if (j.type != JointType::revolute) return std::nullopt;
  // Each link in exactly two joints; the joints' points on a link give its length.
  const int g = m.ground();
  std::array<std::vector<int>, 4> joints_of;
  for (size_t j = 0; j < 4; ++j) {
    joints_of[static_cast<size_t>(m.joints[j].link_a)].push_back(static_cast<int>(j));
    joints_of[static_cast<size_t>(m.joints[j].link_b)].push_back(static_cast<int>(j));
  }
  for (const auto& js : joints_of)
    if (js.size() != 2) return std::nullopt;
  auto other = [&](int joint, int link) {
    const Joint& j = m.joints[joint];
    return j.link_a == link ? j.link_b : j.link_a;
  };
  auto point_on = [&](int joint, int link) -> const Point& {
    const Joint& j = m.joints[joint];
    return m.links[link].points[j.link_a == link ? j.point_a : j.point_b];
  };
  FourBar fb;
  fb.ground = g;
  const auto& gj = joints_of[static_cast<size_t>(g)];
  // The input is the grounded link that carries the driver, if either does.
  int in_joint = gj[0], out_joint = gj[1];
  if (m.axis().timed()) return std::nullopt;  // a four-bar has one driver
  const Driver& d = m.swept();
  const int driven =
      d.type == DriverType::joint_angle ? other(d.joint, m.joints[d.joint].link_a) : d.link;
  if (other(gj[1], g) == driven || (d.type == DriverType::joint_angle && d.joint == gj[1]))
    std::swap(in_joint, out_joint);
  fb.input = other(in_joint, g);
  fb.output = other(out_joint, g);
  if (fb.input == fb.output) return std::nullopt;
  const auto& ij = joints_of[static_cast<size_t>(fb.input)];
  const int b_joint = ij[0] == in_joint ? ij[1] : ij[0];
  fb.coupler = other(b_joint, fb.input);
  const auto& oj = joints_of[static_cast<size_t>(fb.output)];
  const int c_joint = oj[0] == out_joint ? oj[1] : oj[0];
  if (other(c_joint, fb.output) != fb.coupler) return std::nullopt;
  auto length = [&](int link, int j1, int j2) {
    return (point_on(j1, link).local - point_on(j2, link).local).norm();
  };
  fb.ground_length = length(g, in_joint, out_joint);
  fb.input_length = length(fb.input, in_joint, b_joint);
  fb.coupler_length = length(fb.coupler, b_joint, c_joint);
  fb.output_length = length(fb.output, c_joint, out_joint);
  fb.a = point_on(in_joint, g).name;
  fb.b = point_on(b_joint, fb.input).name;
  fb.c = point_on(c_joint, fb.output).name;
  fb.d = point_on(out_joint, g).name;

  std::array<double, 4> l = {fb.ground_length, fb.input_length, fb.coupler_length,
                             fb.output_length};
  const auto [smin, smax] = std::minmax_element(l.begin(), l.end());
  const double sum = l[0] + l[1] + l[2] + l[3];
  const double excess = (*smin + *smax) - (sum - *smin - *smax);
  const double eps = 1e-9 * *smax;  // lengths come from a file: equal to ~9 digits is equal
  fb.grashof = excess < -eps  ? Grashof::grashof
               : excess > eps ? Grashof::non_grashof
                              : Grashof::change_point;
  if (fb.grashof == Grashof::non_grashof) {
    fb.inversion = "triple-rocker";
  } else {
    // A link next to the ground turns fully when it or the ground is a shortest link; equal
    // shortest links count alike (Norton ch. 2: the parallelogram, input and output shortest,
    // is a double crank; so is every inversion of it).
    const double least = *smin;  // a structured binding is not captured by clang 14
    const auto shortest = [&](int i) { return l[static_cast<size_t>(i)] - least <= eps; };
    const bool input_turns = shortest(0) || shortest(1), output_turns = shortest(0) || shortest(3);
    const bool parallelogram = std::abs(l[0] - l[2]) <= eps && std::abs(l[1] - l[3]) <= eps;
    fb.inversion = parallelogram                 ? "parallelogram double-crank"
                   : shortest(0)                 ? "double-crank (drag link)"
                   : input_turns && output_turns ? "double-crank"
                   : input_turns                 ? "crank-rocker"
                   : output_turns                ? "rocker-crank"
                                                 : "double-rocker";
  }
  return fb;
}

std::string FourBar::explain(const Mechanism& m) const {
  const double u = m.units.length;
  std::array<double, 4> l = {ground_length, input_length, coupler_length, output_length};
  std::sort(l.begin(), l.end());
  return fmt::format(
      "{} {} (s + l = {:.6g} {}, p + q = {:.6g}; ground {}{} = {:.6g}, input {}{} "
      "= {:.6g}, coupler {}{} = {:.6g}, output {}{} = {:.6g})",
      to_string(grashof), inversion, (l[0] + l[3]) / u, m.units.length_name, (l[1] + l[2]) / u, a,
      d, ground_length / u, a, b, input_length / u, b, c, coupler_length / u, d, c,
      output_length / u);
}

namespace {
int column(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}
}  // namespace

double transmission_angle(const FourBar& fb, const Trajectory& t, int row) {
  const int b = column(t.point_names, fb.b), c = column(t.point_names, fb.c),
            d = column(t.point_names, fb.d);
  return interior_angle({t.x(row, c), t.y(row, c)}, {t.x(row, b), t.y(row, b)},
                        {t.x(row, d), t.y(row, d)});
}

double interior_angle(const Eigen::Vector2d& vertex, const Eigen::Vector2d& p,
                      const Eigen::Vector2d& q) {
  const Eigen::Vector2d u = p - vertex, v = q - vertex;
  return std::atan2(std::abs(u.x() * v.y() - u.y() * v.x()), u.dot(v));
}

std::optional<TransmissionRange> transmission_range(const FourBar& fb, const Trajectory& t) {
  if (column(t.point_names, fb.b) < 0 || column(t.point_names, fb.c) < 0 ||
      column(t.point_names, fb.d) < 0)
    return std::nullopt;
  TransmissionRange r;
  for (int row = 0; row < t.samples(); ++row) {
    const PoseStatus s = t.status[static_cast<size_t>(row)];
    if (s != PoseStatus::ok && s != PoseStatus::singular) continue;
    const double mu = transmission_angle(fb, t, row);
    if (r.samples == 0 || mu < r.min) r.min = mu, r.min_at = t.along(row);
    if (r.samples == 0 || mu > r.max) r.max = mu, r.max_at = t.along(row);
    ++r.samples;
  }
  if (r.samples == 0) return std::nullopt;
  return r;
}

}  // namespace crosslink
