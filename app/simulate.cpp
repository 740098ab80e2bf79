// `crosslink simulate FILE [--duration T] [--at T] [--format table|json|csv]`: the exact forward
// dynamics of a dynamics case (analytic/physics/dynamics.h), with its energy balance. The JSON of
// one time has the schema of `solve --at` plus `energy`; the table is in the file's units.
#include <fmt/format.h>

#include <cmath>

#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "app/commands.h"
#include "app/output.h"

namespace crosslink::app {
namespace {

// The energy balance at sample k [J]: null where the sample holds no motion.
nlohmann::json energy_json(const Simulation& s, int k) {
  if (!usable(s.trajectory.status[static_cast<size_t>(k)])) return nullptr;
  const double balance = s.energy_balance(k);
  return {{"kinetic", s.kinetic(k)}, {"potential", s.potential(k)},
          {"work", s.work(k)},       {"initial", s.initial_energy},
          {"balance", balance},      {"balance_relative", s.energy_error(k)}};
}

// The energy balance at every sample [J]; not a number where the sample holds no motion.
Eigen::VectorXd energy_balances(const Simulation& s) {
  Eigen::VectorXd balance(s.trajectory.samples());
  for (int k = 0; k < balance.size(); ++k)
    balance(k) = usable(s.trajectory.status[static_cast<size_t>(k)]) ? s.energy_balance(k) : NAN;
  return balance;
}

}  // namespace

int run_simulate(const SimulateArgs& args) {
  const Mechanism m = load_mechanism(args.path);
  if (!m.dynamics) {
    fmt::print(stderr,
               "{}: error: not a dynamics case: simulate needs a [dynamics] table "
               "(docs/dynamics.md); `crosslink solve` gives a prescribed motion\n",
               m.file);
    return kExitBadInput;
  }
  const DynamicsCase& c = *m.dynamics;
  SimulationOptions options{.integrator = args.integrator, .tolerance = args.tolerance};
  std::optional<int> single;
  if (args.at) {
    // Two samples, 0 and T, the integrator landing on T (a time of 0 is the first of the case's).
    options.duration = *args.at > 0.0 ? *args.at : c.interval;
    options.interval = options.duration;
    single = *args.at > 0.0 ? 1 : 0;
  } else if (args.duration) {
    options.duration = *args.duration;
  }
  check_simulation_work(m, options, args.at ? "--at" : "--duration", args.limits);
  options.max_solves = args.limits.max_solves;

  const Simulation s = simulate(m, options);
  const Trajectory& t = s.trajectory;
  double worst = 0.0;
  for (int k = 0; k < t.samples(); ++k)
    if (usable(t.status[static_cast<size_t>(k)])) worst = std::max(worst, s.energy_error(k));
  fmt::print(stderr,
             "{}: method: {}, tolerance {:g}; {} evaluations; energy balance within {:.2e} of "
             "the largest energy\n",
             m.file, t.method, options.tolerance, s.evaluations, worst);
  for (const Trajectory::Event& e : t.events)
    fmt::print(stderr, "{}: note: {} at t = {:.10g} s: {}\n", m.file, to_string(e.kind), e.driver,
               e.message);

  if (args.format == "json") {
    const auto energy = [&s](nlohmann::json& j, int k) { j["energy"] = energy_json(s, k); };
    print_trajectory_json(stdout, m, t, single, "time", energy);
  } else if (args.format == "csv") {
    Eigen::VectorXd balance = energy_balances(s);
    Columns energy = {{"energy.kinetic", s.kinetic},
                      {"energy.potential", s.potential},
                      {"energy.work", s.work},
                      {"energy.balance", balance}};
    for (auto& [name, column] : energy)
      for (int k = 0; k < t.samples(); ++k)
        if (!usable(t.status[static_cast<size_t>(k)])) column(k) = NAN;  // an empty field
    print_csv(t, energy);
  } else if (single) {
    print_table_at(m, t, *single);
    if (const nlohmann::json e = energy_json(s, *single); !e.is_null())
      fmt::print(
          "\nenergy [J]: kinetic {:.10g}, potential {:.10g}, work done {:.10g}, initial {:.10g}; "
          "balance {:.3e}\n",
          e["kinetic"].get<double>(), e["potential"].get<double>(), e["work"].get<double>(),
          s.initial_energy, e["balance"].get<double>());
  } else {
    print_table_rows(m, t, true, 6, table_channels(m, t, "angle,omega"), "energy balance in J",
                     {{"balance", energy_balances(s)}});
  }
  // Stopped by its work limit: the samples it reached are written, the error says where it
  // stopped and how to raise the limit.
  if (s.over_budget) {
    fmt::print(stderr, "{}\n", Diagnostic{c.where, s.message}.str());
    return kExitBadInput;
  }
  if (single && !usable(t.status[static_cast<size_t>(*single)])) {
    fmt::print(stderr, "{}\n",
               Diagnostic{c.where, fmt::format("{} at t = {} s: {}",
                                               to_string(t.status[static_cast<size_t>(*single)]),
                                               *args.at, s.message)}
                   .str());
    return kExitBadInput;
  }
  return kExitOk;
}

}  // namespace crosslink::app
