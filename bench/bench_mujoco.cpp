// MuJoCo engine: wall time per simulated driver cycle for every mechanisms/*.toml, at the
// default settings and at the most accurate ones (a quarter of the default step angle). Run from
// the source root: build/bench/bench_mujoco
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "analytic/loader.h"
#include "analytic/sweep.h"
#include "sim/mujoco/mujoco_engine.h"

namespace {

void run_cycle(benchmark::State& bench, const std::string& path, crosslink::sim::Settings s) {
  const crosslink::Mechanism m = crosslink::load_mechanism(path);
  const auto engine = crosslink::sim::make_mujoco_engine();
  std::string why;
  if (!engine->supports(m, &why)) {
    bench.SkipWithError(why.c_str());
    return;
  }
  const crosslink::Trajectory exact = crosslink::sweep(m);
  double per_cycle = 0.0;
  long steps = 0;
  for (auto _ : bench) {
    const crosslink::sim::EngineRun run = engine->run(m, exact, s);
    per_cycle = run.cost.wall_seconds_per_cycle;
    steps = run.cost.steps;
  }
  bench.counters["s_per_cycle"] = per_cycle;
  bench.counters["steps"] = static_cast<double>(steps);
}

const int registered = [] {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator("mechanisms"))
    if (e.path().extension() == ".toml") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    const std::string name = f.stem().string(), path = f.string();
    benchmark::RegisterBenchmark(("mujoco/default/" + name).c_str(), [path](benchmark::State& s) {
      run_cycle(s, path, {});
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("mujoco/accurate/" + name).c_str(), [path](benchmark::State& s) {
      run_cycle(s, path, {{"max_step_angle", "0.000625"}});
    })->Unit(benchmark::kMillisecond);
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
