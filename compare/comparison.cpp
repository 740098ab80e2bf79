#include "compare/comparison.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "analytic/reference/trust.h"

namespace crosslink::compare {

bool MethodRun::computes(std::string_view channel) const {
  const std::string_view kind = channel.substr(0, channel.find('.'));
  return kinds.empty() || std::find(kinds.begin(), kinds.end(), kind) != kinds.end();
}

std::string_view to_string(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass:
      return "pass";
    case Verdict::fail:
      return "FAIL";
    case Verdict::not_applicable:
      return "n/a";
  }
  return "?";
}

const MethodRun* Comparison::method(std::string_view name) const {
  for (const MethodRun& m : methods)
    if (m.name == name) return &m;
  return nullptr;
}

bool prescribed(const Mechanism& m, std::string_view channel) {
  const size_t dot = channel.find('.');
  if (dot == std::string_view::npos) return false;
  const std::string_view kind = channel.substr(0, dot), object = channel.substr(dot + 1);
  const int ground = m.ground();
  if (ground < 0) return false;
  const bool driven = !m.dynamics;  // in a dynamics case the driver's coordinate moves freely
  // Whether joint j joins `link` to the ground.
  const auto grounded = [&](int link, const Joint& j) {
    return (j.link_a == ground && j.link_b == link) || (j.link_b == ground && j.link_a == link);
  };
  static constexpr std::array<std::string_view, 8> kPointKinds = {"x", "y",  "vx", "vy",
                                                                  "v", "ax", "ay", "a"};
  if (std::find(kPointKinds.begin(), kPointKinds.end(), kind) != kPointKinds.end())
    return m.links[static_cast<size_t>(ground)].find_point(object) >= 0;
  // Several drivers' own values (angle.<name>, s.<name>) follow their laws.
  if ((kind == "angle" || kind == "s") && m.axis().timed() &&
      std::any_of(m.drivers.begin(), m.drivers.end(),
                  [&](const Driver& d) { return d.name == object; }))
    return driven;
  if (kind == "angle" || kind == "omega" || kind == "alpha") {
    const int link = m.find_link(object);
    if (link < 0) return false;
    for (const Joint& j : m.joints)
      if (j.type == JointType::prismatic && grounded(link, j)) return true;
    if (!driven) return false;
    // Every driver's: several drivers each prescribe their link's angle.
    return std::any_of(m.drivers.begin(), m.drivers.end(), [&](const Driver& d) {
      if (d.type == DriverType::link_angle) return d.link == link;
      return d.type == DriverType::joint_angle &&
             grounded(link, m.joints[static_cast<size_t>(d.joint)]);
    });
  }
  if (kind == "s" || kind == "sdot" || kind == "sddot")
    return driven && std::any_of(m.drivers.begin(), m.drivers.end(), [&](const Driver& d) {
             return d.type == DriverType::slider &&
                    m.joints[static_cast<size_t>(d.joint)].name == object;
           });
  return false;
}

int Comparison::failures() const {
  return static_cast<int>(std::count_if(channels.begin(), channels.end(),
                                        [](const auto& c) { return c.verdict == Verdict::fail; }));
}

Comparison::Counts Comparison::counts(bool prescribed) const {
  Counts n;
  for (const ChannelResult& c : channels)
    if (c.prescribed == prescribed)
      ++(c.verdict == Verdict::pass   ? n.pass
         : c.verdict == Verdict::fail ? n.fail
                                      : n.not_applicable);
  return n;
}

std::string Comparison::counts_text() const {
  const Counts computed = counts(false), fixed = counts(true);
  return fmt::format(
             "{} channel comparisons: {} pass, {} fail, {} n/a; {} more of values the definition "
             "prescribes (ground points, the driven coordinate): {} pass, {} fail, {} n/a",
             computed.total(), computed.pass, computed.fail, computed.not_applicable, fixed.total(),
             fixed.pass, fixed.fail, fixed.not_applicable) +
         derived_counts_text() + references_counts_text();
}

