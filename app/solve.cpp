// `crosslink solve FILE [--at VALUE] [--format table|json|csv]`: exact kinematics at one driver
// value or over the whole sweep. The table is in the file's units; JSON and CSV are SI.
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "analytic/dyads.h"
#include "analytic/instant_centres.h"
#include "analytic/loader.h"
#include "analytic/sweep.h"
#include "app/commands.h"

namespace crosslink::app {
namespace {

struct SolveArgs {
  std::string path;
  std::optional<double> at;
  std::string format = "table";
  double step = 0.0;
  std::string method = "auto";    // dyads | newton | auto (dyads when the chain decomposes)
  bool ic = false;                // print the instantaneous centres (with --at)
  std::string at_limit = "stop";  // at a limit of the assembling range: stop | reverse
  WorkLimits limits;
};

// The forces of a usable sample in the documented schema (docs/json.md); null otherwise.
nlohmann::json forces_json(const Mechanism& m, const Trajectory& t, int row) {
  if (!t.has_forces || !usable(t.status[static_cast<size_t>(row)])) return nullptr;
  nlohmann::json f;
  f["driver"] = t.effort(row);
  f["joints"] = nlohmann::json::object();
  size_t slide = 0;
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const auto c = static_cast<Eigen::Index>(j);
    nlohmann::json joint = {{"fx", t.fx(row, c)}, {"fy", t.fy(row, c)}};
    if (m.joints[j].is_slide()) {
      const auto s = static_cast<Eigen::Index>(slide++);
      joint["fn"] = t.fn(row, s);
      if (m.joints[j].type == JointType::prismatic) joint["moment"] = t.moment(row, s);
    }
    f["joints"][m.joints[j].name] = joint;
  }
  f["shaking"] = {
      {"fx", t.shaking(row, 0)}, {"fy", t.shaking(row, 1)}, {"moment", t.shaking(row, 2)}};
  return f;
}

nlohmann::json sample_json(const Mechanism& m, const Trajectory& t, int row) {
  nlohmann::json j;
  j["time"] = t.time(row);
  j["driver"] = t.driver(row);
  j["status"] = std::string(to_string(t.status[static_cast<size_t>(row)]));
  j["links"] = nlohmann::json::object();
  for (size_t l = 0; l < t.link_names.size(); ++l) {
    const auto c = static_cast<Eigen::Index>(l);
    j["links"][t.link_names[l]] = {
        {"angle", t.angle(row, c)}, {"omega", t.omega(row, c)}, {"alpha", t.alpha(row, c)}};
  }
  j["points"] = nlohmann::json::object();
  for (size_t p = 0; p < t.point_names.size(); ++p) {
    const auto c = static_cast<Eigen::Index>(p);
    j["points"][t.point_names[p]] = {{"x", t.x(row, c)},   {"y", t.y(row, c)},
                                     {"vx", t.vx(row, c)}, {"vy", t.vy(row, c)},
                                     {"ax", t.ax(row, c)}, {"ay", t.ay(row, c)}};
  }
  j["sliders"] = nlohmann::json::object();
  for (size_t s = 0; s < t.slider_names.size(); ++s) {
    const auto c = static_cast<Eigen::Index>(s);
    j["sliders"][t.slider_names[s]] = {
        {"s", t.s(row, c)}, {"sdot", t.sdot(row, c)}, {"sddot", t.sddot(row, c)}};
  }
  j["forces"] = forces_json(m, t, row);
  return j;
}

nlohmann::json events_json(const Trajectory& t) {
  nlohmann::json events = nlohmann::json::array();
  for (const Trajectory::Event& e : t.events)
    events.push_back(
        {{"driver", e.driver}, {"kind", std::string(to_string(e.kind))}, {"message", e.message}});
  return events;
}

void print_json(const Mechanism& m, const Trajectory& t, bool single) {
  nlohmann::json j;
  j["mechanism"] = m.name;
  j["file"] = m.file;
  j["units"] = "SI";
  j["method"] = t.method;
  if (single) {
    j.update(sample_json(m, t, 0));
  } else {
    j["status"] = std::string(to_string(
        std::all_of(t.status.begin(), t.status.end(), [](PoseStatus s) { return usable(s); })
            ? PoseStatus::ok
            : *std::find_if(t.status.begin(), t.status.end(),
                            [](PoseStatus s) { return !usable(s); })));
    j["samples"] = nlohmann::json::array();
    for (int r = 0; r < t.samples(); ++r) j["samples"].push_back(sample_json(m, t, r));
  }
  j["events"] = events_json(t);
  fmt::print("{}\n", j.dump(2));
}

void print_csv(const Trajectory& t) {
  const std::vector<std::string> channels = t.channel_names();
  fmt::print("sample,time,driver,status");
  for (const std::string& c : channels) fmt::print(",{}", c);
  fmt::print("\n");
  std::vector<Eigen::VectorXd> columns;
  for (const std::string& c : channels) columns.push_back(*t.channel(c));
  for (int r = 0; r < t.samples(); ++r) {
    fmt::print("{},{:.17g},{:.17g},{}", r, t.time(r), t.driver(r),
               to_string(t.status[static_cast<size_t>(r)]));
    for (const Eigen::VectorXd& col : columns) fmt::print(",{:.17g}", col(r));
    fmt::print("\n");
  }
}

// Notes-style tables at one sample, in the file's units.
void print_table_at(const Mechanism& m, const Trajectory& t, int row) {
  const double L = m.units.length, A = m.units.angle;
  const std::string& ln = m.units.length_name;
  const std::string& an = m.units.angle_name;
  const double driver_unit = m.driver.angular() ? A : L;
  fmt::print("{}  driver = {:.4f} {}  t = {:.6g} s  status: {}\n", m.name,
             t.driver(row) / driver_unit, m.driver.angular() ? an : ln, t.time(row),
             to_string(t.status[static_cast<size_t>(row)]));
  fmt::print("\n{:<14} {:>12} {:>14} {:>16}\n", "link", fmt::format("angle [{}]", an),
             "omega [rad/s]", "alpha [rad/s^2]");
  for (size_t l = 0; l < t.link_names.size(); ++l) {
    const auto c = static_cast<Eigen::Index>(l);
    fmt::print("{:<14} {:>12.4f} {:>14.4f} {:>16.3f}\n", t.link_names[l], t.angle(row, c) / A,
               t.omega(row, c), t.alpha(row, c));
  }
  fmt::print("\n{:<8} {:>10} {:>10} {:>11} {:>11} {:>11} {:>12} {:>12} {:>12}\n", "point",
             fmt::format("x [{}]", ln), fmt::format("y [{}]", ln), "vx", "vy", "|v|", "ax", "ay",
             "|a|");
  for (size_t p = 0; p < t.point_names.size(); ++p) {
    const auto c = static_cast<Eigen::Index>(p);
    const double vx = t.vx(row, c) / L, vy = t.vy(row, c) / L;
    const double ax = t.ax(row, c) / L, ay = t.ay(row, c) / L;
    fmt::print(
        "{:<8} {:>10.4f} {:>10.4f} {:>11.3f} {:>11.3f} {:>11.3f} {:>12.2f} {:>12.2f} "
        "{:>12.2f}\n",
        t.point_names[p], t.x(row, c) / L, t.y(row, c) / L, vx, vy, std::hypot(vx, vy), ax, ay,
        std::hypot(ax, ay));
  }
  fmt::print("(velocities in {0}/s, accelerations in {0}/s^2)\n", ln);
  if (!t.slider_names.empty()) {
    fmt::print("\n{:<20} {:>12} {:>14} {:>16}\n", "slider", fmt::format("s [{}]", ln),
               fmt::format("sdot [{}/s]", ln), fmt::format("sddot [{}/s^2]", ln));
    for (size_t s = 0; s < t.slider_names.size(); ++s) {
      const auto c = static_cast<Eigen::Index>(s);
      fmt::print("{:<20} {:>12.4f} {:>14.3f} {:>16.2f}\n", t.slider_names[s], t.s(row, c) / L,
                 t.sdot(row, c) / L, t.sddot(row, c) / L);
    }
  }
}

// A sweep as one row per sample: driver, status, then each link's angle and omega.
void print_table_sweep(const Mechanism& m, const Trajectory& t) {
  const double A = m.units.angle;
  const double driver_unit = m.driver.angular() ? A : m.units.length;
  std::string header = fmt::format("{:>10} {:>8}", "driver", "status");
  for (const std::string& l : t.link_names)
    header += fmt::format(" {:>12} {:>12}", "angle." + l, "omega." + l);
  fmt::print("{}  (angles in {}, omega in rad/s)\n{}\n", m.name, m.units.angle_name, header);
  for (int r = 0; r < t.samples(); ++r) {
    std::string line = fmt::format("{:>10.4f} {:>8}", t.driver(r) / driver_unit,
                                   to_string(t.status[static_cast<size_t>(r)]));
    for (Eigen::Index c = 0; c < t.angle.cols(); ++c)
      line += fmt::format(" {:>12.4f} {:>12.4f}", t.angle(r, c) / A, t.omega(r, c));
    fmt::print("{}\n", line);
  }
}

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
        c.at_infinity()
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

int run_solve(const SolveArgs& args) {
  const Mechanism m = load_mechanism(args.path);
  SweepOptions options;
  if (args.step != 0.0)  // 0: the default; a negative or non-finite step is refused below
    options.step = args.step * (m.driver.angular() ? m.units.angle : m.units.length);
  const bool reverse = args.at_limit == "reverse";
  if (reverse) options.at_limit = SweepOptions::AtLimit::reverse;
  const bool single = args.at.has_value();
  if (args.ic && !single) {
    fmt::print(stderr, "{}: error: --ic needs --at VALUE (centres of one pose)\n", m.file);
    return kExitBadInput;
  }
  const double at = single ? *args.at * (m.driver.angular() ? m.units.angle : m.units.length) : 0;
  if (single)
    check_solve_at_work(m, at, options, args.limits);
  else
    check_sweep_work(m, options, args.limits);
  Trajectory t = single ? solve_at(m, at, options) : sweep(m, options);
  // Closed-form dyads at the same driver values, when asked for (or, for auto, when possible).
  // Reversing at a toggle revisits driver values on the other assembly mode: the traced Newton
  // sweep follows that; auto keeps it.
  const Decomposition decomposition = args.method == "newton" || (reverse && args.method == "auto")
                                          ? Decomposition{}
                                          : decompose(m);
  if (args.method == "dyads" && !decomposition.complete) {
    fmt::print(stderr, "{}: error: --method dyads: the chain {}\n", m.file,
               "does not decompose into dyads: " + decomposition.reason);
    return kExitBadInput;
  }
  std::string why = "newton (asked for)";
  if (decomposition.complete) {
    t = dyad_sweep(m, t, true);
    why = "dyads (closed form, " + std::to_string(decomposition.groups.size()) + " groups)";
  } else if (args.method == "auto" && reverse) {
    why = "newton (--at-limit reverse: the traced sweep follows the loop through its toggles)";
  } else if (args.method == "auto") {
    why = "newton (the chain does not decompose into dyads: " + decomposition.reason + ")";
  }
  t.flag_non_finite();  // the dyads' samples (Newton's are flagged as they are written)
  fmt::print(stderr, "{}: method: {}\n", m.file, why);
  for (const Trajectory::Event& e : t.events)
    fmt::print(stderr, "{}: note: {} at driver = {:.10g}: {}\n", m.file, to_string(e.kind),
               e.driver, e.message);
  if (args.format == "json")
    print_json(m, t, single);
  else if (args.format == "csv")
    print_csv(t);
  else if (single) {
    print_table_at(m, t, 0);
    if (args.ic && usable(t.status[0])) print_instant_centres(m, t);
  } else
    print_table_sweep(m, t);
  if (single && !usable(t.status[0])) {
    fmt::print(stderr, "{}\n",
               Diagnostic{m.driver.where,
                          fmt::format("{} at driver = {}", to_string(t.status[0]), *args.at)}
                   .str());
    return kExitBadInput;
  }
  return kExitOk;
}

}  // namespace

