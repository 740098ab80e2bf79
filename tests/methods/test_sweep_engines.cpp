// The settings sweep with the real engines on the crank-rocker four-bar (a 0.04, b 0.12, c 0.08,
// d 0.10 m, 8 pi rad/s), against the analytic Newton sweep. Expectations come from
// shared/reference/engine-notes.md (MuJoCo: errors scale as dt^2; MuJoCo's default softness is
// tens of % off) and from the selection rule itself, never from stored output.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "methods/engines.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"
#include "methods/sweep_ranking.h"

namespace crosslink::methods {
namespace {

std::string mechanism_path(const std::string& stem) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + stem + ".toml";
}

const Mechanism& crank_rocker() {
  static const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  return m;
}

GridPoint point(const char* engine, const char* variant, double dt) {
  for (const Variant& v : engine_variants(engine))
    if (v.name == variant) return {engine, v.name, dt, v.settings(dt)};
  ADD_FAILURE() << "no variant " << variant;
  return {};
}

double h() {
  return 1.0 / 1440.0;
}  // the crank-rocker's sample interval: 1 degree

// The work an engine reports (RunCost::model_evaluations) is the steps it took times the model
// evaluations each makes: MuJoCo 2.2's mj_step (engine_forward.c) evaluates the model once and
// then advances with Euler or implicit, while RK4 (mj_RungeKutta, N = 4) evaluates three stages
// more; Bullet's stepSimulation(dt, 0, dt) takes one internal step. The sweep's work column is
// that figure per step over the time step, in a kinematic case and a dynamics case.
TEST(SweepEngines, EnginesReportTheModelEvaluationsTheyMade) {
  struct Case {
    const char* engine;
    const char* variant;
    long stages;
  };
  const Case kinematic[] = {
      {"mujoco", "Euler/Newton", 1},
      {"mujoco", "RK4/Newton, driver watch 0.05 rad", 4},
      {"mujoco", "implicit/Newton, driver watch 0.05 rad", 1},
      {"bullet", "rigid/MLCP Dantzig erp 1", 1},
      {"bullet", "multibody/MLCP Dantzig erp 1", 1},
  };
  const Case dynamics[] = {
      {"mujoco", "RK4/Newton", 4},
      {"mujoco", "implicit/Newton", 1},
      {"bullet", "rigid/MLCP Dantzig erp 1", 1},
  };
  const auto check = [](const Mechanism& m, ReferenceLadder& ladder, const Case& c, double dt) {
    SCOPED_TRACE(fmt::format("{} {} {}", m.name, c.engine, c.variant));
    GridPoint p;
    for (const Variant& v : engine_variants(c.engine, m.dynamics.has_value()))
      if (v.name == c.variant) p = {c.engine, v.name, dt, v.settings(dt)};
    ASSERT_EQ(p.variant, c.variant);
    double snapped = 0.0;
    const MethodRun& reference = ladder.for_dt(dt, &snapped);
    sim::Settings settings = p.settings;
    settings.emplace_back("dt", fmt::format("{:.12g}", snapped));
    const MethodRun run = run_method(c.engine, m, reference, settings);
    ASSERT_TRUE(run.available) << run.message;
    EXPECT_GT(run.cost.steps, 0);
    EXPECT_EQ(run.cost.model_evaluations, run.cost.steps * c.stages);
    const SweepRow row = evaluate_setting(m, ladder, p);
    EXPECT_EQ(row.work(), static_cast<double>(c.stages) / row.dt);
  };
  ReferenceLadder kinematic_ladder(crank_rocker(), {});
  for (const Case& c : kinematic) check(crank_rocker(), kinematic_ladder, c, h() / 2);
  const Mechanism pendulum = load_mechanism(mechanism_path("iftomm_a01_pendulum"));
  ReferenceLadder dynamics_ladder(pendulum, {});
  for (const Case& c : dynamics) check(pendulum, dynamics_ladder, c, 1e-2);
}

// MuJoCo, Euler with the Newton solver and deadbeat loops: second order in dt (engine-notes:
// "errors scale as dt^2"), on every class, over h/2 .. h/16.
TEST(SweepEngines, MujocoDefaultConvergesAtSecondOrder) {
  ReferenceLadder ladder(crank_rocker(), {});
  std::vector<double> dts;
  std::array<std::vector<double>, kErrorClasses.size()> errors;
  for (int n : {2, 4, 8, 16}) {
    const SweepRow r =
        evaluate_setting(crank_rocker(), ladder, point("mujoco", "Euler/Newton", h() / n));
    ASSERT_EQ(r.status, RunStatus::ok) << r.message;
    EXPECT_NEAR(r.dt, h() / n, 1e-12);
    dts.push_back(r.dt);
    for (size_t c = 0; c < errors.size(); ++c) errors[c].push_back(r.max_pct[c]);
  }
  for (ErrorClass c : kErrorClasses) {
    const ConvergenceFit fit = convergence_order(dts, errors[static_cast<size_t>(c)]);
    std::string series;
    for (double e : errors[static_cast<size_t>(c)]) series += fmt::format(" {:.3g}", e);
    EXPECT_GE(fit.points, 2) << to_string(c) << series;
    EXPECT_NEAR(fit.order, 2.0, 0.4) << to_string(c) << series;
  }
}

// MuJoCo's own default loop softness (solref 0.02 1): engine-notes measured a 1.5 cm loop gap
// and 67 % of peak in the rocker's omega. The sweep must show it (flagged) and never pick it.
TEST(SweepEngines, MujocoDefaultSoftnessCollapses) {
  ReferenceLadder ladder(crank_rocker(), {});
  const SweepRow soft = evaluate_setting(
      crank_rocker(), ladder,
      point("mujoco", "Euler/Newton soft (MuJoCo default solref 0.02 1)", h() / 7));
  EXPECT_GT(soft.max_loop_gap, 1e-3) << soft.message;
  EXPECT_NE(soft.status, RunStatus::ok);
  EXPECT_FALSE(soft.meets(10.0));
}

// The search: every chosen setting meets its accuracy; a stricter accuracy never needs a coarser
// step; no coarser step than the chosen one had a setting that met it.
TEST(SweepEngines, CheapestSettingMeetsTheAccuracyAndStopsEarly) {
  for (const std::string& engine : engine_names()) {
    ReferenceLadder ladder(crank_rocker(), {});
    const std::vector<double> dts = accuracy_time_steps(ladder.interval());
    const Selection loose = cheapest_setting(crank_rocker(), ladder, engine, 1.0, dts);
    const Selection strict = cheapest_setting(crank_rocker(), ladder, engine, 0.01, dts);
    ASSERT_TRUE(loose.found) << loose.summary();
    ASSERT_TRUE(strict.found) << strict.summary();
    EXPECT_TRUE(loose.chosen.meets(1.0));
    EXPECT_TRUE(strict.chosen.meets(0.01));
    EXPECT_GE(loose.chosen.dt, strict.chosen.dt * (1 - 1e-9)) << engine;
    for (const SweepRow& r : strict.tried)
      if (r.dt > strict.chosen.dt * (1 + 1e-9)) {
        EXPECT_FALSE(r.meets(0.01)) << r.setting_label();
      }
    // Stopped early: nothing finer than the chosen step was run.
    for (const SweepRow& r : loose.tried) EXPECT_GE(r.dt, loose.chosen.dt * (1 - 1e-9));
    std::printf("%s\n%s\n", loose.summary().c_str(), strict.summary().c_str());
  }
}

// The whole command's library path on two time steps: rows, orders, fronts, CSV and page.
TEST(SweepEngines, SmallSweepProducesRowsFrontsAndReports) {
  SettingsSweepOptions options;
  options.dts = {1e-3, 2e-4};
  options.accuracy_pct = 1.0;
  int calls = 0;
  options.progress = [&](int i, int total, const GridPoint&) {
    ++calls;
    EXPECT_LE(i, total);
  };
  const SettingsSweep sweep = run_settings_sweep(crank_rocker(), options);
  int engine_rows = 0, on_front = 0;
  for (const SweepRow& r : sweep.rows) {
    if (r.engine == "analytic") continue;
    ++engine_rows;
    on_front += r.pareto[2];
    if (r.pareto[2]) {
      EXPECT_EQ(r.status, RunStatus::ok);
    }
  }
  EXPECT_EQ(calls, engine_rows);
  if (engine_rows == 0) GTEST_SKIP() << "no engine built";
  EXPECT_GE(on_front, 1);
  EXPECT_EQ(sweep.rows.front().variant, "newton");
  EXPECT_FALSE(sweep.orders.empty());
  std::ostringstream csv;
  write_sweep_csv(sweep, csv);
  const std::string text = csv.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), static_cast<long>(sweep.rows.size()) + 1);
  if (compare::find_report_assets({})) {
    std::ostringstream html;
    write_sweep_html(sweep, {}, html);
    EXPECT_NE(html.str().find("const REPORT = "), std::string::npos);
    EXPECT_NE(html.str().find("render-status"), std::string::npos);
  }
}

