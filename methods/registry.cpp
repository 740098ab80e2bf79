#include "methods/registry.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/units_text.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/trust.h"
#include "methods/engines.h"
#include "sim/sampling.h"

namespace crosslink::methods {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

MethodRun not_available(std::string_view name, std::string description, std::string why) {
  MethodRun run;
  run.name = std::string(name);
  run.description = std::move(description);
  run.message = std::move(why);
  return run;
}

// Runs an engine through the sim::Engine interface.
MethodRun run_engine(const sim::Engine& engine, std::string description, const Mechanism& mechanism,
                     const MethodRun& reference, const sim::Settings& settings) {
  MethodRun run;
  run.name = engine.name();
  run.description = std::move(description);
  std::string why;
  // Every engine drives each driver's coordinate and needs no other freedom driven (the loader
  // refuses a file whose count differs; a mechanism built in code is held here).
  if (mobility(mechanism).mobility != static_cast<int>(mechanism.drivers.size()))
    why = fmt::format("the chain's mobility is not {}", mechanism.drivers.size());
  if (!why.empty() || !engine.supports(mechanism, &why)) {
    run.message = "cannot realise this mechanism: " + why;
    return run;
  }
  run.available = true;
  sim::EngineRun result = engine.run(mechanism, reference.trajectory, settings);
  run.ok = result.ok;
  run.message = result.message;
  run.trajectory = std::move(result.trajectory);
  run.settings = std::move(result.settings);
  run.cost = result.cost;
  if (run.ok && run.trajectory.samples() != reference.trajectory.samples()) {
    run.ok = false;
    run.message = fmt::format("returned {} samples for the reference's {}",
                              run.trajectory.samples(), reference.trajectory.samples());
  }
  return run;
}

// The engine of that name, or null for a method that is not an engine.
std::unique_ptr<sim::Engine> make_engine(std::string_view name) {
  const EngineEntry* entry = find_engine(name);
  return entry ? entry->make() : nullptr;
}

// Every method's name: the exact methods, then the engine table's.
std::vector<std::string> all_method_names() {
  std::vector<std::string> names = {"analytic", "dyads", "ic"};
  for (const EngineEntry& e : engine_table()) names.push_back(e.name);
  return names;
}

}  // namespace

void check_engine_settings(std::string_view name, const Mechanism& mechanism,
                           const sim::Settings& engine_settings) {
  if (const auto engine = make_engine(name)) engine->check_settings(mechanism, engine_settings);
}

const std::vector<std::string>& method_names() {
  static const std::vector<std::string> names = all_method_names();
  return names;
}

compare::LineStyle method_style(std::string_view name) {
  if (const EngineEntry* engine = find_engine(name)) return engine->style;
  if (name == "analytic") return {"#222222", {}};
  if (name == "dyads") return {"#2ca02c", {8, 3}};
  if (name == "ic") return {"#9467bd", {2, 2}};
  return {"#8c564b", {1, 1}};
}

std::map<std::string, compare::LineStyle> method_styles() {
  std::map<std::string, compare::LineStyle> out;
  for (const std::string& name : method_names()) out[name] = method_style(name);
  return out;
}

bool is_method(std::string_view name) {
  return std::find(method_names().begin(), method_names().end(), name) != method_names().end();
}

namespace {

// A dynamics case's reference: the exact simulation (analytic/physics/dynamics.h), with its energy
// balance as the energy channels; each sample keeps its pose's conditioning (rcond), so the
// trust rules (analytic/reference/trust.h) apply as in a kinematic comparison.
MethodRun simulation_run(const Mechanism& mechanism, const SimulationOptions& options) {
  MethodRun run;
  run.name = "analytic";
  run.description = fmt::format(
      "exact forward dynamics: the minimal-coordinate equation of motion, Boost.Odeint {} at "
      "tolerance {:g}{}",
      options.integrator, options.tolerance,
      options.tolerance == SimulationOptions{}.tolerance ? " (the reference)" : "");
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = sim::thread_cpu_seconds();
  const Simulation sim = simulate(mechanism, options);
  // A reference cut short by its work limit leaves nothing to judge past it: asked too much.
  if (sim.over_budget) throw DefinitionError({Diagnostic{mechanism.dynamics->where, sim.message}});
  run.cost.wall_seconds = seconds_since(start);
  const double cpu = sim::thread_cpu_seconds() - cpu_start;
  run.trajectory = sim.trajectory;
  Trajectory& t = run.trajectory;
  t.add_energy();
  double worst_balance = 0.0;
  for (int k = 0; k < t.samples(); ++k) {
    const double error = sim.kinetic(k) + sim.potential(k) - sim.work(k) - sim.initial_energy;
    t.energy.row(k) << sim.kinetic(k), sim.potential(k), sim.work(k), error;
    if (usable(t.status[static_cast<size_t>(k)]))
      worst_balance = std::max(worst_balance, sim.energy_error(k));
  }
  t.flag_non_finite();
  run.cost.steps = sim.evaluations;
  run.cost.simulated_seconds = t.samples() > 0 ? t.time(t.samples() - 1) - t.time(0) : 0.0;
  run.cost.wall_seconds_per_cycle =
      run.cost.simulated_seconds > 0.0 ? run.cost.wall_seconds / run.cost.simulated_seconds : 0.0;
  run.cost.cpu_seconds_per_cycle =
      run.cost.simulated_seconds > 0.0 ? cpu / run.cost.simulated_seconds : 0.0;
  run.available = true;
  run.ok = true;  // a simulation stopped early flags its remaining samples
  run.message = sim.message;
  run.settings = {{"integrator", options.integrator},
                  {"tolerance", fmt::format("{:g}", options.tolerance)},
                  {"duration", fmt::format("{:g} s", mechanism.dynamics->duration)},
                  {"interval", fmt::format("{:g} s", mechanism.dynamics->interval)},
                  {"samples", fmt::format("{}", t.samples())},
                  {"evaluations", fmt::format("{}", sim.evaluations)},
                  {"energy_balance", fmt::format("{:.2g} (worst, relative)", worst_balance)},
                  {"typical_rcond", fmt::format("{:.3g}", typical_rcond(t))}};
  return run;
}

}  // namespace

