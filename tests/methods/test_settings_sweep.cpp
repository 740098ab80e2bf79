// The settings sweep's analysis on synthetic inputs: Pareto front, observed order of convergence,
// the cheapest-setting rule, grids, time-step snapping and the CSV columns. No engine runs here
// (test_sweep_engines.cpp runs them).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>

#include "analytic/model/loader.h"
#include "methods/engines.h"
#include "methods/settings_sweep.h"

namespace crosslink::methods {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string mechanism_path(const std::string& stem) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + stem + ".toml";
}

// ---------------------------------------------------------------------------------------------
// Pareto front

TEST(ParetoFront, KeepsExactlyTheNonDominatedPoints) {
  //   error
  //    10 |  a
  //     1 |        b     d
  //   0.1 |              c        e
  //       +--------------------------- cost
  //          1     2     4        8
  const std::vector<double> cost = {1, 2, 4, 4, 8};
  const std::vector<double> error = {10, 1, 0.1, 1, 0.1};
  const std::vector<bool> front = pareto_front(cost, error, {true, true, true, true, true});
  EXPECT_EQ(front, (std::vector<bool>{true, true, true, false, false}));
}

TEST(ParetoFront, IneligibleAndNonFinitePointsAreNeverOnItNorDominate) {
  // The cheapest and most accurate point diverged: it must not hide the others.
  const std::vector<double> cost = {0.5, 1, 2, 3};
  const std::vector<double> error = {1e-6, 1, 0.1, kNaN};
  const std::vector<bool> front = pareto_front(cost, error, {false, true, true, true});
  EXPECT_EQ(front, (std::vector<bool>{false, true, true, false}));
}

TEST(ParetoFront, EqualPointsBothStay) {
  const std::vector<bool> front = pareto_front({1, 1}, {2, 2}, {true, true});
  EXPECT_EQ(front, (std::vector<bool>{true, true}));
}

// Errors within kErrorTie are equal: what a 2 % difference in error cannot order (MuJoCo's Euler
// with the Newton or CG solver), the front does not order either.
TEST(ParetoFront, ErrorsWithinTheTieAreEqual) {
  // Equal work, errors 2 % apart: both stay (without the tie the less accurate one drops).
  EXPECT_EQ(pareto_front({1.0, 1.0}, {2.04, 2.0}, {true, true}, kErrorTie),
            (std::vector<bool>{true, true}));
  EXPECT_EQ(pareto_front({1.0, 1.0}, {2.04, 2.0}, {true, true}), (std::vector<bool>{false, true}));
  // Errors 2 % apart, the second with more work: the same error, the lesser work wins.
  EXPECT_EQ(pareto_front({1.0, 1.3}, {2.04, 2.0}, {true, true}, kErrorTie),
            (std::vector<bool>{true, false}));
  // The same work and clearly more accurate: it dominates.
  EXPECT_EQ(pareto_front({1.0, 1.0}, {2, 1}, {true, true}, kErrorTie),
            (std::vector<bool>{false, true}));
}

// The front weighs the work, which a run's timing does not change: two settings of the same time
// step and integrator (MuJoCo's Euler with the Newton and CG solvers) and equal errors stay on it
// together however far apart their measured CPU times are, and RK4 (4 stages) at the same step
// needs a smaller error to be there.
TEST(ParetoFront, TheWorkNotTheTimingDecides) {
  SweepRow newton, cg, rk4;
  for (SweepRow* r : {&newton, &cg, &rk4}) {
    r->engine = "mujoco";
    r->dt = 1e-3;
    r->evaluations_per_step = 1.0;
  }
  newton.cpu_s_per_cycle = 1.0;
  cg.cpu_s_per_cycle = 3.0;  // a loaded machine's timing
  rk4.settings = {{"integrator", "RK4"}};
  rk4.evaluations_per_step = 4.0;  // as MuJoCo's RK4 run reports (RunCost)
  EXPECT_DOUBLE_EQ(newton.work(), 1000.0);
  EXPECT_DOUBLE_EQ(cg.work(), 1000.0);
  EXPECT_DOUBLE_EQ(rk4.work(), 4000.0);
  const std::vector<double> work = {newton.work(), cg.work(), rk4.work()};
  EXPECT_EQ(pareto_front(work, {1.0, 1.01, 1.0}, {true, true, true}, kErrorTie),
            (std::vector<bool>{true, true, false}));
  EXPECT_EQ(pareto_front(work, {1.0, 1.01, 0.2}, {true, true, true}, kErrorTie),
            (std::vector<bool>{true, true, true}));
  SweepRow analytic;
  analytic.engine = "analytic";
  EXPECT_TRUE(std::isnan(analytic.work()));
  SweepRow refused;  // a run that took no step did no work
  refused.engine = "mujoco";
  refused.dt = 1e-3;
  EXPECT_TRUE(std::isnan(refused.work()));
}