std::string Comparison::references_counts_text() const {
  int judged = 0, hold = 0, shown = 0, within = 0;
  for (const ReferenceRow& r : references) {
    if (const std::optional<bool> h = r.holds()) {
      ++judged;
      hold += *h ? 1 : 0;
    } else {
      ++shown;
      within += r.exact_ok && r.reference.within_rounding(r.exact) ? 1 : 0;
    }
  }
  std::string text;
  if (judged)
    text += fmt::format("; {} [[reference]] value{} judged: {} hold, {} fail", judged,
                        judged == 1 ? "" : "s", hold, judged - hold);
  if (shown)
    text += fmt::format(
        "; {} [[reference]] value{} beside the exact ones, {} within their printed rounding "
        "(shown, not judged)",
        shown, shown == 1 ? "" : "s", within);
  return text;
}

int Comparison::reference_failures() const {
  return static_cast<int>(std::count_if(references.begin(), references.end(),
                                        [](const ReferenceRow& r) { return r.holds() == false; }));
}

std::string Comparison::derived_counts_text() const {
  Counts c;
  int summary = 0;
  for (const DerivedCheck& d : derived.checks) {
    if (d.spec->summary) {  // compared, never judged
      ++summary;
      continue;
    }
    (d.verdict == Verdict::pass   ? c.pass
     : d.verdict == Verdict::fail ? c.fail
                                  : c.not_applicable)++;
  }
  std::string text;
  if (c.total())
    text += fmt::format("; {} [[derived]] comparisons: {} pass, {} fail, {} n/a", c.total(), c.pass,
                        c.fail, c.not_applicable);
  if (summary) text += fmt::format("; {} design summary values compared, not judged", summary);
  return text;
}

bool Comparison::pass() const {
  return failures() == 0 && failed_methods.empty() && derived.failures() == 0 &&
         reference_failures() == 0;
}

std::optional<double> value_at(const Trajectory& trajectory, std::string_view channel,
                               double driver_value, bool angular, bool* interpolated) {
  const std::optional<Eigen::VectorXd> column = trajectory.channel(channel);
  if (!column || trajectory.samples() == 0) return std::nullopt;
  const int n = trajectory.samples();
  auto offset = [&](int k) {
    const double d = trajectory.along(k) - driver_value;
    return angular ? wrap_angle(d) : d;
  };
  const Quantity q = Trajectory::quantity_of(channel);
  const bool angle_channel = q == Quantity::angle;
  // A sample on the value: none when that sample holds no such value (flagged, or not run).
  const double on_grid = 1e-9 * std::max(1.0, std::abs(driver_value));
  for (int k = 0; k < n; ++k)
    if (std::abs(offset(k)) <= on_grid) {
      if (!trajectory.has_value(k, q)) return std::nullopt;
      if (interpolated) *interpolated = false;
      return (*column)(k);
    }
  // Two consecutive samples around it (not across a wrap of the offset), both holding a value.
  for (int k = 0; k + 1 < n; ++k) {
    const double a = offset(k), b = offset(k + 1);
    const double step = std::abs(trajectory.along(k + 1) - trajectory.along(k));
    if ((a < 0.0) == (b < 0.0) || std::abs(a - b) > 1.5 * step) continue;
    if (!trajectory.has_value(k, q) || !trajectory.has_value(k + 1, q)) return std::nullopt;
    const double w = a / (a - b);
    double va = (*column)(k), vb = (*column)(k + 1);
    if (angle_channel) vb = va + wrap_angle(vb - va);
    if (interpolated) *interpolated = true;
    return va + w * (vb - va);
  }
  return std::nullopt;
}

std::optional<bool> ReferenceRow::holds() const {
  if (!reference.judged()) return std::nullopt;
  if (!exact_ok) return false;
  if (reference.to_rounding) return reference.within_rounding(exact);
  return std::abs(percent(reference.value, exact)) <= *reference.tolerance_pct;  // NaN: no
}

double ReferenceRow::percent(double value, double against) const {
  // Against a round-off zero, or a subnormal one (a reference at rest): no %.
  if (std::abs(against) <= zero || std::abs(against) < std::numeric_limits<double>::min())
    return std::numeric_limits<double>::quiet_NaN();
  if (Trajectory::quantity_of(reference.quantity) == Quantity::angle)
    return percent_difference(wrap_positive_angle(value), wrap_positive_angle(against));
  return percent_difference(value, against);
}