MethodRun run_simulation(const Mechanism& mechanism, const SimulationOptions& options) {
  return simulation_run(mechanism, options);
}

MethodRun run_reference(const Mechanism& mechanism, const SweepOptions& options) {
  if (mechanism.dynamics) return simulation_run(mechanism, SimulationOptions{});
  MethodRun run;
  run.name = "analytic";
  run.description = "Newton-Raphson on the full constraint equations (the reference)";
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = sim::thread_cpu_seconds();
  run.trajectory = sweep(mechanism, options);
  run.trajectory.flag_non_finite();
  // The reference checks itself where a second exact method can solve the chain.
  const Decomposition decomposition = decompose(mechanism);
  std::string check_text = "none: the chain does not decompose into dyads";
  std::string check_seconds;  // its cost, a setting apart: it says it measures time
  if (decomposition.complete) {
    const double check_start = sim::thread_cpu_seconds();
    const CrossCheck check =
        cross_check(mechanism, run.trajectory, dyad_sweep(mechanism, run.trajectory));
    check_text = fmt::format(
        "dyads on {} samples: agree to {:.2g} of scale (limit {:g}), {} disagree (flagged), {} "
        "singular by the dyads (flagged)",
        check.compared, check.worst, kExactAgreement, check.disagree, check.singular);
    check_seconds = fmt::format("{:.3g}", sim::thread_cpu_seconds() - check_start);
  }
  run.cost.wall_seconds = seconds_since(start);
  run.cost.steps = run.trajectory.samples();
  run.cost.wall_seconds_per_cycle = run.cost.wall_seconds;
  run.cost.cpu_seconds_per_cycle = sim::thread_cpu_seconds() - cpu_start;
  run.available = true;
  run.ok = true;
  const double step = options.step > 0.0 ? options.step : 0.0;
  // In the file's units, as --step takes it (it was the SI value, 0.0349066 for --step 2 deg).
  const std::string step_text =
      mechanism.axis().timed() ? std::string("1/360 of the cycle in time")
      : step > 0.0             ? driver_unit_of(mechanism).text(step, 6)
      : mechanism.swept().angular()
          ? driver_unit_of(mechanism).text(std::numbers::pi / 180.0, 6) + " (default)"
          : std::string("from the range (default)");
  run.settings = {{"newton.tolerance", fmt::format("{:g}", options.newton.tolerance)},
                  {"newton.max_iterations", fmt::format("{}", options.newton.max_iterations)},
                  {"newton.singular_rcond", fmt::format("{:g}", options.newton.singular_rcond)},
                  {"step", step_text},
                  {"samples", fmt::format("{}", run.trajectory.samples())},
                  {"cross_check", check_text},
                  {"typical_rcond", fmt::format("{:.3g}", typical_rcond(run.trajectory))}};
  if (!check_seconds.empty()) run.settings.push_back({"cross_check_cpu_seconds", check_seconds});
  return run;
}

