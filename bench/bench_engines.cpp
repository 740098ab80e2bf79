// The four engines at equal accuracy, in one run: each engine at its cheapest setting meeting the
// same accuracy on the same case, its cost per simulated second (docs/engines-measured.md, "Cost at
// equal accuracy"). The case is the driven crank-rocker four-bar under its own loads (a 0.04, b
// 0.12, c 0.08, d 0.10 m, 240 rpm: 0.25 s of simulated time per run, sampled every degree); the
// accuracy 0.1 % of peak on every quantity class the sweep measures (position, velocity,
// acceleration, the forces an engine reads). The settings are the picks of
//
//   crosslink sweep mechanisms/fourbar_crank_rocker.toml --engines mujoco,bullet,ode,simbody
//       --dt 6.944444e-4,3.472222e-4,2.314815e-4,1.736111e-4,1.157407e-4 --accuracy 0.1
//
// (the coarsest time step where a variant meets it, the least work there). Before timing, each
// benchmark measures its setting's errors through the sweep (evaluate_setting, the comparator's
// metrics) and fails if they do not meet the accuracy, so a change in an engine cannot leave the
// bench timing a setting that no longer meets it.
//
//   Engines/<engine>   one run of the case at the setting (scene build, steps, sampling, forces);
//                      counters: s_per_sim_s (wall time of the benchmark per simulated second),
//                      cpu_s_per_sim_s (the run's own stepping CPU time per simulated second,
//                      RunCost), dt_s, worst_pct (the largest class error, % of peak)
//
// Run from the source root:
//   build/bench/bench_engines --benchmark_min_time=2
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "analytic/model/loader.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"

namespace crosslink {
namespace {

constexpr double kAccuracyPct = 0.1;

// One engine's pick: its variant (the sweep's name) and time step, 1 degree of crank / n.
struct Pick {
  const char* engine;
  const char* variant;
  int per_degree;
};

const Mechanism& crank_rocker() {
  static const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  return m;
}

methods::ReferenceLadder& ladder() {
  static methods::ReferenceLadder l(crank_rocker(), SweepOptions{});
  return l;
}

void engine_at_accuracy(benchmark::State& state, const Pick& pick) {
  const double dt = ladder().interval() / pick.per_degree;
  methods::GridPoint point{pick.engine, pick.variant, dt, {}};
  bool found = false;
  for (const methods::Variant& v : methods::engine_variants(pick.engine))
    if (v.name == pick.variant) point.settings = v.settings(dt), found = true;
  if (!found) {
    state.SkipWithError(fmt::format("{}: no variant '{}'", pick.engine, pick.variant).c_str());
    return;
  }
  const methods::SweepRow row = methods::evaluate_setting(crank_rocker(), ladder(), point);
  double worst = 0.0;
  for (double e : row.max_pct)
    if (std::isfinite(e)) worst = std::max(worst, e);
  if (!row.meets(kAccuracyPct)) {
    state.SkipWithError(fmt::format("{} at dt {:.4g} s no longer meets {} %: worst {:.3g} %",
                                    pick.engine, row.dt, kAccuracyPct, worst)
                            .c_str());
    return;
  }
  const compare::MethodRun& reference = ladder().base();
  double cpu = 0.0;
  for (auto _ : state) {
    const compare::MethodRun run =
        methods::run_method(pick.engine, crank_rocker(), reference, row.overrides);
    if (!run.ok) {
      state.SkipWithError((std::string(pick.engine) + ": " + run.message).c_str());
      return;
    }
    cpu += run.cost.cpu_seconds_per_cycle;
    benchmark::DoNotOptimize(run.trajectory.alpha.data());
  }
  const double cycle = crank_rocker().cycle_period();  // simulated seconds per run
  state.counters["s_per_sim_s"] = benchmark::Counter(
      cycle, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["cpu_s_per_sim_s"] = cpu / static_cast<double>(state.iterations()) / cycle;
  state.counters["dt_s"] = row.dt;
  state.counters["worst_pct"] = worst;
}

// The sweep's picks at 0.1 % (docs/engines-measured.md, "Cost at equal accuracy").
const Pick kMujoco{"mujoco", "Euler/Newton", 2};
const Pick kBullet{"bullet", "rigid/MLCP Dantzig erp 1", 2};
const Pick kOde{"ode", "dWorldStep erp 1 cfm 1e-10", 2};
const Pick kSimbody{"simbody", "Merson interpolated reports", 1};

BENCHMARK_CAPTURE(engine_at_accuracy, mujoco, kMujoco)
    ->Name("Engines/mujoco")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(engine_at_accuracy, bullet, kBullet)
    ->Name("Engines/bullet")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(engine_at_accuracy, ode, kOde)
    ->Name("Engines/ode")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(engine_at_accuracy, simbody, kSimbody)
    ->Name("Engines/simbody")
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace crosslink

BENCHMARK_MAIN();
