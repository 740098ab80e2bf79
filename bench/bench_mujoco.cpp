// MuJoCo engine: wall time per simulated driver cycle for every mechanisms/*.toml, at the
// default settings and at the most accurate ones (a quarter of the default step angle); and the
// fixed cost of one mjData (mj_makeData + mj_deleteData, a run makes three or four) of the scene
// a run loads, sized by its <size> and, as before it had one, at MuJoCo's defaults. Run from the
// source root: build/bench/bench_mujoco
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
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

// One mjData of the mechanism's exported scene (its run's, with a clock), `sized` as crosslink
// writes it or without the <size> line (MuJoCo's defaults: 500 rows, 100 contacts).
void make_data(benchmark::State& bench, const std::string& path, bool sized) {
  const crosslink::Mechanism m = crosslink::load_mechanism(path);
  std::string xml;
  try {
    xml = crosslink::sim::mujoco_mjcf(m, crosslink::sweep(m), {});
  } catch (const std::exception& e) {
    bench.SkipWithError(e.what());
    return;
  }
  if (!sized) xml = std::regex_replace(xml, std::regex("  <size [^\n]*\n"), "");
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("bench_mujoco_" + m.name + ".xml");
  std::ofstream(file) << xml;
  std::array<char, 1000> error{};
  mjModel* model = mj_loadXML(file.string().c_str(), nullptr, error.data(), error.size());
  std::filesystem::remove(file);
  if (!model) {
    bench.SkipWithError(error.data());
    return;
  }
  for (auto _ : bench) {
    mjData* d = mj_makeData(model);
    benchmark::DoNotOptimize(d);
    mj_deleteData(d);
  }
  mjData* d = mj_makeData(model);  // its buffer and stack
  bench.counters["MB"] =
      1e-6 * static_cast<double>(d->nbuffer + d->nstack * static_cast<int>(sizeof(mjtNum)));
  mj_deleteData(d);
  bench.counters["njmax"] = model->njmax;
  bench.counters["nstack"] = static_cast<double>(model->nstack);
  mj_deleteModel(model);
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
    for (const bool sized : {true, false})
      benchmark::RegisterBenchmark(
          ("mujoco/make_data/" + name + (sized ? "/sized" : "/defaults")).c_str(),
          [path, sized](benchmark::State& s) { make_data(s, path, sized); })
          ->Unit(benchmark::kMicrosecond);
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
