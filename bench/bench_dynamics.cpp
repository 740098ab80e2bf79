// The exact forward-dynamics reference (analytic/physics/dynamics.h): what its accuracy costs, and
// how its cost grows with the size of the mechanism (docs/dynamics.md, "Cost").
//
//   Andrews/rkf78/tol:<-log10 tol>   Andrews' squeezer from t = 0 to 0.03 s (one output time);
//                                    counters: significant digits of the seven angles at 0.03 s
//                                    against the Test Set for IVP Solvers' reference (its scd
//                                    measure) and against our own converged solution (rkf78 and
//                                    dopri5 at 1e-15 agreeing), evaluations of the equation
//   A02/N:<n>                        IFToMM A02, 10 s at its 400 output steps, N = 2, 10, 40,
//                                    160 (written at build time by scripts/generate_a02.py, so
//                                    that only this benchmark reads it); counters: evaluations,
//                                    wall seconds per simulated second, and growth_exponent: the
//                                    least-squares slope of log time against log bodies over the
//                                    sizes run so far in this run
//   A02/<engine>/N:<n>               the same run by MuJoCo and Bullet at their defaults, from the
//                                    exact initial state (the reference's own run is not timed);
//                                    counters: engine steps and time step, the stepping CPU
//                                    seconds per simulated second (RunCost), and the IFToMM
//                                    error of B0 against the reference [m, m/s]
//
// Run from the source root (N = 40 takes minutes for each engine; the reference N = 160 takes
// seconds):
//   build/bench/bench_dynamics --benchmark_min_time=0.5
//   build/bench/bench_dynamics --benchmark_filter='A02/'   # cost against size only
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "bench/a02.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"

namespace crosslink {
namespace {

const Mechanism& andrews() {
  static const Mechanism m = load_mechanism("mechanisms/andrews_squeezer.toml");
  return m;
}

// The Test Set's angles (beta ... epsilon) at the last sample; its relative angles are
// differences of the link angles (mechanisms/andrews_squeezer.toml).
std::array<double, 7> test_set_angles(const Trajectory& t) {
  const int k = t.samples() - 1;
  const auto a = [&](const char* link) {
    const auto c = std::find(t.link_names.begin(), t.link_names.end(), link) - t.link_names.begin();
    return t.angle(k, c);
  };
  return {a("body1"), a("body2") - a("body1"), a("body3"), a("body4") - a("body5"),
          a("body5"), a("body6") - a("body7"), a("body7")};
}

// The Test Set for IVP Solvers, problem "andrews": the reference solution at 0.03 s (andrews.f).
constexpr std::array<double, 7> kTestSet = {
    0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1, -0.5347301163226948e+0,
    0.5244099658805304e+0, 0.5347301163226948e+0,  0.1048080741042263e+1};

Simulation andrews_at_end(const std::string& integrator, double tolerance) {
  SimulationOptions o{
      .duration = 0.03, .interval = 0.03, .integrator = integrator, .tolerance = tolerance};
  return simulate(andrews(), o);
}

// -log10 of the largest relative difference of the seven angles.
double digits(const std::array<double, 7>& q, const std::array<double, 7>& reference) {
  double worst = 1e-300;
  for (size_t i = 0; i < q.size(); ++i)
    worst = std::max(worst, std::abs(q[i] - reference[i]) / std::abs(reference[i]));
  return -std::log10(worst);
}

const std::array<double, 7>& converged() {
  static const std::array<double, 7> q = test_set_angles(andrews_at_end("rkf78", 1e-15).trajectory);
  return q;
}

void andrews_reference(benchmark::State& state) {
  const double tolerance = std::pow(10.0, -static_cast<double>(state.range(0)));
  Simulation s;
  for (auto _ : state) {
    s = andrews_at_end("rkf78", tolerance);
    benchmark::DoNotOptimize(s.trajectory.angle.data());
  }
  if (!s.ok) {
    state.SkipWithError(s.message.c_str());
    return;
  }
  const std::array<double, 7> q = test_set_angles(s.trajectory);
  state.counters["digits_test_set"] = digits(q, kTestSet);
  state.counters["digits_converged"] = digits(q, converged());
  state.counters["evaluations"] = static_cast<double>(s.evaluations);
  // How far the converged solution itself is from the check integration (dopri5 at 1e-15).
  static const double check =
      digits(test_set_angles(andrews_at_end("dopri5", 1e-15).trajectory), converged());
  state.counters["digits_converged_check"] = check;
}

void a02_reference(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mechanism& m = bench::a02(n);
  Simulation s;
  const double seconds = bench::thread_seconds_per_run(state, [&] {
    s = simulate(m);
    benchmark::DoNotOptimize(s.trajectory.angle.data());
  });
  if (!s.ok) {
    state.SkipWithError(s.message.c_str());
    return;
  }
  static bench::Growth growth;
  growth.add(state, m.moving_count(), seconds);
  state.counters["bodies"] = static_cast<double>(m.moving_count());
  state.counters["evaluations"] = static_cast<double>(s.evaluations);
  state.counters["s_per_simulated_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 10.0,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The engine at its defaults on A02 with N loops, against the exact simulation (run once per N,
// outside the timing).
template <const char* engine>
void a02_engine(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Mechanism& m = bench::a02(n);
  static std::map<int, compare::MethodRun> references;
  auto ref = references.find(n);
  if (ref == references.end()) ref = references.emplace(n, methods::run_reference(m)).first;
  compare::MethodRun run;
  for (auto _ : state) {
    run = methods::run_method(engine, m, ref->second);
    benchmark::DoNotOptimize(run.trajectory.angle.data());
  }
  if (!run.ok) {
    state.SkipWithError(run.message.c_str());
    return;
  }
  const std::array<double, 2> tip =
      methods::benchmark_tip_errors(m, ref->second.trajectory, run.trajectory);
  state.counters["bodies"] = static_cast<double>(m.moving_count());
  state.counters["steps"] = static_cast<double>(run.cost.steps);
  for (const auto& [name, value] : run.settings)
    if (name == "dt") state.counters["dt"] = std::stod(value);
  state.counters["cpu_s_per_simulated_s"] = run.cost.cpu_seconds_per_cycle;
  state.counters["B0_position_error"] = tip[0];
  state.counters["B0_velocity_error"] = tip[1];
}
constexpr char kMujoco[] = "mujoco";
constexpr char kBullet[] = "bullet";

BENCHMARK(andrews_reference)
    ->Name("Andrews/rkf78/tol")
    ->DenseRange(10, 14)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(a02_reference)
    ->Name("A02/N")
    ->Arg(2)
    ->Arg(10)
    ->Arg(40)
    ->Arg(160)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(a02_engine<kMujoco>)
    ->Name("A02/mujoco/N")
    ->Arg(2)
    ->Arg(10)
    ->Arg(40)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(a02_engine<kBullet>)
    ->Name("A02/bullet/N")
    ->Arg(2)
    ->Arg(10)
    ->Arg(40)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace crosslink

BENCHMARK_MAIN();