// ---------------------------------------------------------------------------------------------
// Order of convergence

TEST(ConvergenceOrder, RecoversTheExponentOfAPowerLaw) {
  const std::vector<double> dt = {1e-3, 5e-4, 2e-4, 1e-4};
  for (double p : {1.0, 2.0, 4.0}) {
    std::vector<double> e;
    for (double h : dt) e.push_back(2e3 * std::pow(h, p) / std::pow(1e-3, p) * 1e-3);
    const ConvergenceFit fit = convergence_order(dt, e);
    EXPECT_NEAR(fit.order, p, 1e-9) << "p = " << p;
    EXPECT_EQ(fit.points, 4);
  }
}

TEST(ConvergenceOrder, LeavesOutSaturatedCoarsePointsAndTheFloor) {
  // Coarse: collapsed (40 %, 12 %); then second order; then a floor where finer steps stop
  // improving (local order log(1/0.9)/log(2.5) = 0.11 < 0.5), though the last is lower still.
  const std::vector<double> dt = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5};
  std::vector<double> e = {40, 12};
  for (double h : {2e-3, 1e-3, 5e-4, 2.5e-4}) e.push_back(1e-1 * (h / 2e-3) * (h / 2e-3));
  e.push_back(0.9 * e.back());
  e.push_back(0.2 * e.back());
  const ConvergenceFit fit = convergence_order(dt, e);
  EXPECT_NEAR(fit.order, 2.0, 1e-9);
  EXPECT_EQ(fit.points, 4);
  EXPECT_DOUBLE_EQ(fit.dt_max, 2e-3);
  EXPECT_DOUBLE_EQ(fit.dt_min, 2.5e-4);
  EXPECT_EQ(fit.used, (std::vector<bool>{false, false, true, true, true, true, false, false}));
}

TEST(ConvergenceOrder, IgnoresInputOrderAndMissingPoints) {
  const std::vector<double> dt = {1e-4, 1e-3, 3e-4, 2e-3};
  const std::vector<double> e = {1e-4, 1e-2, kNaN, 4e-2};  // second order, one point missing
  const ConvergenceFit fit = convergence_order(dt, e);
  EXPECT_NEAR(fit.order, 2.0, 1e-9);
  EXPECT_EQ(fit.points, 3);
}

TEST(ConvergenceOrder, NoOrderFromFewerThanTwoPoints) {
  EXPECT_TRUE(std::isnan(convergence_order({1e-3, 1e-4}, {50.0, 1e-3}).order));
  EXPECT_TRUE(std::isnan(convergence_order({1e-3}, {1e-3}).order));
  EXPECT_TRUE(std::isnan(convergence_order({}, {}).order));
}

// Issue 23: a series whose error stays or grows at its finest step is told apart from one that
// still falls (first or second order), whatever the order of the points and the ones missing.
TEST(ErrorFalls, TellsASeriesThatStillFallsFromOneThatStaysOrGrows) {
  const std::vector<double> dt = {4e-4, 2e-4, 1e-4, 5e-5};
  EXPECT_TRUE(error_falls(dt, {16.0, 4.0, 1.0, 0.25}));  // second order
  EXPECT_TRUE(error_falls(dt, {8.0, 4.0, 2.0, 1.0}));    // first order
  // MuJoCo RK4 on the crank-rocker (docs/sweep.md): velocity stalls, acceleration grows.
  EXPECT_FALSE(error_falls(dt, {0.919, 0.491, 0.443, 0.443}));
  EXPECT_FALSE(error_falls(dt, {1.65, 113.0, 264.0, 529.0}));
  // Within the tie (10 %) is no fall; the finest two finite points decide, in any order.
  EXPECT_FALSE(error_falls(dt, {4.0, 2.0, 1.0, 0.95}));
  EXPECT_TRUE(error_falls({5e-5, 4e-4, 1e-4, 2e-4}, {0.25, 16.0, kNaN, 4.0}));
  EXPECT_FALSE(error_falls({5e-5, 4e-4, 1e-4, 2e-4}, {5.0, 16.0, kNaN, 4.0}));
  // Fewer than two finite points: nothing to say.
  EXPECT_TRUE(error_falls(dt, {kNaN, kNaN, kNaN, 3.0}));
  EXPECT_TRUE(error_falls({}, {}));
}