Comparison compare_methods(const Mechanism& mechanism, std::vector<MethodRun> methods,
                           const Tolerances& tolerances, const ExactValues& exact) {
  Comparison out;
  out.mechanism = &mechanism;
  out.methods = std::move(methods);
  const Trajectory& ref = out.methods.front().trajectory;
  const int n = ref.samples();
  const std::vector<std::string> channels = ref.channel_names();

  // Reference columns, and the scales of metrics.h: the size L, the driver's peak rate W, the
  // largest peak of each kind.
  // Trusted reference samples, and why the others are kept out (analytic/reference/trust.h): the
  // kinematic channels' and, stricter near singular positions, the forces'.
  const double force_rcond = kForceConditioning * typical_rcond(ref);
  std::vector<std::string> ref_out(static_cast<size_t>(n)), ref_out_forces(ref_out);
  std::vector<bool> ref_usable(static_cast<size_t>(n)), ref_usable_forces(ref_usable);
  for (int k = 0; k < n; ++k) {
    const auto ks = static_cast<size_t>(k);
    ref_out[ks] = untrusted(ref, k, 0.0);
    ref_out_forces[ks] = untrusted(ref, k, force_rcond);
    ref_usable[ks] = ref_out[ks].empty();
    ref_usable_forces[ks] = ref_out_forces[ks].empty();
  }
  // Peaks, and so scales, over the trusted samples of each channel's kind.
  auto trusted = [&](std::string_view channel) -> const std::vector<bool>& {
    const Quantity q = Trajectory::quantity_of(channel);
    return q == Quantity::force || q == Quantity::torque ? ref_usable_forces : ref_usable;
  };
  const double size = mechanism.size();
  const double driver_rate = driver_peak_rate(mechanism, ref);
  const double energy_scale = ref.energy_scale();
  std::vector<Eigen::VectorXd> ref_columns;
  std::map<std::string, double> kind_peak;
  Scales scales{size, driver_rate};
  for (const std::string& c : channels) {
    ref_columns.push_back(*ref.channel(c));
    const double p = channel_peak(c, ref_columns.back(), trusted(c), size);
    double& peak = kind_peak[channel_kind(c)];
    peak = std::max(peak, p);
    const Quantity q = Trajectory::quantity_of(c);
    if (q == Quantity::force) scales.force = std::max(scales.force, p);
    if (q == Quantity::torque) scales.torque = std::max(scales.torque, p);
  }
  // A component (vx.B) is judged against its vector's magnitude (v.B).
  auto magnitude_peak = [&](const std::string& channel) {
    const std::string kind = channel.substr(0, channel.find('.'));
    if (kind != "vx" && kind != "vy" && kind != "ax" && kind != "ay" && kind != "fx" &&
        kind != "fy")
      return 0.0;
    const std::string magnitude = kind.substr(0, 1) + channel.substr(channel.find('.'));
    return channel_peak(magnitude, *ref.channel(magnitude), trusted(magnitude), size);
  };

  // Every method after the reference, channel by channel.
  for (size_t mi = 1; mi < out.methods.size(); ++mi) {
    const MethodRun& run = out.methods[mi];
    if (!run.available) continue;
    if (!run.ok) {
      out.failed_methods.push_back(run.name);
      continue;
    }
    // Why each sample is kept out of this method's verdicts: the reference's reason, else the
    // method's own status.
    std::vector<std::string> out_kinematic(static_cast<size_t>(n)), out_forces(out_kinematic);
    std::vector<bool> both(static_cast<size_t>(n)), both_forces(both);
    int usable_samples = 0;
    for (int k = 0; k < n; ++k) {
      const auto ks = static_cast<size_t>(k);
      const PoseStatus s = run.trajectory.status[ks];
      const std::string own = usable(s) ? "" : "method:" + std::string(to_string(s));
      out_kinematic[ks] = ref_out[ks].empty() ? own : ref_out[ks];
      out_forces[ks] = ref_out_forces[ks].empty() ? own : ref_out_forces[ks];
      both[ks] = out_kinematic[ks].empty();
      both_forces[ks] = out_forces[ks].empty();
      usable_samples += both[ks] ? 1 : 0;
    }
    // A method that flags every sample has shown nothing: it fails rather than passing empty.
    if (usable_samples == 0 && n > 0) {
      out.failed_methods.push_back(run.name);
      continue;
    }
    for (size_t c = 0; c < channels.size(); ++c) {
      const Quantity q = Trajectory::quantity_of(channels[c]);
      if (!run.computes(channels[c])) continue;
      const std::optional<Eigen::VectorXd> column = run.trajectory.channel(channels[c]);
      if (!column) continue;
      ChannelResult result;
      result.method = run.name;
      // Energy channels have no scale of their own (potential energy depends on the origin, the
      // balance's error is zero when exact): the energy the reference's motion moves.
      const double floor = q == Quantity::energy
                               ? energy_scale
                               : peak_floor(channels[c], kind_peak[channel_kind(channels[c])],
                                            magnitude_peak(channels[c]), scales);
      const bool force = q == Quantity::force || q == Quantity::torque;
      result.metrics = compare_channel(channels[c], ref_columns[c], *column,
                                       force ? both_forces : both, size, floor);
      result.metrics.reason = force ? out_forces : out_kinematic;
      result.tolerance = tolerances.of(run.name, q);
      result.prescribed = prescribed(mechanism, channels[c]);
      // No sample, or no scale to take a % of (a reference at rest): no verdict.
      result.verdict = result.metrics.usable == 0 || std::isnan(result.metrics.max_pct_of_peak)
                           ? Verdict::not_applicable
                       : result.metrics.max_pct_of_peak <= result.tolerance ? Verdict::pass
                                                                            : Verdict::fail;
      out.channels.push_back(std::move(result));
    }
  }

  out.derived = compare_derived(mechanism, out.methods, tolerances, exact.derived);
  if (exact.references.size() != mechanism.references.size())
    throw std::logic_error("compare_methods: the exact values are not the mechanism's references");

  // [[reference]] rows: exact at the printed driver value, every method on its sweep (the
  // loader refuses them in a sweep in time).
  for (size_t k = 0; k < mechanism.references.size(); ++k) {
    const Reference& r = mechanism.references[k];
    const bool angular = mechanism.swept().angular();
    ReferenceRow row;
    row.reference = r;
    if (r.derived) {
      // A [[derived]] quantity: exact as located, every other method's from its samples.
      if (const std::optional<double> v = derived_value(out.derived.exact, r.quantity)) {
        row.exact = *v;
        row.exact_ok = true;
        row.zero = 1e-9 * std::abs(*v);
      }
      if (const std::optional<double> v = derived_value(out.derived.estimate, r.quantity))
        row.values.push_back({out.methods.front().name, *v, true});
      for (const DerivedResults::Method& method : out.derived.methods)
        if (const std::optional<double> v = derived_value(method.values, r.quantity))
          row.values.push_back({method.name, *v, true});
      out.references.push_back(std::move(row));
      continue;
    }
    const Eigen::VectorXd none;
    row.zero = 1e-9 * std::max(channel_peak(r.quantity, none, {}, size),
                               peak_floor(r.quantity, 0.0, 0.0, scales));
    if (exact.references[k]) {
      row.exact = *exact.references[k];
      row.exact_ok = true;
    }
    for (const MethodRun& run : out.methods) {
      if (!run.available || !run.ok || !run.computes(r.quantity)) continue;
      bool interpolated = false;
      if (const auto v =
              value_at(run.trajectory, r.quantity, r.driver_value, angular, &interpolated))
        row.values.push_back({run.name, *v, interpolated});
    }
    out.references.push_back(std::move(row));
  }
  return out;
}

WorstContext worst_context(const Trajectory& reference, int k, bool in_time) {
  WorstContext out;
  if (k < 0 || k >= reference.samples()) return out;
  if (reference.rcond.size() == reference.samples() && reference.rcond(k) > 0.0) {
    std::vector<double> usable_rcond;
    for (int i = 0; i < reference.samples(); ++i)
      if (usable(reference.status[static_cast<size_t>(i)]) && reference.rcond(i) > 0.0)
        usable_rcond.push_back(reference.rcond(i));
    if (!usable_rcond.empty()) {
      const auto middle = usable_rcond.begin() + static_cast<long>(usable_rcond.size() / 2);
      std::nth_element(usable_rcond.begin(), middle, usable_rcond.end());
      out.rcond = reference.rcond(k);
      out.median_rcond = *middle;
    }
  }
  const double at = in_time ? reference.time(k) : reference.along(k);
  for (const Trajectory::Event& e : reference.events)
    if (e.kind == PoseStatus::singular &&
        (!out.nearest_singular || std::abs(e.driver - at) < std::abs(out.distance))) {
      out.nearest_singular = &e;
      out.distance = e.driver - at;
    }
  return out;
}

}  // namespace crosslink::compare
