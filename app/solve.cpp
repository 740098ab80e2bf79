// `crosslink solve FILE [--at VALUE] [--format table|json|csv]`: exact kinematics at one driver
// value or over the whole sweep. The table is in the file's units; JSON and CSV are SI.
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "analytic/reference/sweep.h"
#include "app/commands.h"
#include "app/files.h"
#include "app/output.h"
#include "compare/derived.h"
#include "compare/drawing_svg.h"
#include "methods/solve.h"

namespace crosslink::app {
namespace {

// Kennedy–Aronhold centres at one sample and the velocities they give, beside the exact ones.
void print_instant_centres(const Mechanism& m, const Trajectory& t) {
  const double L = m.units.length;
  const std::string& ln = m.units.length_name;
  const InstantCentres ic = instant_centres(m, t, 0);
  fmt::print("\ninstantaneous centres (links numbered in definition order: {})\n", [&] {
    std::string names;
    for (size_t l = 0; l < m.links.size(); ++l)
      names += fmt::format("{}{} {}", l ? ", " : "", l + 1, m.links[l].name);
    return names;
  }());
  fmt::print("{:<8} {:>24}  {}\n", "pair", fmt::format("x, y [{}]", ln), "found");
  for (const InstantCentre& c : ic.centres) {
    const std::string where =
        !c.placed() ? std::string("undefined")
        : c.at_infinity()
            ? fmt::format("at infinity, direction ({:.4f}, {:.4f})", c.point.x(), c.point.y())
            : fmt::format("{:.4f}, {:.4f}", c.point.x() / L, c.point.y() / L);
    fmt::print("I({},{})   {:>24}  {}\n", c.i + 1, c.j + 1, where, c.how);
  }
  if (ic.kennedy_unplaced > 0)
    fmt::print(
        "({} centre(s) Kennedy's theorem alone cannot place: taken from the velocity "
        "solution, as labelled)\n",
        ic.kennedy_unplaced);
  const CentreVelocities v = centre_velocities(m, ic, t, 0);
  if (!v.complete) {
    fmt::print("velocities from the centres: {}\n", v.message);
    return;
  }
  fmt::print("\n{:<14} {:>14} {:>14} {:>10}\n", "link", "omega exact", "omega IC", "diff %");
  for (size_t l = 0; l < t.link_names.size(); ++l) {
    const double exact = t.omega(0, static_cast<Eigen::Index>(l));
    fmt::print("{:<14} {:>14.4f} {:>14.4f} {:>10.2e}{}\n", t.link_names[l], exact, v.omega[l],
               exact != 0.0 ? 100.0 * (v.omega[l] - exact) / exact : 0.0,
               v.from_geometry[l] ? "" : "  (uses a centre from the velocity solution)");
  }
  fmt::print("\n{:<8} {:>12} {:>12} {:>12} {:>12} {:>10}   [{}/s]\n", "point", "vx exact",
             "vy exact", "vx IC", "vy IC", "|v| diff %", ln);
  for (size_t p = 0; p < t.point_names.size(); ++p) {
    const auto c = static_cast<Eigen::Index>(p);
    const Eigen::Vector2d exact(t.vx(0, c), t.vy(0, c));
    fmt::print("{:<8} {:>12.4f} {:>12.4f} {:>12.4f} {:>12.4f} {:>10.2e}\n", t.point_names[p],
               exact.x() / L, exact.y() / L, v.point[p].x() / L, v.point[p].y() / L,
               exact.norm() > 0.0 ? 100.0 * (v.point[p] - exact).norm() / exact.norm() : 0.0);
  }
}

}  // namespace

int run_solve(const SolveArgs& args) {
  const Mechanism m = load_mechanism(args.path);
  SweepOptions options;
  if (args.step != 0.0)  // 0: not given (the default); --step itself is positive
    options.step = args.step * axis_unit_of(m).scale;
  const bool reverse = args.at_limit == "reverse";
  if (reverse) options.at_limit = SweepOptions::AtLimit::reverse;
  const bool single = args.at.has_value();
  if (args.ic && !single) {
    fmt::print(stderr, "{}: error: --ic needs --at VALUE (centres of one pose)\n", m.file);
    return kExitBadInput;
  }
  if (args.ic && m.at_rest()) {  // at the speed that says so
    fmt::print(stderr, "{}\n",
               Diagnostic{m.axis().timed() ? start_where(m) : m.swept().law.where,
                          "--ic: the driver is at rest (speed 0): every velocity is zero and "
                          "no centre is defined by them"}
                   .str());
    return kExitBadInput;
  }
  if (args.animate != 0.0 && (args.svg.empty() || single || !(args.animate > 0.0))) {
    fmt::print(stderr,
               "{}: error: --animate SECONDS animates the --svg drawing over the sweep: it needs "
               "--svg FILE, no --at, and a positive number of seconds\n",
               m.file);
    return kExitBadInput;
  }
  if (!args.columns.empty() && (single || args.format != "table")) {
    fmt::print(
        stderr, "{}: error: --columns chooses the sweep table's columns: {}\n", m.file,
        single ? "--at prints every channel of its pose" : "json and csv hold every channel");
    return kExitBadInput;
  }
  std::vector<std::string> columns;  // checked before any work
  if (!single && args.format == "table") {
    Trajectory names;
    names.resize(m, 0, true);
    columns = table_channels(m, names, args.columns);
  }
  // Several drivers: the sweep's parameter is time, and --at is a time [s].
  const bool timed = m.axis().timed();
  const double at = single ? *args.at * axis_unit_of(m).scale : 0;
  const methods::Solution solution =
      methods::solve(m, {.method = args.method,
                         .at = single ? std::optional<double>(at) : std::nullopt,
                         .sweep = options,
                         .limits = args.limits});
  const Trajectory& t = solution.trajectory;
  const std::vector<DerivedValue>& derived = solution.derived;
  const std::string& why = solution.method;
  fmt::print(stderr, "{}: method: {}\n", m.file, why);
  for (const Trajectory::Event& e : t.events)
    fmt::print(stderr, "{}: note: {} at {}: {}\n", m.file, to_string(e.kind),
               sweep_position_text(m, e.driver), e.message);  // the file's units
  if (args.format == "json")
    print_trajectory_json(
        stdout, m, t, single ? std::optional<int>(0) : std::nullopt, timed ? "time" : "driver", {},
        derived.empty() ? nlohmann::json()
                        : nlohmann::json{{"derived", compare::derived_json(derived)}});
  else if (args.format == "csv")
    print_csv(t);
  else if (single) {
    print_table_at(m, t, 0);
    if (args.ic && usable(t.status[0])) print_instant_centres(m, t);
  } else {
    print_table_rows(m, t, timed, 4, columns, "the file's units");
    compare::print_derived_exact(stdout, m, derived);
  }
  if (!args.svg.empty()) {
    // At --at, or at the sweep's start: its first sample with a position.
    int row = 0;
    while (row + 1 < t.samples() && !has_position(t.status[static_cast<size_t>(row)])) ++row;
    try {
      write_file(args.svg, compare::drawing_svg(m, t, row, args.animate));
    } catch (const std::invalid_argument& e) {
      fmt::print(stderr, "{}: error: --svg: {}\n", m.file, e.what());
      return kExitBadInput;
    }
    fmt::print(stderr, "{}: drawing: {}\n", m.file, args.svg);
  }
  if (single && !usable(t.status[0])) {
    fmt::print(stderr, "{}\n",
               Diagnostic{start_where(m), fmt::format("{} at {}", to_string(t.status[0]),
                                                      sweep_position_text(m, at, 6))}
                   .str());
    return kExitBadInput;
  }
  return kExitOk;
}

}  // namespace crosslink::app
