#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <numbers>

#include "analytic/derived/claims.h"
#include "analytic/derived/jump.h"
#include "analytic/kinematics/branch.h"
#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/fourbar.h"
#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"
#include "compare/derived.h"
#include "methods/check.h"

namespace crosslink::methods {
namespace {

std::string joint_text(const Mechanism& m, const Joint& j) {
  const double mm = m.units.length;
  const std::string& unit = m.units.length_name;
  if (j.type == JointType::gear)
    return fmt::format(
        "gear         {} - {} about {} ({}, pitch radii {:g} and {:g} {}, ratio "
        "{:g})",
        m.links[j.link_a].name, m.links[j.link_b].name, m.links[j.carrier].name,
        j.ratio > 0.0 ? "external" : "internal", j.radius_a / mm, j.radius_b / mm, unit, j.ratio);
  if (j.type == JointType::rack_pinion)
    return fmt::format("rack_pinion  {} on the rack {} of slide {} (pitch radius {:g} {})",
                       m.links[j.link_a].name, m.links[j.link_b].name, m.joints[j.slide].name,
                       j.radius_a / mm, unit);
  if (j.type == JointType::revolute)
    return fmt::format("revolute     {} - {} at {}", m.links[j.link_a].name, m.links[j.link_b].name,
                       m.links[j.link_a].points[j.point_a].name);
  if (j.type == JointType::cam) {
    const cam::Follower& f = j.contour->follower();
    const char* kind = f.kind == cam::FollowerKind::flat_faced ? "flat-faced"
                       : f.kind == cam::FollowerKind::roller   ? "roller"
                                                               : "knife-edge";
    const std::string roller = f.kind == cam::FollowerKind::roller
                                   ? fmt::format(", roller {:g} {}", f.roller_radius / mm, unit)
                                   : "";
    // How the follower is kept on: a groove, or a spring against a contact that only pushes.
    const std::string closure = j.form_closed ? "; form-closed" : "; force-closed";
    const std::string& cam_link = m.links[j.link_a].name;
    const std::string& centre = m.links[j.link_a].points[j.centre_a].name;
    if (const cam::TangentCam* t = j.contour->tangent())
      return fmt::format(
          "cam          {} {} on tangent cam {} about {} (base circle {:g} {}, nose {:.6g} {} at "
          "{:.6g} {} from the centre, lift {:g} {} over an ascent of {:.4g} deg{}{})",
          kind, m.links[j.link_b].name, cam_link, centre, t->base_radius / mm, unit,
          t->nose_radius / mm, unit, t->distance / mm, unit, t->lift() / mm, unit,
          t->ascent() * 180.0 / std::numbers::pi, roller, closure);
    if (j.contour->surface())
      return fmt::format(
          "cam          {} {} on cam {} about {} (a profile through its points{}; least radius of "
          "curvature {:.4g} {}{})",
          kind, m.links[j.link_b].name, cam_link, centre, roller,
          j.contour->least_radius_of_curvature() / mm, unit, closure);
    if (const cam::EccentricCam* e = j.contour->eccentric())
      return fmt::format(
          "cam          {} {} on eccentric cam {} about {} (disc of radius {:g} {} at an "
          "eccentricity of {:g} {}, its centre at {:.6g} deg{}{})",
          kind, m.links[j.link_b].name, cam_link, centre, e->radius / mm, unit,
          e->eccentricity / mm, unit, e->angle * 180.0 / std::numbers::pi, roller, closure);
    return fmt::format(
        "cam          {} {} {} on {} about {} (base circle {:g} {}{}; least radius of curvature "
        "{:.4g} {}, largest pressure angle {:.2f} deg{})",
        f.oscillating ? "oscillating" : "translating", kind, m.links[j.link_b].name, cam_link,
        centre, f.base_radius / mm, unit, roller, j.contour->least_radius_of_curvature() / mm, unit,
        j.contour->largest_pressure_angle() * 180.0 / std::numbers::pi, closure);
  }
  if (j.type == JointType::pin_in_spline) {
    std::vector<std::string> through;
    for (int p : j.through) through.push_back(m.links[j.link_a].points[p].name);
    return fmt::format(
        "pin_in_slot  {} in a spline slot of {} (point {}, through {}, {:g} {} "
        "along its chord)",
        m.links[j.link_b].name, m.links[j.link_a].name, m.links[j.link_b].points[j.point_b].name,
        fmt::join(through, ", "), j.slot->last() / mm, unit);
  }
  if (j.type == JointType::pin_in_arc)
    return fmt::format("pin_in_slot  {} in an arc of {} (point {}, radius {:g} {} about {})",
                       m.links[j.link_b].name, m.links[j.link_a].name,
                       m.links[j.link_b].points[j.point_b].name, j.radius_a / mm, unit,
                       m.links[j.link_a].points[j.centre_a].name);
  return fmt::format("{:<12} {} on line '{}' of {} (point {})", to_string(j.type),
                     m.links[j.link_b].name, m.links[j.link_a].lines[j.line].name,
                     m.links[j.link_a].name, m.links[j.link_b].points[j.point_b].name);
}

std::string driver_text(const Mechanism& m, const Driver& d) {
  const DriverUnit u = driver_unit_of(d, m.units);
  const double unit = u.scale;
  const std::string& unit_name = u.name;
  std::string what;
  switch (d.type) {
    case DriverType::joint_angle:
      what = fmt::format("angle of {}->{} on {} relative to {} (joint {})",
                         m.links[d.link].points[d.from].name, m.links[d.link].points[d.to].name,
                         m.links[d.link].name, m.links[m.joints[d.joint].link_a].name,
                         m.joints[d.joint].name);
      break;
    case DriverType::link_angle:
      what = fmt::format("absolute angle of {}->{} on {}", m.links[d.link].points[d.from].name,
                         m.links[d.link].points[d.to].name, m.links[d.link].name);
      break;
    case DriverType::slider:
      what = fmt::format("displacement of slider {}", m.joints[d.joint].name);
      break;
  }
  std::string law;
  if (m.dynamics) {  // no motion law: the coordinate moves under the loads from its start
    const FreeCoordinate& c = m.dynamics->coordinate(static_cast<int>(&d - m.drivers.data()));
    const double rate_unit = d.angular() ? 1.0 : m.units.length;
    const std::string rate_name = d.angular() ? "rad/s" : m.units.length_name + "/s";
    law = fmt::format("free coordinate (dynamics): initial rate {:.6g} {}, {}, {:.6g} s",
                      c.rate / rate_unit, rate_name,
                      c.effort.empty()
                          ? std::string("no applied effort")
                          : fmt::format("applied effort table of {} rows", c.effort.size()),
                      m.dynamics->duration);
    return fmt::format("{}, start {:.6g} {}, {}", what, d.start / unit, unit_name, law);
  }
  switch (d.law.kind) {
    case MotionLaw::Kind::constant_speed:
      law = fmt::format("constant speed {:.6g} {}", d.law.speed / d.law.speed_unit.si,
                        d.law.speed_unit.name);
      break;
    case MotionLaw::Kind::constant_acceleration:
      law =
          fmt::format("constant acceleration {:.6g} {} from speed {:.6g} {}, over {:.6g} s",
                      d.law.acceleration / d.law.acceleration_unit.si, d.law.acceleration_unit.name,
                      d.law.speed / d.law.speed_unit.si, d.law.speed_unit.name, d.law.duration);
      break;
    case MotionLaw::Kind::polynomial:
      law = fmt::format("polynomial over {:.6g} s", d.law.duration);
      break;
    case MotionLaw::Kind::table:
      law = fmt::format("table of {} rows over {:.6g} s", d.law.table_time.size(), d.law.duration);
      break;
  }
  return fmt::format("{}, start {:.6g} {}, {}", what, d.start / unit, unit_name, law);
}

// Mass model, gravity, loads and springs, in the file's units; links on the default model named.
void print_physics(const Mechanism& m, std::string& out) {
  const double L = m.units.length, M = m.units.mass;
  std::vector<std::string> assumed;
  out +=
      fmt::format("  mass model ({}, {}, inertia about the centre of mass in {} {}^2):\n",
                  m.units.mass_name, m.units.length_name, m.units.mass_name, m.units.length_name);
  for (const Link& l : m.links) {
    if (l.ground) continue;
    if (l.mass.assumed) assumed.push_back(l.name);
    out +=
        fmt::format("    {:<14} mass {:.6g}  com ({:.6g}, {:.6g})  inertia {:.6g}{}\n", l.name,
                    l.mass.mass / M, l.mass.com.x() / L, l.mass.com.y() / L,
                    l.mass.inertia / (M * L * L), l.mass.assumed ? "  (default: uniform bar)" : "");
  }
  if (!assumed.empty())
    out += fmt::format(
        "  note: {} of {} moving links use the default mass model (a uniform bar between "
        "their farthest points, 1 kg per mechanism size of length): give mass, com and "
        "inertia for real forces\n",
        assumed.size(), m.moving_count());
  if (m.gravity.norm() > 0.0)
    out += fmt::format("  gravity: ({:.6g}, {:.6g}) {}/s^2\n", m.gravity.x() / L, m.gravity.y() / L,
                       m.units.length_name);
  for (const Load& load : m.loads)
    out += fmt::format(
        "  load {}: {} on {}{}\n", load.name, load.kind == Load::Kind::force ? "force" : "torque",
        m.links[static_cast<size_t>(load.link)].name,
        load.table ? fmt::format(" (table of {} rows over the driver)", load.rows.size()) : "");
  for (const Spring& s : m.springs)
    out += fmt::format(
        "  spring {}: {}:{} - {}:{}, stiffness {:.6g} {}/{}, free length {:.6g} {}, "
        "damping {:.6g} {} s/{}\n",
        s.name, m.links[static_cast<size_t>(s.link_a)].name, s.point_a,
        m.links[static_cast<size_t>(s.link_b)].name, s.point_b, s.stiffness * L / m.units.force,
        m.units.force_name, m.units.length_name, s.free_length / L, m.units.length_name,
        s.damping * L / m.units.force, m.units.force_name, m.units.length_name);
  for (int ji : m.friction_joints()) {
    const Joint& j = m.joints[static_cast<size_t>(ji)];
    const JointFriction& f = *j.friction;
    const double F = m.units.force;
    std::vector<std::string> parts;
    if (f.coefficient > 0.0 && !j.is_slide())
      parts.push_back(fmt::format("mu {:g} on a pin of radius {:g} {} (friction circle {:.6g} {})",
                                  f.coefficient, f.radius / L, m.units.length_name,
                                  f.coefficient * f.radius / L, m.units.length_name));
    if (f.coefficient > 0.0 && j.is_slide())
      parts.push_back(f.length > 0.0 ? fmt::format("mu {:g} over a bearing {:g} {} long",
                                                   f.coefficient, f.length / L, m.units.length_name)
                                     : fmt::format("mu {:g} at a point contact", f.coefficient));
    if (f.constant > 0.0)
      parts.push_back(j.is_slide()
                          ? fmt::format("{:.6g} {} constant", f.constant / F, m.units.force_name)
                          : fmt::format("{:.6g} {} {} constant", f.constant / (F * L),
                                        m.units.force_name, m.units.length_name));
    out += fmt::format("  friction at {}: {}\n", j.name, fmt::join(parts, " + "));
  }
}

// Singular positions over the sweep (at_limit = stop) and, for four-bars, the Grashof class and
// the transmission angle over the swept samples.
// Returns the sweep it printed from.
Trajectory print_singular_positions(const Mechanism& m, const SweepOptions& options,
                                    std::string& out, std::vector<SingularPosition>& singular) {
  // Several drivers: the sweep runs in time, and its events are located in time.
  const bool timed = m.axis().timed();
  const DriverUnit axis_unit = axis_unit_of(m);
  const double unit = axis_unit.scale;
  const std::string& unit_name = axis_unit.name;
  const std::string_view at = timed ? "t" : "driver";
  const Trajectory t = sweep(m, options, singular);
  int flagged = 0;
  for (const PoseStatus s : t.status) flagged += s != PoseStatus::ok;
  // Several drivers: the timed sweep's singular positions are its classified events.
  const auto classified = static_cast<size_t>(std::count_if(
      t.events.begin(), t.events.end(),
      [](const Trajectory::Event& e) { return e.singularity != ParallelSingularity::none; }));
  const size_t located = timed ? classified : singular.size();
  out +=
      fmt::format("  singular positions over the sweep: {}{}\n",
                  located == 0 ? std::string("none") : std::to_string(located),
                  flagged ? fmt::format(" ({} of {} samples flagged)", flagged, t.samples()) : "");
  // Located to ~1e-12: a value that rounds to zero is printed as 0, not -0.
  const auto value = [&](double driver) {
    const double v = driver / unit;
    return std::abs(v) < 5e-10 ? 0.0 : v;
  };
  for (const SingularPosition& p : singular)
    out += fmt::format("    {:<13} at {} = {:.9f} {}\n", to_string(p.kind), at, value(p.driver),
                       unit_name);  // a time where the sweep runs in time
  if (singular.empty())
    for (const Trajectory::Event& e : t.events)  // the Follower's events (explicit range, law)
      out += fmt::format(
          "    {:<13} at {} = {:.9f} {}: {}\n",
          e.singularity != ParallelSingularity::none ? to_string(e.singularity) : to_string(e.kind),
          at, value(e.driver), unit_name, e.message);
  if (const auto fb = four_bar(m)) {
    out += fmt::format("  four-bar: {}\n", fb->explain(m));
    if (const auto mu = transmission_range(*fb, t))
      out += fmt::format(
          "  transmission angle (at {}, over {} samples): min {:.4f} deg at driver = {:.6f} "
          "{}, max {:.4f} deg at driver = {:.6f} {}\n",
          fb->c, mu->samples, mu->min * 180 / std::numbers::pi, mu->min_at / unit, unit_name,
          mu->max * 180 / std::numbers::pi, mu->max_at / unit, unit_name);
  }
  return t;
}

// Each spline slot's ends where the sweep met them (the sweep's events: where the pin leaves the
// slot and where it comes back), as the driver's values past them, which have no pose; the
// assembling range above is its toggles'.
// (A sweep in time lists its events only: the ends are located on a driver's value.)
void print_slot_ends(const Mechanism& m, const Trajectory& t, std::string& out) {
  if (m.axis().timed()) return;
  const DriverUnit unit = axis_unit_of(m);
  for (const Joint& j : m.joints) {
    if (j.type != JointType::pin_in_spline) continue;
    const std::string slot = fmt::format("spline slot '{}'", j.name);
    std::vector<std::string> past;  // "from A to B"
    std::string from = t.samples() > 0 ? unit.text(t.along(0), 9) : "";
    bool open = false;  // the pin is past an end
    for (const Trajectory::Event& e : t.events) {
      if (e.kind != PoseStatus::cannot_assemble || e.message.find(slot) == std::string::npos)
        continue;
      const bool back = e.message.find(" comes back from past ") != std::string::npos;
      if (!back) from = unit.text(e.driver, 9);
      if (back) past.push_back(fmt::format("from {} to {}", from, unit.text(e.driver, 9)));
      open = !back;
    }
    if (open) past.push_back(fmt::format("from {} to the sweep's end", from));
    out += past.empty() ? fmt::format("  {}: holds its pin over the sweep\n", slot)
                        : fmt::format("  {}: its ends stop the pin: no pose {}\n", slot,
                                      fmt::join(past, ", "));
  }
}

// Which assembly the chain starts on, who chose it, and whether another closes there.
void print_modes(const Mechanism& m, const KinematicState& assembled, std::string& out) {
  std::string chosen =
      m.drawn() ? "as the poses draw it" : "by default: no poses drawn, no [[branch]]";
  if (!m.branches.empty()) {
    chosen = "as [[branch]] asks:";
    for (const BranchChoice& b : m.branches)
      chosen += fmt::format(" {} (line {});", b.text(), b.where.line);
    chosen.pop_back();
  }
  const std::vector<GroupMode> modes = start_modes(m, assembled);
  if (modes.empty()) {
    out += fmt::format("  assembly mode at start: {}\n", chosen);
    return;
  }
  out += fmt::format("  assembly modes at start ({}):\n", chosen);
  for (const GroupMode& g : modes) {
    std::string other = "the other mode does not close the chain here";
    if (g.other_closes && g.other) {
      std::string names;
      for (const std::string& n : g.other->names)
        names += fmt::format("{}\"{}\"", names.empty() ? "" : ", ", n);
      other = fmt::format("the other mode closes too: [[branch]] points = [{}], turn = \"{}\"",
                          names, g.other->counter_clockwise ? "ccw" : "cw");
    } else if (g.other_closes) {
      other = "the other mode closes too (draw poses near it to choose it)";
    }
    out += fmt::format("    {}: {}; {}\n", g.group, g.mode, other);
  }
}

// The design summary (DerivedSpec::summary) among the [[derived]] values, in the file's units.
void print_design_summary(const Mechanism& m, std::vector<DerivedValue> summary, std::string& out) {
  std::erase_if(summary, [](const DerivedValue& v) { return !v.spec->summary; });
  if (summary.empty()) return;
  out += "  design summary (docs/mechanism-format.md, \"Design summary\"):\n" +
         compare::derived_exact_text(m, summary, 4);
}

// The definition's own claims ([expect], [expect.derived]) judged against the exact sweep: each
// on stdout, each that does not hold also at its place on stderr, with exit 1. Returns how many
// do not hold.
// `derived`: the [[derived]] values on the exact sweep, none without one.
int print_claims(const Mechanism& m, const std::optional<std::vector<DerivedValue>>& derived,
                 const std::vector<SingularPosition>& singular, CheckReport& report) {
  if (!m.expect) return 0;
  const double tolerance = claim_tolerance_pct(*m.expect);
  if (!derived) {  // at rest: nothing swept, nothing to judge a claim against
    report.err += Diagnostic{m.expect->where,
                             "[expect]: not judged: the driver is at rest (speed 0), so "
                             "nothing is swept"}
                      .str() +
                  "\n";
    report.exit_code = CheckReport::kClaimFails;
    return 1;
  }
  const std::vector<Claim> claims = judge_claims(m, *derived, singular);
  const auto failed = static_cast<int>(
      std::count_if(claims.begin(), claims.end(), [](const Claim& c) { return !c.holds; }));
  report.out += fmt::format("  claims ([expect], tolerance {:g} %{}): {} of {} hold\n", tolerance,
                            m.expect->tolerance_pct ? "" : ", the default",
                            claims.size() - static_cast<size_t>(failed), claims.size());
  for (const Claim& c : claims) {
    report.out += fmt::format("    {:<4} {} (line {}): claimed {}, computed {}\n",
                              c.holds ? "ok" : "FAIL", c.what, c.where.line, c.claimed, c.computed);
    if (!c.holds)
      report.err += Diagnostic{c.where, fmt::format("{} does not hold: claimed {}, computed {} "
                                                    "(tolerance {:g} %)",
                                                    c.what, c.claimed, c.computed, tolerance)}
                        .str() +
                    "\n";
  }
  if (failed) report.exit_code = CheckReport::kClaimFails;
  return failed;
}

}  // namespace

CheckReport check_report(const Mechanism& m, const WorkLimits& limits,
                         const SweepOptions& options) {
  if (!m.at_rest()) check_sweep_work(m, options, limits);
  CheckReport report;
  std::string& out = report.out;
  out += fmt::format("{}: {}\n", m.file, m.name);
  if (!m.citation.empty()) out += fmt::format("  source: {}\n", m.citation);
  out += fmt::format("  units: {}, {}\n", m.units.length_name, m.units.angle_name);
  out += fmt::format("  links ({}):\n", m.links.size());
  for (const Link& l : m.links) {
    std::string points;
    for (const Point& p : l.points) points += (points.empty() ? "" : " ") + p.name;
    out += fmt::format("    {:<14} {}points {}\n", l.name, l.ground ? "(ground) " : "", points);
  }
  out += fmt::format("  joints ({}):\n", m.joints.size());
  for (const Joint& j : m.joints) out += fmt::format("    {:<14} {}\n", j.name, joint_text(m, j));
  print_physics(m, out);
  out += fmt::format("  mobility: {}\n", mobility(m).explain());
  if (m.axis().timed()) {
    out += fmt::format(
        "  drivers ({}; the sweep runs in time over {:.6g} s, the longest of their "
        "cycles):\n",
        m.drivers.size(), m.cycle_period());
    for (const Driver& d : m.drivers)
      out += fmt::format("    {:<14} {}\n", d.name, driver_text(m, d));
  } else {
    out += fmt::format("  driver: {}\n", driver_text(m, m.swept()));
  }

  // The closed-form method: the groups the chain decomposes into once the drivers, gear pairs
  // and racks are applied, or why it does not (Newton solves it).
  if (const Decomposition d = decompose(m); d.complete) {
    out += fmt::format("  closed-form dyads ({} groups):\n", d.groups.size());
    for (const AssurGroup& g : d.groups) out += fmt::format("    {}\n", g.name);
  } else {
    out += fmt::format("  closed-form dyads: none: {}\n", d.reason);
  }

  const NewtonSolver solver(m);
  KinematicState state(m);
  const SolveReport assembled = solver.assemble(state);
  if (assembled.status == PoseStatus::cannot_assemble ||
      assembled.status == PoseStatus::no_convergence) {
    // At the driver's table: its start value is where the chain must close.
    const Diagnostic problem{
        start_where(m), fmt::format("cannot assemble at {}: {}", start_text(m), assembled.message)};
    report.err = problem.str() + "\n";
    report.exit_code = CheckReport::kCannotStart;
    return report;
  }
  out += fmt::format(
      "  assembly at start: {} (residual {:.1e} m, {} Newton iterations, rcond {:.2e})\n",
      to_string(assembled.status), assembled.residual, assembled.iterations, assembled.rcond);
  if (m.dynamics) {
    if (const std::string why = singular_start(m, assembled.rcond); !why.empty()) {
      report.err = Diagnostic{m.dynamics->where, why}.str() + "\n";
      report.exit_code = CheckReport::kCannotStart;
      return report;
    }
  }
  print_modes(m, state, out);
  if (m.at_rest()) {
    out +=
        "  speed 0: one pose at rest (solve --at VALUE); the assembling range and the singular "
        "positions over a sweep need a speed\n";
  } else if (!m.axis().timed() && m.swept().law.kind == MotionLaw::Kind::constant_speed) {
    const AssemblingRange range = assembling_range(m, options);
    out += fmt::format("  assembling range: {}{}\n", range.explain(m),
                       range.full_cycle || !range.unknown.empty()
                           ? ""
                           : " (limits: toggles; the chain cannot close beyond)");
  }
  std::vector<SingularPosition> singular;
  if (!m.at_rest()) report.sweep = print_singular_positions(m, options, out, singular);
  if (report.sweep) print_slot_ends(m, *report.sweep, out);
  // A force-closed cam's jump speed: faster, its follower leaves the cam (docs/cams.md).
  for (size_t ji = 0; report.sweep && ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (j.type != JointType::cam || j.form_closed) continue;
    const JumpSpeed jump = jump_speed(m, static_cast<int>(ji));
    if (!jump.speed) {
      out += fmt::format("  jump speed of cam {}: none: {}\n", j.name, jump.reason);
      continue;
    }
    const bool angular = m.swept().angular();
    const DriverUnit unit = axis_unit_of(m);
    out += fmt::format(
        "  jump speed of cam {}: {:.6g} {}{} at driver = {:.6g} {} (faster, the follower leaves "
        "the cam there)\n",
        j.name, *jump.speed, angular ? "rad/s" : "m/s",
        angular ? fmt::format(" ({:.6g} rpm)", *jump.speed * 30.0 / std::numbers::pi) : "",
        jump.at / unit.scale, unit.name);
  }
  out += fmt::format("  references: {}\n", m.references.size());
  if (assembled.status == PoseStatus::singular)
    out += fmt::format("  warning: the drawn position is singular: {}\n", assembled.message);
  // The [[derived]] values once, for the design summary and the claims.
  std::optional<std::vector<DerivedValue>> derived;
  if (report.sweep) {
    derived = derived_exact(m, *report.sweep);
    print_design_summary(m, *derived, out);
  }
  const int failed = print_claims(m, derived, singular, report);
  out += failed ? fmt::format("  FAIL: {} claim{} of the definition do{} not hold\n", failed,
                              failed == 1 ? "" : "s", failed == 1 ? "es" : "")
                : "  ok\n";
  return report;
}

}  // namespace crosslink::methods