// A dynamics case (IFToMM A02 with N = 2 over 10 s), MuJoCo at one time step: the rows carry the
// error at the end of the run and of the energy balance; the exact simulation's second
// integrator (dopri5) at looser tolerances is drawn beside, its error falling with the tolerance
// (the reference, rkf78 stepped to each sample, would give the same run at every tolerance);
// the IFToMM limits on B0 per series; and two identical sweeps give the same errors (the
// engines are deterministic) and pick the same setting.
TEST(SweepEngines, DynamicsCaseWorkPrecisionRows) {
  const Mechanism m = load_mechanism(mechanism_path("iftomm_a02_double_fourbar"));
  SettingsSweepOptions options;
  options.engines = {"mujoco"};
  options.dts = {2e-3};
  options.repeat = 3;
  options.accuracy_pct = 1.0;
  const SettingsSweep a = run_settings_sweep(m, options);
  const SettingsSweep b = run_settings_sweep(m, options);
  ASSERT_TRUE(a.dynamics);
  ASSERT_EQ(a.rows.size(), b.rows.size());
  int engine_rows = 0;
  double previous = INFINITY;
  for (size_t i = 0; i < a.rows.size(); ++i) {
    const SweepRow& r = a.rows[i];
    EXPECT_EQ(r.variant, b.rows[i].variant);
    EXPECT_EQ(r.max_pct, b.rows[i].max_pct) << r.variant;
    if (r.engine == "analytic") {
      if (r.variant.starts_with("exact, tolerance")) {  // looser first
        EXPECT_LT(r.error(ErrorClass::position), previous) << r.variant;
        previous = r.error(ErrorClass::position);
        EXPECT_LE(r.tip_position_error, r.benchmark_error()) << r.variant;
      }
      continue;
    }
    ++engine_rows;
    EXPECT_EQ(r.repeats, 3);
    EXPECT_GT(r.cpu_s_per_cycle, 0.0);
    if (r.status != RunStatus::ok) continue;
    for (size_t k = 0; k < 3; ++k) EXPECT_LE(r.end_pct[k], r.max_pct[k] * (1 + 1e-12));
    EXPECT_TRUE(std::isfinite(r.energy_pct)) << r.variant;
  }
  EXPECT_EQ(engine_rows, 6);
  // The IFToMM limits on B0, per series (6 MuJoCo variants and the exact integrator): a limit
  // met is met by its row, with status ok; one not met says why.
  ASSERT_EQ(a.limits.size(), kBenchmarkLimits.size() * 7);
  for (const BenchmarkLimit& l : a.limits) {
    if (!l.met) {
      EXPECT_FALSE(l.why.empty()) << l.variant;
      continue;
    }
    EXPECT_EQ(l.row.status, RunStatus::ok) << l.variant;
    EXPECT_LE(l.row.benchmark_error(), l.limit) << l.variant;
    EXPECT_GT(l.run_cpu_seconds, 0.0) << l.variant;
  }
  // Shown in the console and the report.
  char* text = nullptr;
  size_t size = 0;
  std::FILE* console = open_memstream(&text, &size);
  print_sweep(a, console);
  std::fclose(console);
  EXPECT_NE(std::string(text, size).find("IFToMM accuracy limits"), std::string::npos);
  std::free(text);
  if (compare::find_report_assets({})) {
    std::ostringstream html;
    write_sweep_html(a, {}, html);
    EXPECT_NE(html.str().find("<h2>IFToMM accuracy limits</h2>"), std::string::npos);
  }
  ASSERT_EQ(a.selections.size(), 1u);
  ASSERT_TRUE(a.selections[0].found) << a.selections[0].summary();
  // Two identical sweeps: the same pick and the same fronts (they weigh the work, not the CPU
  // times, which differ between the two runs).
  EXPECT_EQ(a.selections[0].chosen.setting_label(), b.selections[0].chosen.setting_label());
  for (size_t i = 0; i < a.rows.size(); ++i)
    EXPECT_EQ(a.rows[i].pareto, b.rows[i].pareto) << a.rows[i].setting_label();
  EXPECT_NE(a.selections[0].summary().find("per simulated s"), std::string::npos);
}

