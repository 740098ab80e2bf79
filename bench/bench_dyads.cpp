// Cost per pose of the closed-form dyads on the crank-rocker four-bar (position, velocity,
// acceleration), with Newton–Raphson on the same four-bar beside it. Target: dyads under 0.2 us
// per pose (position + velocity + acceleration). The driver advances 1 degree per pose, as in a
// sweep, so the dyads' continuity check and Newton's warm start are both exercised.
#include <benchmark/benchmark.h>

#include <numbers>
#include <string>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"

namespace crosslink {
namespace {

constexpr double kStep = std::numbers::pi / 180.0;

const Mechanism& fourbar() {
  static const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  return m;
}

// parts: 1 position, 2 + velocity, 3 + acceleration.
void BM_DyadsFourbar(benchmark::State& bench, int parts) {
  const Mechanism& m = fourbar();
  const DyadSolver solver(m, decompose(m));
  const NewtonSolver newton(m);
  KinematicState assembled(m);
  newton.assemble(assembled);
  DyadState state(m);
  solver.set_modes(assembled, state);
  state.kinematics.swept() = assembled.swept();
  for (auto _ : bench) {
    state.kinematics.swept().value += kStep;
    benchmark::DoNotOptimize(solver.solve_position(state));
    if (parts >= 2) solver.solve_velocity(state);
    if (parts >= 3) solver.solve_acceleration(state);
    benchmark::DoNotOptimize(state.kinematics.qddot.data());
  }
  bench.SetItemsProcessed(bench.iterations());
}
BENCHMARK_CAPTURE(BM_DyadsFourbar, position, 1);
BENCHMARK_CAPTURE(BM_DyadsFourbar, position_velocity, 2);
BENCHMARK_CAPTURE(BM_DyadsFourbar, position_velocity_acceleration, 3);

void BM_NewtonFourbar(benchmark::State& bench, int parts) {
  const Mechanism& m = fourbar();
  const NewtonSolver newton(m);
  KinematicState state(m);
  newton.assemble(state);
  for (auto _ : bench) {
    state.swept().value += kStep;  // warm start from the previous pose
    benchmark::DoNotOptimize(newton.solve_position(state));
    if (parts >= 2) newton.solve_velocity(state);
    if (parts >= 3) newton.solve_acceleration(state);
    benchmark::DoNotOptimize(state.qddot.data());
  }
  bench.SetItemsProcessed(bench.iterations());
}
BENCHMARK_CAPTURE(BM_NewtonFourbar, position, 1);
BENCHMARK_CAPTURE(BM_NewtonFourbar, position_velocity_acceleration, 3);

}  // namespace
}  // namespace crosslink

BENCHMARK_MAIN();
