// Bullet engine against the exact sweep: default settings on every bundled mechanism it can
// realise, the settings it reports, and the singular cases (flagged or reported, never silent).
#include <LinearMath/btScalar.h>
#include <gtest/gtest.h>

#include <iostream>
#include <numbers>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"
#include "tests/sim/bullet/agreement.h"

namespace crosslink {
namespace {

std::string path(const std::string& name) {
  return "mechanisms/" + name + ".toml";
}

std::string setting(const sim::EngineRun& run, const std::string& name) {
  for (const auto& [k, v] : run.settings)
    if (k == name) return v;
  return "<absent>";
}

int not_ok(const Trajectory& t) {
  int n = 0;
  for (PoseStatus s : t.status) n += s != PoseStatus::ok;
  return n;
}

TEST(Bullet, IsTheFloat64Build) {
  EXPECT_TRUE(btIsDoublePrecision());
}

class BulletDefaults : public ::testing::TestWithParam<std::string> {};

// Positions within 1e-4 of the mechanism's size, velocities within 0.1 % and accelerations
// within 1 % of each quantity's peak over the cycle.
TEST_P(BulletDefaults, AgreesWithTheAnalyticSweep) {
  const Mechanism m = load_mechanism(path(GetParam()));
  const auto engine = sim::make_bullet_engine();
  std::string why;
  ASSERT_TRUE(engine->supports(m, &why)) << why;
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = engine->run(m, ref, {});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_EQ(run.trajectory.method, "bullet");
  const test::Agreement a = test::agreement(m, ref, run.trajectory);
  EXPECT_GT(a.compared, ref.samples() * 9 / 10) << "too many flagged samples";
  EXPECT_LT(a.position, 1e-4);
  EXPECT_LT(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LT(a.acceleration, 1e-2) << a.worst_acceleration;
  std::cout << GetParam() << ": position " << a.position << " of size, velocity "
            << 100 * a.velocity << " % (" << a.worst_velocity << "), acceleration "
            << 100 * a.acceleration << " % (" << a.worst_acceleration << "), "
            << run.cost.wall_seconds_per_cycle << " s per cycle, " << run.cost.steps << " steps\n";
}

INSTANTIATE_TEST_SUITE_P(Bundled, BulletDefaults,
                         ::testing::Values("fourbar_crank_rocker", "slider_crank_offset",
                                           "sewing_machine", "quick_return", "sixbar_slider_guide",
                                           "stephenson_sixbar", "watt_sixbar", "wanzer_needle_bar",
                                           "wanzer_needle_bar_inversion1"));

// The polycentric hinge's range ends at two toggles where d(theta)/d(theta4) grows without
// bound; the link-angle driver is realised directly, and the run must say so.
TEST(Bullet, PolycentricHingeRunsWithItsLinkAngleDriver) {
  const Mechanism m = load_mechanism(path("polycentric_hinge"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_NE(run.message.find("link-angle driver"), std::string::npos) << run.message;
  // The sweep starts and ends exactly on the limits (flagged singular): the run covers the
  // usable samples only, and the ends keep the reference's flag.
  EXPECT_EQ(run.trajectory.status.front(), ref.status.front());
  EXPECT_EQ(run.trajectory.status.back(), ref.status.back());
  EXPECT_NE(run.message.find("usable samples"), std::string::npos) << run.message;
  // As the comparator: a sample next to a singular one is not in the verdict (there the start
  // from rest leaves Bullet's one-sided end samples 11 % and 2 % off in alpha;
  // docs/engines-measured.md).
  Trajectory judged = run.trajectory;
  for (int i = 0; i < ref.samples(); ++i)
    for (int j : {i - 1, i + 1})
      if (j >= 0 && j < ref.samples() && ref.status[static_cast<size_t>(j)] == PoseStatus::singular)
        judged.status[static_cast<size_t>(i)] = PoseStatus::singular;
  const test::Agreement a = test::agreement(m, ref, judged);
  EXPECT_GE(a.compared, ref.samples() - 4);
  EXPECT_LT(a.position, 1e-4);
  EXPECT_LT(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LT(a.acceleration, 1e-2) << a.worst_acceleration;
  std::cout << "polycentric_hinge: position " << a.position << " of size, velocity "
            << 100 * a.velocity << " % (" << a.worst_velocity << "), acceleration "
            << 100 * a.acceleration << " % (" << a.worst_acceleration << "), " << run.cost.steps
            << " steps\n";
}

// A change point that is not a parallelogram: Bullet may take either branch there, but a sample
// on another assembly mode than the reference is flagged, never passed on.
TEST(Bullet, OtherBranchAfterAChangePointIsFlagged) {
  const Mechanism m = load_mechanism(path("singular/fourbar_change_point_crank_rocker"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {});
  ASSERT_TRUE(run.ok) << run.message;
  const Eigen::VectorXd r = *ref.channel("angle.coupler"),
                        e = *run.trajectory.channel("angle.coupler");
  int jumped = 0;
  for (int i = 0; i < ref.samples(); ++i) {
    const auto row = static_cast<size_t>(i);
    jumped += run.trajectory.status[row] == PoseStatus::branch_jump;
    if (ref.status[row] != PoseStatus::ok || run.trajectory.status[row] != PoseStatus::ok) continue;
    EXPECT_LT(std::abs(std::remainder(r(i) - e(i), 2 * std::numbers::pi)), 1e-3) << "sample " << i;
  }
  std::cout << "change-point crank-rocker: " << jumped << " samples branch_jump\n";
}

TEST(Bullet, WanzerNeedleVelocityAtDiskAngleZero) {
  const Mechanism m = load_mechanism(path("wanzer_needle_bar"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {});
  ASSERT_TRUE(run.ok) << run.message;
  ASSERT_EQ(ref.along(0), 0.0);
  const double exact = (*ref.channel("vy.G"))(0), bullet = (*run.trajectory.channel("vy.G"))(0);
  std::cout << "Wanzer V_G at disk angle 0: bullet " << bullet * 1e3 << " mm/s, exact "
            << exact * 1e3 << " mm/s, Working Model -365 mm/s\n";
  RecordProperty("bullet_vy_G_mm_s", std::to_string(bullet * 1e3));
  EXPECT_NEAR(bullet, exact, 1e-3 * std::abs(exact));
  // Working Model's 365 mm/s is 4.5 % below the exact value: reported, not asserted.
}

TEST(Bullet, ReportsEverySetting) {
  const Mechanism m = load_mechanism(path("fourbar_crank_rocker"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run =
      sim::make_bullet_engine()->run(m, ref, {{"steps_per_sample", "3"}, {"erp", "0.9"}});
  for (const char* name : {"formulation", "solver", "dt", "steps_per_sample", "iterations", "erp",
                           "precision", "gap_threshold", "perturb_link"})
    EXPECT_NE(setting(run, name), "<absent>") << name;
  EXPECT_EQ(setting(run, "precision"), "float64");
  EXPECT_EQ(setting(run, "steps_per_sample"), "3");
  EXPECT_EQ(setting(run, "erp"), "0.9");
  const sim::EngineRun bad = sim::make_bullet_engine()->run(m, ref, {{"no_such", "1"}});
  EXPECT_FALSE(bad.ok);
}

TEST(Bullet, MultibodyFormulationAgreesOnTheCrankRocker) {
  const Mechanism m = load_mechanism(path("fourbar_crank_rocker"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {{"formulation", "multibody"}});
  ASSERT_TRUE(run.ok) << run.message;
  const test::Agreement a = test::agreement(m, ref, run.trajectory);
  EXPECT_LT(a.position, 1e-4);
  EXPECT_LT(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LT(a.acceleration, 1e-2) << a.worst_acceleration;
}

TEST(Bullet, PerturbedLinkChangesTheResult) {
  const Mechanism m = load_mechanism(path("fourbar_crank_rocker"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run =
      sim::make_bullet_engine()->run(m, ref, {{"perturb_link", "coupler:1.02"}});
  const test::Agreement a = test::agreement(m, ref, run.trajectory);
  EXPECT_GT(a.position, 1e-3);
}

TEST(Bullet, ChangePointIsFlaggedOrReported) {
  const Mechanism m = load_mechanism(path("fourbar_change_point"));
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {});
  EXPECT_TRUE(!run.ok || not_ok(run.trajectory) > 0) << run.message;
  EXPECT_FALSE(run.trajectory.events.empty());
}

// Driven past the end of its assembling range, the chain cannot follow: loop gap or
// divergence, reported.
TEST(Bullet, DrivenPastAnAssemblyLimitIsFlaggedOrReported) {
  const Mechanism m = load_mechanism(path("polycentric_hinge"));
  const AssemblingRange range = assembling_range(m);
  ASSERT_FALSE(range.full_cycle);
  SweepOptions beyond;
  beyond.range = std::make_pair(range.lower + 0.05, range.upper + 0.3);
  // Drive the engine on through the samples the chain cannot reach: mark them usable so the
  // engine runs there, and require its own watch (loop gap, lost driver) to say so.
  Trajectory driven = sweep(m, beyond);
  std::vector<int> past;
  for (int i = 0; i < driven.samples(); ++i)
    if (driven.status[static_cast<size_t>(i)] == PoseStatus::cannot_assemble) {
      driven.status[static_cast<size_t>(i)] = PoseStatus::ok;
      past.push_back(i);
    }
  ASSERT_FALSE(past.empty());
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, driven, {});
  const long watched = std::count_if(past.begin(), past.end(), [&](int i) {
    const PoseStatus s = run.trajectory.status[static_cast<size_t>(i)];
    return s == PoseStatus::loop_gap || s == PoseStatus::diverged;
  });
  EXPECT_TRUE(!run.ok || watched >= static_cast<long>(past.size()) / 2)
      << "driven past the limit, the engine's watch said nothing: " << run.message;
}

// A step the length of the sample interval on samples 20 degrees of crank apart (a dt longer than
// the interval is shortened to it, so the samples are coarsened instead).
TEST(Bullet, FarTooCoarseTimeStepIsFlaggedOrReported) {
  const Mechanism m = load_mechanism(path("fourbar_crank_rocker"));
  SweepOptions coarse;
  coarse.step = 20.0 * std::numbers::pi / 180.0;
  const Trajectory ref = sweep(m, coarse);
  const double interval = ref.time(1) - ref.time(0);
  const sim::EngineRun run =
      sim::make_bullet_engine()->run(m, ref, {{"dt", std::to_string(interval)}});
  EXPECT_TRUE(!run.ok || not_ok(run.trajectory) > 0) << run.message;
}

}  // namespace
}  // namespace crosslink