// Why MuJoCo's Euler (and Bullet's multibody, the same semi-implicit Euler in joint coordinates)
// converges at first order on Andrews' squeezer, the coasting sewing machine and the motored
// slider-crank, and at second on A01: semi-implicit Euler, started half a step back and read by
// central differences, is the leapfrog (second order) only while the accelerations do not depend
// on the velocity. A velocity-dependent force is evaluated at the velocity half a step behind,
// an O(dt) error every step. The pendulum of A01 over 10 s has none (one hinge, constant
// inertia): second order; the same pendulum with a damper from P1 to a ground point: first order.
// (In joint coordinates a chain's Coriolis and centrifugal terms are such forces too;
// docs/dynamics.md.)
TEST(SweepEngines, SemiImplicitEulerLosesAnOrderToVelocityDependentForces) {
  // The bundled A01 over 10 s at 0.05 s, with a ground point G 3 m below the pivot.
  std::ifstream file(mechanism_path("iftomm_a01_pendulum"));
  std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"duration = 2000", "duration = 10"},
        {"interval = 0.5", "interval = 0.05"},
        {"points = { O = [0, 0] }", "points = { O = [0, 0], G = [0, -3] }"}}) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  const Mechanism free = parse_mechanism(text, "free.toml");
  text += R"(
[[spring]]
name = "drag"
links = ["ground", "pendulum"]
points = ["G", "P1"]
stiffness = 0
free_length = 0
damping = 0.2
)";
  const Mechanism damped = parse_mechanism(text, "damped.toml");
  for (const auto& [engine, variant] :
       {std::pair<const char*, const char*>{"mujoco", "Euler/Newton"},
        {"bullet", "multibody/MLCP Dantzig erp 1"}}) {
    for (const Mechanism* m : {&free, &damped}) {
      ReferenceLadder ladder(*m, {});
      std::vector<double> dts, errors;
      for (double dt : {8e-3, 4e-3, 2e-3, 1e-3}) {  // above the floor (auxiliary inertia)
        GridPoint p{engine, variant, dt, {}};
        for (const Variant& v : engine_variants(engine, true))
          if (v.name == variant) p.settings = v.settings(dt);
        const SweepRow r = evaluate_setting(*m, ladder, p);
        ASSERT_EQ(r.status, RunStatus::ok) << engine << " " << r.message;
        dts.push_back(r.dt);
        errors.push_back(r.error(ErrorClass::position));
      }
      const ConvergenceFit fit = convergence_order(dts, errors);
      const double expected = m == &free ? 2.0 : 1.0;
      EXPECT_NEAR(fit.order, expected, 0.3) << engine << " " << m->name << " " << fit.points;
    }
  }
}

}  // namespace
}  // namespace crosslink::methods