MethodRun run_method(std::string_view name, const Mechanism& mechanism, const MethodRun& reference,
                     const sim::Settings& engine_settings) {
  if (name == "analytic") return reference;
  if (mechanism.dynamics && (name == "dyads" || name == "ic"))
    return not_available(name,
                         name == "dyads" ? "closed-form Assur groups (dyads) solved in sequence"
                                         : "instantaneous centres (Kennedy-Aronhold): velocities",
                         "a kinematic method (it follows a motion law): a dynamics case compares "
                         "the engines with the exact simulation");
  if (name == "dyads") {
    const std::string description = "closed-form Assur groups (dyads) solved in sequence";
    const Decomposition decomposition = decompose(mechanism);
    if (!decomposition.complete)
      return not_available(name, description,
                           "does not decompose into dyads: " + decomposition.reason);
    MethodRun run;
    run.name = "dyads";
    run.description = description;
    // Its forces are the multipliers at its poses (as the reference's): no independent check.
    run.kinds = {"angle", "omega", "alpha", "x", "y",    "vx",    "vy", "v",
                 "ax",    "ay",    "a",     "s", "sdot", "sddot", "mu"};
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = sim::thread_cpu_seconds();
    run.trajectory = dyad_sweep(mechanism, reference.trajectory);
    run.trajectory.flag_non_finite();
    run.cost.wall_seconds = seconds_since(start);
    run.cost.wall_seconds_per_cycle = run.cost.wall_seconds;
    run.cost.cpu_seconds_per_cycle = sim::thread_cpu_seconds() - cpu_start;
    run.cost.steps = run.trajectory.samples();
    run.available = true;
    run.ok = run.trajectory.samples() == reference.trajectory.samples();
    if (!run.ok) run.message = "returned a different number of samples than the reference";
    std::string groups;
    for (const AssurGroup& g : decomposition.groups)
      groups += (groups.empty() ? "" : "; ") + g.name;
    run.settings = {{"groups", groups}, {"singular_sine", "1e-7"}};
    return run;
  }
  if (name == "ic") {
    const std::string description = "instantaneous centres (Kennedy-Aronhold): velocities";
    // Velocities from the centres of every exact pose; positions are the reference's.
    MethodRun run;
    run.name = "ic";
    run.description = description;
    run.kinds = {"omega", "vx", "vy", "v"};
    run.available = run.ok = true;
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = sim::thread_cpu_seconds();
    const Trajectory& exact = reference.trajectory;
    run.trajectory = exact;
    run.trajectory.method = "ic";
    int incomplete = 0, not_geometric = 0;
    for (int k = 0; k < exact.samples(); ++k) {
      const auto ks = static_cast<size_t>(k);
      if (!usable(exact.status[ks])) continue;
      const CentreVelocities v =
          centre_velocities(mechanism, instant_centres(mechanism, exact, k), exact, k);
      if (!v.complete) {
        run.trajectory.status[ks] = PoseStatus::singular;
        ++incomplete;
        continue;
      }
      for (size_t l = 0; l < v.omega.size(); ++l)
        run.trajectory.omega(k, static_cast<Eigen::Index>(l)) = v.omega[l];
      for (size_t p = 0; p < v.point.size(); ++p) {
        run.trajectory.vx(k, static_cast<Eigen::Index>(p)) = v.point[p].x();
        run.trajectory.vy(k, static_cast<Eigen::Index>(p)) = v.point[p].y();
      }
      if (std::find(v.from_geometry.begin(), v.from_geometry.end(), false) != v.from_geometry.end())
        ++not_geometric;
    }
    run.trajectory.flag_non_finite();
    run.cost.wall_seconds = seconds_since(start);
    run.cost.wall_seconds_per_cycle = run.cost.wall_seconds;
    run.cost.cpu_seconds_per_cycle = sim::thread_cpu_seconds() - cpu_start;
    run.cost.steps = exact.samples();
    if (incomplete)
      run.message += fmt::format(
          "{} samples where the centres do not give every velocity "
          "(flagged, kept out of verdicts). ",
          incomplete);
    if (not_geometric)
      run.message += fmt::format(
          "{} samples use a centre placed from the exact velocities "
          "(Kennedy alone cannot place it): not an independent check "
          "there.",
          not_geometric);
    run.settings = {{"positions", "from the reference sweep"},
                    {"centres", "primary + Kennedy-Aronhold, else from exact velocities"}};
    return run;
  }
  if (const EngineEntry* entry = find_engine(name))
    return run_engine(*entry->make(), entry->description, mechanism, reference, engine_settings);
  throw std::invalid_argument(
      fmt::format("unknown method '{}' (valid: {})", name, fmt::join(method_names(), ", ")));
}

compare::ExactValues exact_values(const Mechanism& m, const MethodRun& reference) {
  compare::ExactValues exact;
  exact.derived = derived_exact(m, reference.trajectory);
  for (const Reference& r : m.references) {
    std::optional<double> value;
    if (!r.derived) {
      const Trajectory t = solve_at(m, r.driver_value);
      if (t.samples() > 0 && usable(t.status[0]))
        if (const auto v = t.channel(r.quantity)) value = (*v)(0);
    }
    exact.references.push_back(value);
  }
  return exact;
}

compare::Comparison compare_runs(const Mechanism& m, std::vector<MethodRun> runs,
                                 const compare::Tolerances& tolerances) {
  const compare::ExactValues exact = exact_values(m, runs.front());
  return compare::compare_methods(m, std::move(runs), tolerances, exact);
}

compare::Drawing drawing(const Mechanism& m, std::optional<double> at) {
  compare::Drawing out;
  out.at = at.value_or(m.axis().timed() ? 0.0 : m.swept().start);
  out.asked = at.has_value();
  out.pose = solve_at(m, out.at);
  if (usable(out.pose.status.at(0))) out.centres = instant_centres(m, out.pose, 0);
  return out;
}

}  // namespace crosslink::methods
