// Stability catalogue, engine side (docs/sweep.md): where the engines' closed loops cannot be
// trusted, the run must say so (flag the samples or report divergence), and the comparator must
// keep those samples out of its verdicts.
//
//   singular mechanisms  mechanisms/singular/*.toml and the bundled change-point four-bar,
//                        driven through a whole driver turn: past an assembly limit the chain
//                        cannot close (the analytic solver says cannot_assemble), at a change
//                        point or toggle the Jacobian is singular
//   coarse time step     30 degrees of crank per step on the crank-rocker
//   soft constraints     MuJoCo's own default solref "0.02 1" (engine-notes: 1.5 cm loop gap,
//                        67 % of peak in the rocker's omega)
//   forward dynamics     IFToMM A02 through its singular positions at steps too coarse, every
//                        MuJoCo integrator and Bullet formulation (the default step:
//                        tests/sim/*/test_*_dynamics.cpp)
// Expectations come from the analytic solver and closed-form geometry, never stored output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/loader.h"
#include "compare/comparison.h"
#include "methods/engines.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"

namespace crosslink::methods {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

std::string source(const std::string& relative) {
  return (fs::path(CROSSLINK_SOURCE_DIR) / relative).string();
}

std::vector<std::string> singular_files() {
  std::vector<std::string> files = {source("mechanisms/fourbar_change_point.toml")};
  const fs::path dir = source("mechanisms/singular");
  if (fs::is_directory(dir))
    for (const auto& entry : fs::directory_iterator(dir))
      if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// Every engine of the engine table (methods/engines.h).
std::vector<std::string> engines() {
  return engine_names();
}

// The reference through a whole driver turn for a constant-speed crank that cannot turn fully
// (without a range of its own), so it is driven past its limits; else the file's own sweep.
MethodRun whole_turn_reference(const Mechanism& m) {
  SweepOptions options;
  if (!m.drivers[0].range && m.drivers[0].angular() &&
      m.drivers[0].law.kind == MotionLaw::Kind::constant_speed && !assembling_range(m).full_cycle) {
    const double direction = m.drivers[0].law.speed < 0.0 ? -1.0 : 1.0;
    const double a = m.drivers[0].start,
                 b = m.drivers[0].start + direction * 2.0 * std::numbers::pi;
    options.range = std::make_pair(std::min(a, b), std::max(a, b));
  }
  return run_reference(m, options);
}

// The comparator keeps every sample that either side flagged out of every verdict.
void expect_flagged_samples_out_of_verdicts(const Comparison& cmp, const std::string& what) {
  const Trajectory& ref = cmp.reference().trajectory;
  for (const ChannelResult& c : cmp.channels) {
    const MethodRun* run = cmp.method(c.method);
    ASSERT_NE(run, nullptr);
    for (size_t k = 0; k < c.metrics.in_verdict.size(); ++k)
      if (!usable(ref.status[k]) || !usable(run->trajectory.status[k])) {
        ASSERT_FALSE(c.metrics.in_verdict[k])
            << what << ": " << c.metrics.channel << " sample " << k << " is flagged but judged";
      }
  }
}

class SingularCatalogue : public ::testing::TestWithParam<std::string> {};

TEST_P(SingularCatalogue, EnginesFlagWhatTheAnalyticSolverCannotUse) {
  const Mechanism m = load_mechanism(GetParam());
  const MethodRun reference = whole_turn_reference(m);
  const Trajectory& ref = reference.trajectory;
  const auto unusable =
      std::count_if(ref.status.begin(), ref.status.end(), [](PoseStatus s) { return !usable(s); });
  for (const std::string& engine : engines()) {
    const MethodRun run = run_method(engine, m, reference);
    if (!run.available) continue;  // the engine cannot realise it: said so, nothing to check
    const std::string what = fs::path(GetParam()).stem().string() + " / " + engine;
    // Where the chain cannot close, or the Jacobian is singular, the run reports divergence or
    // flags a sample within two samples (engines sample between reference values).
    if (run.ok && unusable > 0) {
      const int n = ref.samples();
      for (int k = 0; k < n; ++k) {
        if (usable(ref.status[static_cast<size_t>(k)])) continue;
        bool flagged = false;
        for (int j = std::max(0, k - 2); j <= std::min(n - 1, k + 2); ++j)
          flagged = flagged || !usable(run.trajectory.status[static_cast<size_t>(j)]);
        EXPECT_TRUE(flagged) << what << ": the reference says " << to_string(ref.status[k])
                             << " at driver " << ref.along(k) / kDeg
                             << " deg but the engine flags nothing near it (" << run.message << ")";
        if (!flagged) break;
      }
    }
    // At each singular position the sweep met between samples (a change point or a toggle, an
    // event located to ~1e-12), an engine may take either branch: it must flag a sample within
    // two sample steps of it, or report divergence, or stay on the reference's branch (every
    // later usable sample within 1 % of peak in position). Never a silent branch change.
    const double step = std::abs(ref.along(1) - ref.along(0));
    for (const Trajectory::Event& e : ref.events) {
      if (e.kind != PoseStatus::singular || !run.ok) continue;
      bool flagged = false;
      for (int k = 0; k < ref.samples(); ++k)
        flagged = flagged || (std::abs(ref.along(k) - e.driver) <= 2.5 * step &&
                              !usable(run.trajectory.status[static_cast<size_t>(k)]));
      if (flagged) continue;
      double after = 0.0;  // largest position-class error after the event [% of peak]
      const Comparison c =
          compare_runs(m, {reference, run}, Tolerances(engine_tolerances(false), m.tolerances));
      for (const ChannelResult& r : c.channels) {
        if (r.metrics.quantity != Quantity::position && r.metrics.quantity != Quantity::angle)
          continue;
        for (int k = 0; k < ref.samples(); ++k)
          if (r.metrics.in_verdict[static_cast<size_t>(k)] &&
              (ref.along(k) - e.driver) * (ref.along(1) - ref.along(0)) > 0.0)
            after = std::max(after, std::abs(r.metrics.pct_of_peak(k)));
      }
      EXPECT_LT(after, 1.0) << what << ": " << e.message << " at driver " << e.driver / kDeg
                            << " deg: nothing flagged near it, and afterwards the engine is "
                            << after << " % of peak off in position (another branch)";
    }
    const Comparison cmp =
        compare_runs(m, {reference, run}, Tolerances(engine_tolerances(false), m.tolerances));
    if (run.ok)
      expect_flagged_samples_out_of_verdicts(cmp, what);
    else
      EXPECT_FALSE(cmp.pass()) << what << ": a diverged run must fail the comparison";
    const auto flagged = std::count_if(run.trajectory.status.begin(), run.trajectory.status.end(),
                                       [](PoseStatus st) { return !usable(st); });
    std::printf(
        "%s: ok=%d, %ld reference samples unusable, %zu reference events, %ld samples "
        "flagged by the engine; %s\n",
        what.c_str(), run.ok, static_cast<long>(unusable), ref.events.size(),
        static_cast<long>(flagged), run.message.c_str());
  }
}

INSTANTIATE_TEST_SUITE_P(Files, SingularCatalogue, ::testing::ValuesIn(singular_files()),
                         [](const auto& info) {
                           std::string name = fs::path(info.param).stem().string();
                           std::replace_if(
                               name.begin(), name.end(), [](char c) { return !std::isalnum(c); },
                               '_');
                           return name;
                         });

// Each engine at a time step too coarse to be stable (30 degrees of crank per step): the run
// flags samples or reports divergence; it never passes as an ordinary result. Simbody's
// integrator controls its own error (251 internal steps over the cycle here), so its positions
// stay exact (8e-8 % of peak) and nothing is flagged, but its rates, differenced over samples
// 30 degrees apart, are 10.2 % (velocity) and 19.4 % (acceleration) off: its verdict fails it.
TEST(Stability, CoarseTimeStepIsFlaggedOrDiverges) {
  const Mechanism m = load_mechanism(source("mechanisms/fourbar_crank_rocker.toml"));
  SweepOptions coarse;
  coarse.step = 30 * kDeg;
  ReferenceLadder ladder(m, coarse);
  for (const std::string& engine : engines()) {
    const SweepRow row = evaluate_setting(m, ladder, {engine, "default", ladder.interval(), {}});
    if (engine != "simbody") {
      EXPECT_NE(row.status, RunStatus::ok)
          << engine << " at dt " << row.dt << " s: errors " << row.max_pct[0] << " / "
          << row.max_pct[1] << " / " << row.max_pct[2] << " % of peak, " << row.message;
    }
    EXPECT_FALSE(row.meets(10.0)) << engine;
  }
}

// MuJoCo's default (soft) constraints: the loop opens by about 1.5 cm (engine-notes). With the
// gap watch on, every such sample is flagged; with it off, the verdict fails on large errors.
TEST(Stability, MujocoDefaultSoftConstraintsFailTheVerdict) {
  const Mechanism m = load_mechanism(source("mechanisms/fourbar_crank_rocker.toml"));
  const MethodRun reference = run_reference(m);
  const sim::Settings soft = {{"solref", "0.02 1"}, {"solimp", "0.9 0.95 0.001 0.5 2"}};

  const MethodRun watched = run_method("mujoco", m, reference, soft);
  ASSERT_TRUE(watched.available);
  double gap = 0.0;
  for (Eigen::Index k = 0; k < watched.trajectory.loop_gap.size(); ++k)
    gap = std::max(gap, watched.trajectory.loop_gap(k));
  EXPECT_GT(gap, 1e-3) << "engine-notes: about 1.5 cm";
  const long flagged =
      std::count_if(watched.trajectory.status.begin(), watched.trajectory.status.end(),
                    [](PoseStatus s) { return s == PoseStatus::loop_gap; });
  EXPECT_GT(flagged, 0) << watched.message;
  expect_flagged_samples_out_of_verdicts(
      compare_runs(m, {reference, watched}, Tolerances(engine_tolerances(false), m.tolerances)),
      "soft, watched");

  sim::Settings unwatched = soft;
  unwatched.emplace_back("gap_threshold", "1");  // judge every sample
  const MethodRun judged = run_method("mujoco", m, reference, unwatched);
  ASSERT_TRUE(judged.ok) << judged.message;
  const Comparison cmp =
      compare_runs(m, {reference, judged}, Tolerances(engine_tolerances(false), m.tolerances));
  EXPECT_FALSE(cmp.pass());
  double omega_rocker = 0.0;
  for (const ChannelResult& c : cmp.channels)
    if (c.metrics.channel == "omega.rocker") omega_rocker = c.metrics.max_pct_of_peak;
  EXPECT_GT(omega_rocker, 10.0) << "engine-notes: 67 % of peak";
  std::printf("soft MuJoCo: gap %.3g m, %ld samples flagged; omega.rocker %.3g %% of peak\n", gap,
              flagged, omega_rocker);
}

// IFToMM A02 (five bars under gravity, 10 s, seven passages through the position where every
// bar is parallel) at steps too coarse for its motion: 0.1, 0.05 and 0.025 s, 0.6 to 0.15 rad
// per step at the fastest bar. Each MuJoCo integrator and each Bullet formulation either reports
// a divergence, flags samples (beyond the configuration's own `singular` ones: the comparator
// keeps them out of its verdicts), or is failed by the comparator at the default tolerances;
// none passes. Some runs are reported only by the verdict: MuJoCo's RK4 at 0.1 s keeps its loops
// closed and its energy within the engine's 1e-3 watch, B0 0.17 m off.
TEST(Stability, DynamicsAtACoarseStepIsReported) {
  const Mechanism m = load_mechanism(source("mechanisms/iftomm_a02_double_fourbar.toml"));
  const MethodRun reference = run_simulation(m, {.interval = 0.1});
  ASSERT_TRUE(reference.ok) << reference.message;
  const std::vector<std::pair<std::string, sim::Settings>> variants = {
      {"mujoco", {{"integrator", "Euler"}}},
      {"mujoco", {{"integrator", "implicit"}}},
      {"mujoco", {{"integrator", "RK4"}}},
      {"bullet", {{"formulation", "rigid"}}},
      {"bullet", {{"formulation", "multibody"}}}};
  for (const auto& [engine, variant] : variants)
    for (const char* dt : {"0.1", "0.05", "0.025"}) {
      sim::Settings settings = variant;
      settings.emplace_back("dt", dt);
      const MethodRun run = run_method(engine, m, reference, settings);
      const std::string what = engine + " " + variant.front().second + " at dt " + dt;
      ASSERT_TRUE(run.available) << what;
      const long flagged =
          std::count_if(run.trajectory.status.begin(), run.trajectory.status.end(),
                        [](PoseStatus s) { return !usable(s) && s != PoseStatus::singular; });
      const Comparison cmp = compare_runs(m, {reference, run}, default_tolerances(m));
      std::printf("%s: %s, %ld samples flagged, verdict %s\n", what.c_str(),
                  run.ok ? "finished" : "diverged", flagged, cmp.pass() ? "PASS" : "FAIL");
      EXPECT_TRUE(!run.ok || flagged > 0 || !cmp.pass()) << what << ": " << run.message;
      expect_flagged_samples_out_of_verdicts(cmp, what);
    }
}

}  // namespace
}  // namespace crosslink::methods