namespace crosslink::methods {
namespace {

// The largest error over its limit of a row, read from the row's own columns (forces only where
// the engine reads them; infinity where a class has no value), and whether it meets them.
double ratio_to(const SweepRow& r, const ClassLimits& limits) {
  double worst = 0.0;
  for (size_t k = 0; k < 4; ++k) {
    if (k == 3 && std::isnan(r.max_pct[k])) continue;
    worst = std::max(worst, std::isnan(r.max_pct[k]) ? INFINITY : r.max_pct[k] / limits.pct[k]);
  }
  if (!std::isnan(r.energy_pct)) worst = std::max(worst, r.energy_pct / limits.energy_pct);
  return worst;
}

// The ranking of a tiny sweep of all four engines (the crank-rocker at 1 and 1/2 degree of crank
// per step), at --accuracy 0.1 % and at the common tolerances, checked against the sweep's own
// rows: an engine ranked as meeting the limits has a row at the rank's setting that meets them
// and none at a coarser step; an engine ranked as not meeting them has no row that does; the
// ones that meet come first, by their row's CPU time; the others by their best row's ratio to the
// limits. The HTML table and the CSV's rank column list them in the same order.
TEST(SweepEngines, FourEnginesAreRankedByTheirOwnNumbers) {
  SettingsSweepOptions options;
  options.engines = {"mujoco", "bullet", "ode", "simbody"};
  options.dts = {h(), h() / 2};
  options.accuracy_pct = 0.1;
  SettingsSweep sweep = run_settings_sweep(crank_rocker(), options);
  const auto check = [&](const EngineRanking& ranking, const ClassLimits& limits) {
    ASSERT_EQ(ranking.engines.size(), 4u);
    int met = 0, unmet = 0;
    for (size_t i = 0; i < ranking.engines.size(); ++i) {
      const EngineRank& e = ranking.engines[i];
      SCOPED_TRACE(e.engine);
      double coarsest_meeting = 0.0, best_ratio = INFINITY;
      for (const SweepRow& r : sweep.rows) {
        if (r.engine != e.engine) continue;
        const double ratio = r.status == RunStatus::ok ? ratio_to(r, limits) : INFINITY;
        if (ratio <= 1.0) coarsest_meeting = std::max(coarsest_meeting, r.dt);
        best_ratio = std::min(best_ratio, ratio);
      }
      if (e.met) {
        ++met;
        EXPECT_EQ(unmet, 0) << "an engine that meets the limits after one that does not";
        EXPECT_LE(ratio_to(e.row, limits), 1.0);
        EXPECT_EQ(e.row.dt, coarsest_meeting);
        if (i > 0 && ranking.engines[i - 1].met) {
          EXPECT_LE(ranking.engines[i - 1].row.cost(), e.row.cost());
        }
      } else {
        ++unmet;
        EXPECT_EQ(coarsest_meeting, 0.0) << "a row meets the limits";
        EXPECT_DOUBLE_EQ(e.worst_ratio, best_ratio);
        if (i > 0 && !ranking.engines[i - 1].met) {
          EXPECT_LE(ranking.engines[i - 1].worst_ratio, e.worst_ratio);
        }
      }
    }
    EXPECT_EQ(met + unmet, 4);
  };
  // --accuracy 0.1 %: MuJoCo and Bullet meet it from 1/2 degree (docs/sweep.md), Simbody (its
  // forces at exact states, rates from poses 1 degree apart) from 1 degree.
  const EngineRanking at_accuracy = rank_engines(sweep);
  ASSERT_NO_FATAL_FAILURE(check(at_accuracy, ClassLimits::uniform(0.1)));
  EXPECT_GE(std::count_if(at_accuracy.engines.begin(), at_accuracy.engines.end(),
                          [](const EngineRank& e) { return e.met; }),
            2);
  // The common tolerances (position 0.01 % of peak): the time-stepping engines need 1/6 degree
  // (docs/sweep.md), so they never meet them here and are ranked after Simbody by how close
  // they come.
  sweep.accuracy_pct.reset();
  const EngineRanking at_tolerances = rank_engines(sweep);
  const ClassLimits common = common_tolerances(options.engines, false);
  EXPECT_EQ(common.pct[0], 0.01);
  EXPECT_EQ(common.pct[3], 0.05);  // MuJoCo's and Simbody's, tighter than Bullet's and ODE's
  ASSERT_NO_FATAL_FAILURE(check(at_tolerances, common));
  EXPECT_TRUE(std::any_of(at_tolerances.engines.begin(), at_tolerances.engines.end(),
                          [](const EngineRank& e) { return !e.met && e.has_row; }));

  // The report's table and the CSV's rank column, in the ranking's order.
  sweep.accuracy_pct = 0.1;
  std::ostringstream html, csv;
  write_sweep_html(sweep, {}, html);
  write_sweep_csv(sweep, csv);
  const std::string page = html.str();
  const size_t table = page.find("<table id=\"ranking\">");
  ASSERT_NE(table, std::string::npos);
  EXPECT_LT(table, page.find("Error against cost")) << "the ranking is at the top";
  size_t at = table;
  for (size_t i = 0; i < at_accuracy.engines.size(); ++i) {
    const std::string cells =
        fmt::format("<td>{}</td><td>{}</td>", i + 1, at_accuracy.engines[i].engine);
    const size_t found = page.find(cells, at);
    EXPECT_NE(found, std::string::npos) << cells;
    at = found;
  }
  std::istringstream lines(csv.str());
  std::string line;
  std::vector<std::string> ranked(4);
  while (std::getline(lines, line)) {
    const size_t comma = line.rfind(',');
    const std::string rank = line.substr(comma + 1);
    if (!rank.empty() && rank != "rank")
      ranked.at(std::stoul(rank) - 1) = line.substr(0, line.find(','));
  }
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(ranked[i], at_accuracy.engines[i].engine);
}

}  // namespace
// A sweep where no engine ran (a planetary train with an internal mesh and ODE, which says why)
// ranks none, and its rule writes no limit: before, the common tolerances of no engine were
// "inf % of peak".
TEST(SweepEngines, ASweepWithoutEnginesRanksNoneAndWritesNoLimit) {
  SettingsSweepOptions options;
  options.engines = {"ode"};
  options.dts = {1e-3};
  options.repeat = 1;
  // The sweep keeps a pointer to its mechanism: it lives as long as the sweep.
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/gears/planetary_fixed_ring.toml");
  const SettingsSweep sweep = run_settings_sweep(m, options);
  // The engine says why.
  EXPECT_EQ(std::count_if(sweep.skipped.begin(), sweep.skipped.end(),
                          [&](const std::string& s) { return s.starts_with("ode: "); }),
            1);
  const EngineRanking ranking = rank_engines(sweep);
  EXPECT_TRUE(ranking.engines.empty());
  EXPECT_EQ(ranking.rule, "no engine ran: nothing to rank");
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  print_sweep(sweep, file);
  std::rewind(file);
  std::string console;
  for (int c; (c = std::fgetc(file)) != EOF;) console += static_cast<char>(c);
  std::fclose(file);
  EXPECT_NE(console.find("no engine ran: nothing to rank"), std::string::npos) << console;
  EXPECT_EQ(console.find("inf"), std::string::npos) << console;
}

}  // namespace crosslink::methods