// ---------------------------------------------------------------------------------------------
// The cheapest setting

// A row's position, velocity and acceleration errors, and its force error (NaN: forces not
// read).
SweepRow row(std::string variant, double dt, double cost, std::array<double, 3> e,
             RunStatus status = RunStatus::ok, double force = std::nan("")) {
  SweepRow r;
  r.engine = "mujoco";
  r.variant = std::move(variant);
  r.dt = dt;
  r.wall_s_per_cycle = cost;
  r.max_pct = {e[0], e[1], e[2], force};
  r.status = status;
  r.evaluations_per_step = r.variant.starts_with("RK4") ? 4.0 : 1.0;  // RK4: 4 stages of work
  return r;
}

// The forces are a class of their own: a setting that misses them is not picked, a run that
// reads none is judged on its motion.
TEST(Selection, ForcesWhereReadMustMeetTheAccuracy) {
  const std::vector<SweepRow> rows = {
      row("Euler", 1e-3, 1.0, {0.1, 0.1, 0.1}, RunStatus::ok, 5.0),  // forces 5 % off
      row("RK4", 1e-3, 1.2, {0.1, 0.1, 0.1}, RunStatus::ok, 0.5),
  };
  const Selection s = select_cheapest("mujoco", 1.0, rows);
  ASSERT_TRUE(s.found);
  EXPECT_EQ(s.chosen.variant, "RK4");
  EXPECT_FALSE(rows[0].meets(1.0));
  EXPECT_TRUE(row("Euler", 1e-3, 1.0, {0.1, 0.1, 0.1}).meets(1.0));            // no forces read
  EXPECT_FALSE(row("Euler", 1e-3, 1.0, {0.1, std::nan(""), 0.1}).meets(1.0));  // no motion
}

TEST(Selection, StopsAtTheCoarsestTimeStepThatMeetsTheAccuracy) {
  const std::vector<SweepRow> rows = {
      row("Euler", 1e-3, 1.0, {0.5, 3, 20}),        // misses acceleration
      row("RK4", 1e-3, 2.0, {0.1, 0.5, 0.9}),       // meets 1 %
      row("implicit", 1e-3, 1.2, {0.1, 0.5, 0.8}),  // meets 1 %, a quarter of RK4's work
      row("Euler", 1e-4, 0.5, {1e-3, 1e-3, 1e-3}),  // cheaper still (a noisy timing), finer:
                                                    // not needed, never chosen
      row("soft", 1e-3, 0.1, {0.01, 0.01, 0.01}, RunStatus::flagged),  // flagged: never chosen
  };
  const Selection s = select_cheapest("mujoco", 1.0, rows);
  ASSERT_TRUE(s.found);
  EXPECT_EQ(s.chosen.variant, "implicit");
  EXPECT_DOUBLE_EQ(s.chosen.dt, 1e-3);
  EXPECT_EQ(s.tried.size(), 4u);  // the 1e-3 level only
  EXPECT_NE(s.summary().find("implicit"), std::string::npos);

  const Selection strict = select_cheapest("mujoco", 0.01, rows);
  ASSERT_TRUE(strict.found);
  EXPECT_DOUBLE_EQ(strict.chosen.dt, 1e-4);

  const Selection impossible = select_cheapest("mujoco", 1e-6, rows);
  EXPECT_FALSE(impossible.found);
  EXPECT_NE(impossible.summary().find("no setting"), std::string::npos);
  EXPECT_FALSE(select_cheapest("bullet", 1.0, rows).found);  // another engine's rows
}

