// Bullet engine: wall time per simulated driver cycle for every bundled mechanism, at the
// default settings and at the most accurate ones (20 steps per sample). Run from the source root.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"

namespace {

void run_engine(benchmark::State& state, const std::string& file,
                const crosslink::sim::Settings& settings) {
  const crosslink::Mechanism m = crosslink::load_mechanism(file);
  const crosslink::Trajectory ref = crosslink::sweep(m);
  const auto engine = crosslink::sim::make_bullet_engine();
  double per_cycle = 0.0;
  long steps = 0;
  for (auto _ : state) {
    const crosslink::sim::EngineRun run = engine->run(m, ref, settings);
    per_cycle = run.cost.wall_seconds_per_cycle;
    steps = run.cost.steps;
    if (!run.ok) state.SkipWithError(run.message.c_str());
  }
  state.counters["s_per_cycle"] = per_cycle;
  state.counters["steps"] = static_cast<double>(steps);
}

const int registered = [] {
  const crosslink::sim::Settings accurate = {{"steps_per_sample", "20"}};
  for (const auto& entry : std::filesystem::directory_iterator("mechanisms")) {
    if (entry.path().extension() != ".toml") continue;
    const std::string file = entry.path().string(), name = entry.path().stem().string();
    benchmark::RegisterBenchmark(("bullet/default/" + name).c_str(), run_engine, file,
                                 crosslink::sim::Settings{})
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("bullet/accurate/" + name).c_str(), run_engine, file, accurate)
        ->Unit(benchmark::kMillisecond);
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