void add_solve(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand("solve", "Exact kinematics at one driver value or over a sweep");
  auto args = std::make_shared<SolveArgs>();
  cmd->add_option("FILE", args->path, "mechanism definition (.toml)")->required();
  cmd->add_option("--at", args->at, "driver value, in the file's units (default: whole sweep)");
  cmd->add_option("--step", args->step, "sweep step in the file's units (default 1 degree)");
  cmd->add_option("--format", args->format, "output format")
      ->check(CLI::IsMember({"table", "json", "csv"}));
  cmd->add_option("--method", args->method,
                  "dyads (closed form), newton, or auto (dyads when the chain decomposes)")
      ->check(CLI::IsMember({"dyads", "newton", "auto"}));
  cmd->add_option("--at-limit", args->at_limit,
                  "at a limit of the assembling range (a toggle): stop, or reverse the driver "
                  "as a real rocker would and follow the loop back on the other assembly mode")
      ->check(CLI::IsMember({"stop", "reverse"}));
  cmd->add_flag("--ic", args->ic,
                "with --at: instantaneous centres (Kennedy–Aronhold) and their velocities");
  add_max_samples(*cmd, args->limits);
  cmd->callback([&run, args] { run = [args] { return run_solve(*args); }; });
}

}  // namespace crosslink::app