// At one time step the least work is taken, and among equal work the earlier row in the grid
// (the engine's default variant first): the measured cost never decides, so timing noise cannot
// change the pick.
TEST(Selection, TheGridOrderDecidesBetweenEqualWork) {
  const std::vector<SweepRow> rows = {row("Euler/Newton", 1e-3, 1.0, {0.1, 0.1, 0.1}),
                                      row("Euler/CG", 1e-3, 0.3, {0.1, 0.1, 0.1})};
  EXPECT_EQ(select_cheapest("mujoco", 1.0, rows).chosen.variant, "Euler/Newton");
  const std::vector<SweepRow> rk4_first = {row("RK4/Newton", 1e-3, 0.5, {0.1, 0.1, 0.1}),
                                           row("Euler/CG", 1e-3, 2.0, {0.1, 0.1, 0.1})};
  EXPECT_EQ(select_cheapest("mujoco", 1.0, rk4_first).chosen.variant, "Euler/CG");
  // A dynamics row must meet the accuracy on its energy balance too.
  SweepRow drifting = row("Euler/Newton", 1e-3, 1.0, {0.1, 0.1, 0.1});
  drifting.energy_pct = 2.0;
  EXPECT_FALSE(drifting.meets(1.0));
}

TEST(Selection, ARowWithoutAComparableClassNeverMeets) {
  EXPECT_FALSE(row("x", 1e-3, 1, {0.1, kNaN, 0.1}).meets(1.0));
  EXPECT_TRUE(row("x", 1e-3, 1, {0.1, 0.1, 1.0}).meets(1.0));
  EXPECT_FALSE(row("x", 1e-3, 1, {0.1, 0.1, 0.1}, RunStatus::diverged).meets(1.0));
}

// ---------------------------------------------------------------------------------------------
// The IFToMM accuracy limits

SweepRow tip_row(std::string variant, double dt, double cost, double position, double velocity,
                 RunStatus status = RunStatus::ok) {
  SweepRow r = row(std::move(variant), dt, cost, {0.1, 0.1, 0.1}, status);
  r.cpu_s_per_cycle = cost;
  r.tip_position_error = position;
  r.tip_velocity_error = velocity;
  return r;
}

// Per series the largest time step meeting each limit, the larger of the two errors deciding;
// a flagged run never meets one; a series that meets none says why, from its finest step.
TEST(BenchmarkLimits, LargestStepMeetingEachLimitAndItsRunCost) {
  const std::vector<SweepRow> rows = {
      tip_row("Euler", 1e-2, 0.01, 0.2, 0.05),                      // position over 1e-1
      tip_row("Euler", 3e-3, 0.02, 0.03, 0.08),                     // meets 1e-1
      tip_row("Euler", 1e-3, 0.05, 4e-4, 2e-3),                     // velocity over 1e-3
      tip_row("Euler", 5e-4, 0.09, 2e-4, 9e-4),                     // meets 1e-3
      tip_row("soft", 1e-2, 0.01, 1e-5, 1e-5, RunStatus::flagged),  // never meets
      tip_row("soft", 1e-3, 0.05, 0.5, 0.5),                        // ok but too far off
  };
  const std::vector<BenchmarkLimit> limits = benchmark_limits(rows, 10.0);
  ASSERT_EQ(limits.size(), 4u);  // 2 limits x 2 series, limit-major
  EXPECT_EQ(limits[0].variant, "Euler");
  EXPECT_DOUBLE_EQ(limits[0].limit, 1e-1);
  ASSERT_TRUE(limits[0].met);
  EXPECT_DOUBLE_EQ(limits[0].row.dt, 3e-3);
  EXPECT_DOUBLE_EQ(limits[0].run_cpu_seconds, 0.2);  // 0.02 s per simulated s over 10 s
  EXPECT_FALSE(limits[1].met);                       // soft, 1e-1
  EXPECT_DOUBLE_EQ(limits[1].row.dt, 1e-3);          // its finest step
  EXPECT_NE(limits[1].why.find("error 0.5"), std::string::npos) << limits[1].why;
  ASSERT_TRUE(limits[2].met);  // Euler, 1e-3
  EXPECT_DOUBLE_EQ(limits[2].limit, 1e-3);
  EXPECT_DOUBLE_EQ(limits[2].row.dt, 5e-4);
  EXPECT_NE(benchmark_limit_text(limits[2]).find("dt 0.0005 s"), std::string::npos);
  EXPECT_FALSE(limits[3].met);
  // Nothing with a tip error, nothing met; analytic rows other than the looser tolerances are
  // not a series.
  SweepRow reference = tip_row("exact", kNaN, 0.01, 0.0, 0.0);
  reference.engine = "analytic";
  SweepRow loose = tip_row("exact, tolerance 1e-06", kNaN, 0.002, 2e-3, 5e-3);
  loose.engine = "analytic";
  SweepRow tight = tip_row("exact, tolerance 1e-08", kNaN, 0.003, 2e-5, 5e-5);
  tight.engine = "analytic";
  const std::vector<BenchmarkLimit> exact = benchmark_limits({reference, loose, tight}, 10.0);
  ASSERT_EQ(exact.size(), 2u);
  EXPECT_EQ(exact[0].variant, "exact, dopri5");
  EXPECT_EQ(exact[0].row.variant, loose.variant);  // the loosest meeting 1e-1
  EXPECT_EQ(exact[1].row.variant, tight.variant);  // and 1e-3
  EXPECT_NE(benchmark_limit_text(exact[1]).find("met at tolerance 1e-08"), std::string::npos)
      << benchmark_limit_text(exact[1]);
}

