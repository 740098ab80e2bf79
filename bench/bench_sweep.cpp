// Speed against accuracy, as benchmarks: the cost of one driver cycle of the crank-rocker
// four-bar (a 0.04, b 0.12, c 0.08, d 0.10 m, 8 pi rad/s, sampled every degree: 360 poses) by
// every method, through the same interfaces `crosslink compare` and `crosslink sweep` use, so the
// ratios compare like with like (docs/sweep.md, README "Performance").
//
//   Cycle/newton             the exact sweep (Newton, position + velocity + acceleration)
//   Cycle/reference          the reference `compare` judges by: the Newton sweep checked by the
//                            dyads at its samples (analytic/reference/trust.h), so its cost over
//                            Cycle/newton is the self-check's
//   Cycle/dyads              closed-form dyads at the same 360 driver values
//   Cycle/<engine>/dt:<n>    an engine at its default variant, dt = (1 degree of crank) / n, the
//                            whole run (scene build, steps, sampling); counters: steps per cycle,
//                            wall time per step, and the run's own stepping time per cycle
//
//   A02/newton/N:<n>         the exact sweep of IFToMM A02 with N = 2, 10, 40, 160 four-bar loops
//                            (one driver cycle of its crank, driven at its initial rate);
//                            counters: bodies, samples, growth_exponent (the least-squares slope
//                            of log time against log bodies over the sizes run so far)
//   A02/mujoco/N:<n>         MuJoCo's driven run of the same cycle at its default settings (the
//                            kinematic view: the [dynamics] case removed), on the Newton sweep's
//                            samples: what the exact sweep's time at each N is set against
//
// Run from the source root:
//   build/bench/bench_sweep --benchmark_min_time=0.5
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <map>
#include <string>
#include <utility>

#include "analytic/model/loader.h"
#include "bench/a02.h"
#include "methods/registry.h"

namespace crosslink {
namespace {

const Mechanism& crank_rocker() {
  static const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  return m;
}

const compare::MethodRun& reference() {
  static const compare::MethodRun r = methods::run_reference(crank_rocker());
  return r;
}

void newton_cycle(benchmark::State& state) {
  for (auto _ : state) {
    const Trajectory t = sweep(crank_rocker());
    benchmark::DoNotOptimize(t.alpha.data());
  }
  state.counters["poses"] = reference().trajectory.samples();
}

void a02_sweep(benchmark::State& state) {
  const Mechanism& m = bench::a02(static_cast<int>(state.range(0)));
  Trajectory t;
  const double seconds = bench::thread_seconds_per_run(state, [&] {
    t = sweep(m);
    benchmark::DoNotOptimize(t.alpha.data());
  });
  static bench::Growth growth;
  growth.add(state, m.moving_count(), seconds);
  state.counters["bodies"] = m.moving_count();
  state.counters["samples"] = t.samples();
}

// A02's kinematic view (driven at its initial rate, as `sweep` runs it) and its reference, per N.
const std::pair<Mechanism, compare::MethodRun>& a02_driven(int n) {
  static std::map<int, std::pair<Mechanism, compare::MethodRun>> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    Mechanism m = bench::a02(n);
    m.dynamics.reset();
    compare::MethodRun reference = methods::run_reference(m);
    it = cache.emplace(n, std::make_pair(std::move(m), std::move(reference))).first;
  }
  return it->second;
}

void a02_engine(benchmark::State& state, const std::string& engine) {
  const auto& [m, reference] = a02_driven(static_cast<int>(state.range(0)));
  long steps = 0;
  const double seconds = bench::thread_seconds_per_run(state, [&] {
    const compare::MethodRun run = methods::run_method(engine, m, reference);
    if (!run.ok) state.SkipWithError((engine + ": " + run.message).c_str());
    steps = run.cost.steps;
    benchmark::DoNotOptimize(run.trajectory.alpha.data());
  });
  static bench::Growth growth;
  growth.add(state, m.moving_count(), seconds);
  state.counters["bodies"] = m.moving_count();
  state.counters["steps_run"] = static_cast<double>(steps);
}

void reference_cycle(benchmark::State& state) {
  for (auto _ : state) {
    const compare::MethodRun run = methods::run_reference(crank_rocker());
    benchmark::DoNotOptimize(run.trajectory.alpha.data());
  }
  state.counters["poses"] = reference().trajectory.samples();
}

void method_cycle(benchmark::State& state, const std::string& method) {
  for (auto _ : state) {
    const compare::MethodRun run = methods::run_method(method, crank_rocker(), reference());
    if (!run.ok) {
      state.SkipWithError((method + ": " + run.message).c_str());
      return;
    }
    benchmark::DoNotOptimize(run.trajectory.alpha.data());
  }
  state.counters["poses"] = reference().trajectory.samples();
}

void engine_cycle(benchmark::State& state, const std::string& engine) {
  const double interval = reference().trajectory.time(1) - reference().trajectory.time(0);
  const double dt = interval / static_cast<double>(state.range(0));
  const sim::Settings settings = {{"dt", fmt::format("{:.12g}", dt)}};
  double stepping = 0.0;
  long steps = 0;
  for (auto _ : state) {
    const compare::MethodRun run =
        methods::run_method(engine, crank_rocker(), reference(), settings);
    if (!run.ok) {
      state.SkipWithError((engine + ": " + run.message).c_str());
      return;
    }
    stepping = run.cost.wall_seconds_per_cycle;
    steps = run.cost.steps;
    benchmark::DoNotOptimize(run.trajectory.alpha.data());
  }
  const double cycle = crank_rocker().cycle_period();
  state.counters["dt_s"] = dt;
  state.counters["steps_per_cycle"] = cycle / dt;
  state.counters["stepping_s_per_cycle"] = stepping;
  state.counters["s_per_step"] = stepping * dt / cycle;
  state.counters["steps_run"] = static_cast<double>(steps);
}

BENCHMARK(newton_cycle)->Name("Cycle/newton")->Unit(benchmark::kMillisecond);
BENCHMARK(a02_sweep)
    ->Name("A02/newton/N")
    ->Arg(2)
    ->Arg(10)
    ->Arg(40)
    ->Arg(160)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(a02_engine, mujoco, std::string("mujoco"))
    ->Name("A02/mujoco/N")
    ->Arg(2)
    ->Arg(10)
    ->Arg(40)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(reference_cycle)->Name("Cycle/reference")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(method_cycle, dyads, std::string("dyads"))
    ->Name("Cycle/dyads")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(engine_cycle, mujoco, std::string("mujoco"))
    ->Name("Cycle/mujoco")
    ->ArgName("dt:1deg/")
    ->Arg(1)
    ->Arg(7)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(engine_cycle, bullet, std::string("bullet"))
    ->Name("Cycle/bullet")
    ->ArgName("dt:1deg/")
    ->Arg(1)
    ->Arg(7)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace crosslink

BENCHMARK_MAIN();
