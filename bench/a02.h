// IFToMM A02, the N four-bar chain, for the benchmarks of cost against size (bench_dynamics,
// bench_sweep): N = 2 (bundled), 10 and 40 (mechanisms/scaling/), 160 (written into the build
// folder by scripts/generate_a02.py, see bench/CMakeLists.txt, so only the benchmarks read it).
#pragma once

#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/loader.h"
#include "sim/sampling.h"

namespace crosslink::bench {

inline std::string a02_file(int n) {
  if (n == 2) return "mechanisms/iftomm_a02_double_fourbar.toml";
  if (n == 160) return CROSSLINK_A02_160;
  return "mechanisms/scaling/iftomm_a02_nfourbar_" + std::to_string(n) + ".toml";
}

// A02 with N four-bar loops (2N + 1 moving bars), loaded once.
inline const Mechanism& a02(int n) {
  static std::map<int, Mechanism> cache;
  auto it = cache.find(n);
  if (it == cache.end()) it = cache.emplace(n, load_mechanism(a02_file(n))).first;
  return it->second;
}

// Runs `run` once per benchmark iteration; its mean CPU time of the thread [s]
// (sim::thread_cpu_seconds: on a shared machine the wall time of one run swings with the load).
template <class Run>
double thread_seconds_per_run(benchmark::State& state, Run&& run) {
  double seconds = 0.0;
  for (auto _ : state) {
    const double start = sim::thread_cpu_seconds();
    run();
    seconds += sim::thread_cpu_seconds() - start;
  }
  return seconds / static_cast<double>(state.iterations());
}

// The growth exponent of a cost against the number of bodies within one run: each size's time
// (CPU seconds) is added as it is measured (sizes in increasing order), and from the second size on
// the counter growth_exponent is the least-squares slope of log time against log bodies so far.
class Growth {
 public:
  void add(benchmark::State& state, double bodies, double seconds) {
    points_.emplace_back(std::log(bodies), std::log(seconds));
    if (points_.size() < 2) return;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [x, y] : points_) {
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    const double k = static_cast<double>(points_.size());
    state.counters["growth_exponent"] = (k * sxy - sx * sy) / (k * sxx - sx * sx);
  }

 private:
  std::vector<std::pair<double, double>> points_;
};

}  // namespace crosslink::bench