// The measure on A02's B0: per coordinate, positions and velocities apart; samples an engine
// did not reach are not counted.
TEST(BenchmarkLimits, TipErrorsAreB0sLargestCoordinateDifferences) {
  const Mechanism m = load_mechanism(mechanism_path("iftomm_a02_double_fourbar"));
  ASSERT_EQ(benchmark_tip_point(m), "B0");
  Trajectory reference;
  reference.point_names = {"A0", "B0", "B1"};
  const int n = 5;
  reference.time = Eigen::VectorXd::LinSpaced(n, 0.0, 0.1);
  for (Eigen::MatrixXd* column : {&reference.x, &reference.y, &reference.vx, &reference.vy})
    *column = Eigen::MatrixXd::Zero(n, 3);
  reference.status.assign(n, PoseStatus::ok);
  Trajectory run = reference;
  run.x(1, 1) = 2e-3;   // B0
  run.y(2, 1) = -3e-3;  // B0: the position error
  run.vx(3, 1) = 4e-3;  // B0: the velocity error
  run.vy(3, 2) = 1.0;   // B1: not the tip
  run.x(4, 1) = 10.0;   // B0, after the run diverged
  run.status[4] = PoseStatus::diverged;
  run.status[2] = PoseStatus::singular;  // counted: the benchmark measures every output step
  const std::array<double, 2> e = benchmark_tip_errors(m, reference, run);
  EXPECT_DOUBLE_EQ(e[0], 3e-3);
  EXPECT_DOUBLE_EQ(e[1], 4e-3);
  run.vy(0, 1) = kNaN;  // a rate not written is not counted
  EXPECT_DOUBLE_EQ(benchmark_tip_errors(m, reference, run)[1], 4e-3);
}

// ---------------------------------------------------------------------------------------------
// Grids and references on step boundaries

TEST(Grid, CoarseToFineWithEveryVariantPerStepDefaultFirst) {
  for (const std::string& engine : engine_names()) {
    const std::vector<Variant> variants = engine_variants(engine);
    ASSERT_GE(variants.size(), 2u) << engine << ": the default and other settings";
    EXPECT_TRUE(variants.front().settings(1e-3).empty()) << engine << ": default first";
    const std::vector<GridPoint> grid = engine_grid(engine, {1e-4, 1e-2, 1e-3, 1e-3});
    ASSERT_EQ(grid.size(), 3 * variants.size());
    EXPECT_DOUBLE_EQ(grid.front().dt, 1e-2);
    EXPECT_DOUBLE_EQ(grid.back().dt, 1e-4);
    for (size_t i = 1; i < grid.size(); ++i) EXPECT_LE(grid[i].dt, grid[i - 1].dt);
  }
  // Softness that follows the step: solref (2 dt, 0.5).
  for (const Variant& v : engine_variants("mujoco"))
    if (v.name.find("2dt") != std::string::npos) {
      const sim::Settings s = v.settings(1e-3);
      ASSERT_EQ(s.size(), 1u);
      EXPECT_EQ(s[0].second, "0.002 0.5");
    }
  EXPECT_THROW(engine_variants("adams"), std::invalid_argument);
}

// A mechanism with joint friction adds each engine's friction variants after its others (its
// error against its friction settings, docs/sweep.md), for kinematic and dynamics cases alike;
// each sets only friction settings, every one of them the engine takes for such a mechanism.
TEST(Grid, FrictionAddsEachEnginesFrictionVariantsWhichItsSettingsTake) {
  const Mechanism rough = load_mechanism(mechanism_path("friction/fourbar_friction_circles"));
  for (const EngineEntry& e : engine_table())
    for (const bool dynamics : {false, true}) {
      const std::vector<Variant> plain = engine_variants(e.name, dynamics);
      const std::vector<Variant> with = engine_variants(e.name, dynamics, true);
      ASSERT_GE(e.friction_variants.size(), 2u) << e.name;
      ASSERT_EQ(with.size(), plain.size() + e.friction_variants.size()) << e.name;
      for (size_t i = 0; i < plain.size(); ++i) EXPECT_EQ(with[i].name, plain[i].name);
      const std::unique_ptr<sim::Engine> engine = e.make();
      for (size_t i = plain.size(); i < with.size(); ++i) {
        const sim::Settings s = with[i].settings(1e-3);
        ASSERT_FALSE(s.empty()) << with[i].name;
        for (const auto& setting : s)
          EXPECT_EQ(setting.first.rfind("friction_", 0), 0u) << with[i].name;
        EXPECT_NO_THROW(engine->check_settings(rough, s)) << with[i].name;
      }
      EXPECT_EQ(engine_grid(e.name, {1e-3}, dynamics, true).size(), with.size());
    }
}

TEST(Grid, DefaultTimeStepsSpanTwoDecades) {
  const std::vector<double> dts = default_time_steps();
  EXPECT_GE(*std::max_element(dts.begin(), dts.end()) / *std::min_element(dts.begin(), dts.end()),
            100.0);
}

TEST(ReferenceLadder, SnapsTimeStepsSoSamplesFallOnStepBoundaries) {
  // Crank-rocker at 8 pi rad/s sampled every degree: h = 1/1440 s.
  const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  ReferenceLadder ladder(m, {});
  const double h = 1.0 / 1440.0;
  ASSERT_NEAR(ladder.interval(), h, 1e-12);
  double dt = 0.0;
  const MethodRun& fine = ladder.for_dt(1e-4, &dt);
  EXPECT_NEAR(dt, h / 7, 1e-15);  // 6.94e-4 / 1e-4 = 6.9 -> 7 steps per sample
  EXPECT_EQ(&fine, &ladder.base());
  const MethodRun& coarse = ladder.for_dt(1e-2, &dt);
  EXPECT_NEAR(dt, 14 * h, 1e-12);  // 14.4 -> every 14th degree
  const Trajectory& t = coarse.trajectory;
  ASSERT_GE(t.samples(), 20);
  for (int k = 1; k < t.samples(); ++k) {
    EXPECT_NEAR(t.time(k) - t.time(k - 1), dt, 1e-9 * dt);
    EXPECT_NEAR(t.along(k) - t.along(k - 1), 14 * std::numbers::pi / 180, 1e-9);
  }
  // Kept, not rebuilt.
  double again = 0.0;
  EXPECT_EQ(&ladder.for_dt(9.8e-3, &again), &coarse);
}

// ---------------------------------------------------------------------------------------------
// CSV

TEST(Csv, FirstColumnsAreExactlyTheDocumentedOnesInOrder) {
  SettingsSweep sweep;
  sweep.rows.push_back(row("Euler/Newton", 1e-3, 2e-3, {0.1, 0.2, kNaN}, RunStatus::flagged));
  sweep.rows.back().message = "3 samples flagged, \"loop_gap\"";
  std::ostringstream out;
  write_sweep_csv(sweep, out);
  const std::string text = out.str();
  EXPECT_EQ(text.rfind("engine,setting,dt,wall_s_per_cycle,max_pct_position,max_pct_velocity,"
                       "max_pct_acceleration,max_loop_gap,status,",
                       0),
            0u);
  const std::string line = text.substr(text.find('\n') + 1);
  EXPECT_EQ(line.rfind("mujoco,\"Euler/Newton, dt=0.001\",0.001,0.002,0.1,0.2,,0,flagged,", 0), 0u)
      << line;
  EXPECT_NE(line.find("\"3 samples flagged, \"\"loop_gap\"\"\""), std::string::npos);
}

}  // namespace
}  // namespace crosslink::methods
