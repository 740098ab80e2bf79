// MuJoCo engine against the exact solver (an independent method): every bundled mechanism over
// its whole sweep, the most accurate settings, the Wanzer needle bar's V_G, and the singular
// cases, which must end flagged or reported, never as silent numbers.
//
//   crank-rocker:  A (ground) --- B --- C --- D (ground), crank AB driven at 8 pi rad/s
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/mujoco/mujoco_engine.h"
#include "tests/common/mechanisms.h"

namespace crosslink::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

std::string mechanism_path(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml";
}

bool usable_sample(PoseStatus s) {
  return s == PoseStatus::ok;
}

// Largest difference of every channel over the samples both methods call usable, from the
// reference's first usable sample to its next unusable or singular position (rcond below 1e-6:
// beyond a change point, which branch is followed is a choice, not an error), as a fraction of the
// channel's peak. A channel identically zero in the reference is measured against the peak of its
// quantity over the whole mechanism (e.g. all links' alpha), and when that is zero too (a
// parallelogram's alpha), against the largest point speed or acceleration, per mechanism size for
// angular channels.
struct Agreement {
  double position = 0.0;                      // / mechanism size
  double angle = 0.0;                         // rad
  double velocity = 0.0, acceleration = 0.0;  // / peak
  std::string worst_velocity, worst_acceleration;
  int compared = 0, usable_reference = 0;
};

Agreement agreement(const Mechanism& m, const Trajectory& exact, const Trajectory& engine) {
  Agreement a;
  // From the first usable sample (a range-limited sweep starts with a flagged sample exactly on
  // the assembly limit) to the next unusable or singular one.
  int begin = 0;
  while (begin < exact.samples() && exact.status[static_cast<size_t>(begin)] != PoseStatus::ok)
    ++begin;
  int last = exact.samples();
  for (int i = begin; i < exact.samples(); ++i)
    if (exact.status[static_cast<size_t>(i)] != PoseStatus::ok || exact.rcond(i) < 1e-6) {
      last = i;
      break;
    }
  // Samples next to a singular one stay out, as they do of the comparator's verdicts (metrics.h,
  // K): the polycentric hinge's sample 1 is 1 degree past the assembly limit where its driver,
  // the link DE's angle, turns back; its rates go as one over the root of the distance (a.G
  // falls from 0.65 to 0.24 m/s^2 in the next degree), and MuJoCo, driving that angle, has its
  // constraints near their singularity there (a.G 1.07 against 0.65; 0.018 % of peak off at
  // sample 2).
  std::vector<int> rows;
  for (int i = begin; i < last; ++i) {
    ++a.usable_reference;
    if (usable_sample(engine.status[static_cast<size_t>(i)]) && !exact.beside_singular(i))
      rows.push_back(i);
  }
  a.compared = static_cast<int>(rows.size());
  auto peak_of = [&](const Eigen::VectorXd& v) {
    double p = 0.0;
    for (int i : rows) p = std::max(p, std::abs(v(i)));
    return p;
  };
  for (const std::string& name : exact.channel_names()) {
    // Motion only: the forces are compared where the engine reads them.
    const std::optional<Eigen::VectorXd> engine_column = engine.channel(name);
    if (!engine_column) continue;
    const Eigen::VectorXd r = *exact.channel(name), e = *engine_column;
    const std::string prefix = name.substr(0, name.find('.'));
    double family = 0.0;
    for (const std::string& other : exact.channel_names())
      if (other.substr(0, other.find('.')) == prefix)
        family = std::max(family, peak_of(*exact.channel(other)));
    const bool angular = prefix == "omega" || prefix == "alpha";
    const bool accel = Trajectory::quantity_of(name) == Quantity::acceleration;
    double largest = 0.0;
    for (const std::string& p : exact.point_names)
      largest = std::max(largest, peak_of(*exact.channel((accel ? "a." : "v.") + p)));
    double peak = peak_of(r), error = 0.0;
    if (peak <= 1e-9 * family) peak = family;
    if (peak <= 1e-9 * largest) peak = angular ? largest / m.size() : largest;
    for (int i : rows) error = std::max(error, std::abs(r(i) - e(i)));
    switch (Trajectory::quantity_of(name)) {
      case Quantity::position:
        a.position = std::max(a.position, error / m.size());
        break;
      case Quantity::angle:
        a.angle = std::max(a.angle, error);
        break;
      case Quantity::velocity:
        if (peak > 0 && error / peak > a.velocity) {
          a.velocity = error / peak;
          a.worst_velocity = name;
        }
        break;
      case Quantity::acceleration:
        if (peak > 0 && error / peak > a.acceleration) {
          a.acceleration = error / peak;
          a.worst_acceleration = name;
        }
        break;
      case Quantity::jerk:
      case Quantity::force:
      case Quantity::torque:
      case Quantity::energy:
        break;
    }
  }
  return a;
}

class Bundled : public ::testing::TestWithParam<std::string> {};

// Default settings: positions within 1e-4 of the size, velocities 0.1 % and accelerations 1 %
// of each channel's peak, over the whole sweep.
TEST_P(Bundled, AgreesWithExactSweepAtDefaults) {
  const Mechanism m = load_mechanism(mechanism_path(GetParam()));
  const auto engine = make_mujoco_engine();
  std::string why;
  if (!engine->supports(m, &why)) GTEST_SKIP() << "MuJoCo cannot realise it: " << why;
  const Trajectory exact = sweep(m);
  const EngineRun run = engine->run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  const Agreement a = agreement(m, exact, run.trajectory);
  // Flags may only mark a few samples (singular positions), never hide the sweep.
  EXPECT_GE(a.compared, a.usable_reference * 9 / 10) << run.message;
  EXPECT_LE(a.position, 1e-4);
  EXPECT_LE(a.angle, 1e-4);
  EXPECT_LE(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LE(a.acceleration, 1e-2) << a.worst_acceleration;
  std::printf(
      "%-24s pos %.2e size, vel %.4f %% (%s), acc %.4f %% (%s), %.4f s per cycle, %ld steps\n",
      GetParam().c_str(), a.position, 100 * a.velocity, a.worst_velocity.c_str(),
      100 * a.acceleration, a.worst_acceleration.c_str(), run.cost.wall_seconds_per_cycle,
      run.cost.steps);
}

INSTANTIATE_TEST_SUITE_P(Mechanisms, Bundled, ::testing::ValuesIn(test::bundled_stems()),
                         [](const auto& info) { return info.param; });

// The most accurate settings (a quarter of the default step angle, so 16x smaller errors).
TEST(CrankRocker, MostAccurateAccelerationsWithinOneHundredthPercent) {
  const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  const Trajectory exact = sweep(m);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {{"max_step_angle", "0.000625"}});
  ASSERT_TRUE(run.ok) << run.message;
  const Agreement a = agreement(m, exact, run.trajectory);
  EXPECT_EQ(a.compared, exact.samples());
  EXPECT_LE(a.acceleration, 1e-4) << a.worst_acceleration;
  EXPECT_LE(a.velocity, 1e-5) << a.worst_velocity;
}

// Notes 002: Working Model gave V_G = 365 mm/s down at disk angle 0; instantaneous centres 370.
TEST(WanzerNeedleBar, NeedleVelocityAtDiskAngleZero) {
  const Mechanism m = load_mechanism(mechanism_path("wanzer_needle_bar"));
  const Trajectory exact = sweep(m);
  ASSERT_NEAR(exact.along(0), 0.0, 1e-12);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  const double vg_exact = (*exact.channel("vy.G"))(0) * 1000.0;
  const double vg_mujoco = (*run.trajectory.channel("vy.G"))(0) * 1000.0;
  std::printf(
      "Wanzer V_G at disk 0: exact %.3f mm/s, MuJoCo %.3f mm/s (%.4f %%), Working Model "
      "-365 mm/s (%.2f %% from exact)\n",
      vg_exact, vg_mujoco, 100 * (vg_mujoco - vg_exact) / vg_exact,
      100 * (-365.0 - vg_exact) / vg_exact);
  EXPECT_NEAR(vg_mujoco, vg_exact, 1e-3 * std::abs(vg_exact));
  EXPECT_LT(vg_exact, 0.0);  // down
}

// Change point (a + d = b + c): MuJoCo passes it silently; the run must flag it.
TEST(Singular, ChangePointIsFlagged) {
  const Mechanism m = load_mechanism(mechanism_path("fourbar_change_point"));
  SweepOptions full;
  full.range = std::make_pair(m.drivers[0].start, m.drivers[0].start + 2.0 * std::numbers::pi);
  const Trajectory exact = sweep(m, full);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {});
  int flagged_near_180 = 0;
  for (int i = 0; i < exact.samples(); ++i)
    if (run.trajectory.status[static_cast<size_t>(i)] != PoseStatus::ok &&
        std::abs(exact.along(i) - 180 * kDeg) < 2 * kDeg)
      ++flagged_near_180;
  EXPECT_GE(flagged_near_180, 1) << run.message;
}

// The polycentric hinge's sweep starts and ends with a sample exactly on an assembly limit
// (flagged singular): the run covers the usable samples only, the two ends keep the reference's
// flag with no engine value, and the rest agrees at the comparator's default tolerances.
TEST(Singular, RangeLimitedSweepRunsOverItsUsableSamples) {
  const Mechanism m = load_mechanism(mechanism_path("polycentric_hinge"));
  const Trajectory exact = sweep(m);
  ASSERT_NE(exact.status.front(), PoseStatus::ok);
  ASSERT_NE(exact.status.back(), PoseStatus::ok);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_EQ(run.trajectory.status.front(), exact.status.front());
  EXPECT_EQ(run.trajectory.status.back(), exact.status.back());
  EXPECT_EQ(run.trajectory.angle.row(0).norm(), 0.0);
  EXPECT_NE(run.message.find("usable samples"), std::string::npos) << run.message;
  const Agreement a = agreement(m, exact, run.trajectory);
  EXPECT_GE(a.compared, a.usable_reference - 4);
  EXPECT_LE(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LE(a.acceleration, 1e-2) << a.worst_acceleration;
}

// A change point that is not a parallelogram: the engine may take either branch there, but a
// sample on another assembly mode than the reference is flagged, never passed on.
TEST(Singular, OtherBranchAfterAChangePointIsFlagged) {
  const Mechanism m = load_mechanism(mechanism_path("singular/fourbar_change_point_crank_rocker"));
  const Trajectory exact = sweep(m);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  const Eigen::VectorXd r = *exact.channel("angle.coupler"),
                        e = *run.trajectory.channel("angle.coupler");
  for (int i = 0; i < exact.samples(); ++i) {
    if (exact.status[static_cast<size_t>(i)] != PoseStatus::ok ||
        run.trajectory.status[static_cast<size_t>(i)] != PoseStatus::ok)
      continue;
    EXPECT_LT(std::abs(std::remainder(r(i) - e(i), 2 * std::numbers::pi)), 1e-3) << "sample " << i;
  }
}

// A non-Grashof four-bar (s + l > p + q) driven at constant speed through a whole turn: past
// its assembly limit the loop cannot close.
TEST(Singular, DrivenPastAssemblyLimitIsFlaggedOrReported) {
  const Mechanism m = parse_mechanism(R"(
name = "non-Grashof four-bar"
[units]
length = "m"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], D = [0.10, 0] }
[[link]]
name = "crank"
points = { A = [0, 0], B = [0.08, 0] }
pose = [0, 0, 60]
[[link]]
name = "coupler"
points = { B = [0, 0], C = [0.05, 0] }
pose = [0.04, 0.0693, -10]
[[link]]
name = "rocker"
points = { D = [0, 0], C = [0.07, 0] }
pose = [0.10, 0, 100]
[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"
[[joint]]
type = "revolute"
links = ["crank", "coupler"]
point = "B"
[[joint]]
type = "revolute"
links = ["coupler", "rocker"]
point = "C"
[[joint]]
type = "revolute"
links = ["ground", "rocker"]
point = "D"
[driver]
type = "joint_angle"
joint = "A"
to = "B"
start = 60
speed = 60
speed_unit = "rpm"
)",
                                      "non_grashof.toml");
  SweepOptions full;
  full.range = std::make_pair(m.drivers[0].start, m.drivers[0].start + 2.0 * std::numbers::pi);
  const Trajectory exact = sweep(m, full);
  ASSERT_NE(exact.status.back(), PoseStatus::ok) << "the chain should not assemble everywhere";
  // Drive the engine on through the samples the chain cannot reach: mark them usable so the
  // engine runs there, and require its own watch (loop gap, lost driver) to say so.
  Trajectory driven = exact;
  std::vector<int> past;
  for (int i = 0; i < driven.samples(); ++i)
    if (driven.status[static_cast<size_t>(i)] == PoseStatus::cannot_assemble) {
      driven.status[static_cast<size_t>(i)] = PoseStatus::ok;
      past.push_back(i);
    }
  ASSERT_FALSE(past.empty());
  const EngineRun run = make_mujoco_engine()->run(m, driven, {});
  const long watched = std::count_if(past.begin(), past.end(), [&](int i) {
    const PoseStatus s = run.trajectory.status[static_cast<size_t>(i)];
    return s == PoseStatus::loop_gap || s == PoseStatus::diverged;
  });
  EXPECT_TRUE(!run.ok || watched >= static_cast<long>(past.size()) / 2)
      << "driven past the limit, the engine's watch said nothing: " << run.message;
  std::printf("past the assembly limit: ok=%d, %ld of %zu samples past it flagged; %s\n", run.ok,
              watched, past.size(), run.message.c_str());
}

// A time step far too coarse (30 degrees of crank per step) must not pass silently.
TEST(Singular, CoarseTimeStepIsFlaggedOrReported) {
  const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  SweepOptions coarse;
  coarse.step = 30 * kDeg;
  const Trajectory exact = sweep(m, coarse);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {{"dt", "1"}});
  const long bad = std::count_if(run.trajectory.status.begin(), run.trajectory.status.end(),
                                 [](PoseStatus s) { return s != PoseStatus::ok; });
  EXPECT_TRUE(!run.ok || bad > 0) << "no flag, no divergence: " << run.message;
  std::printf("coarse step: ok=%d, %ld of %d samples flagged; %s\n", run.ok, bad, exact.samples(),
              run.message.c_str());
}

// The agreement check can fail: a coupler 2 % too long is a wrong model.
TEST(Settings, PerturbedLinkDisagrees) {
  const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  const Trajectory exact = sweep(m);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {{"perturb_link", "coupler:1.02"}});
  ASSERT_TRUE(run.ok) << run.message;
  const Agreement a = agreement(m, exact, run.trajectory);
  EXPECT_EQ(a.compared, exact.samples()) << "a valid linkage, only not the defined one";
  EXPECT_GT(a.position, 1e-3);
}

TEST(Settings, EveryDefaultIsReportedAndOverridesApply) {
  const Mechanism m = load_mechanism(mechanism_path("fourbar_crank_rocker"));
  const Trajectory exact = sweep(m);
  const EngineRun run =
      make_mujoco_engine()->run(m, exact, {{"dt", "1e-4"}, {"integrator", "implicit"}});
  ASSERT_TRUE(run.ok) << run.message;
  auto value = [&](const std::string& name) {
    for (const auto& [key, v] : run.settings)
      if (key == name) return v;
    return std::string("<missing>");
  };
  for (const char* name :
       {"dt", "integrator", "solver", "iterations", "tolerance", "solref", "solimp",
        "driver_solref", "driver_solimp", "gap_threshold", "perturb_link"})
    EXPECT_NE(value(name), "<missing>") << name;
  EXPECT_EQ(value("integrator"), "implicit");
  // 1e-4 rounded down to divide the 1-degree sample interval (1/1440 s): 7 steps.
  EXPECT_EQ(value("steps_per_sample"), "7");
  // A whole usable cycle is periodic: 8 pre-roll steps before the first sample, 8 after the last.
  EXPECT_EQ(run.cost.steps, 7 * (exact.samples() - 1) + 2 * 8);
  const EngineRun wrong = make_mujoco_engine()->run(m, exact, {{"time_step", "1e-4"}});
  EXPECT_FALSE(wrong.ok);
  EXPECT_NE(wrong.message.find("time_step"), std::string::npos);
}

// The export is the runs' scene (test_mjcf_export.cpp runs it alone): contacts off, the loops
// closed by <connect>, sliders as slide joints.
TEST(Export, MjcfIsTheRunsScene) {
  const Mechanism m = load_mechanism(mechanism_path("sewing_machine"));
  const std::string xml = mujoco_mjcf(m, sweep(m), {});
  EXPECT_NE(xml.find("<connect"), std::string::npos);
  EXPECT_NE(xml.find("contact=\"disable\""), std::string::npos);
  EXPECT_NE(xml.find("gravity=\"0 0 0\""), std::string::npos);
  EXPECT_NE(xml.find("type=\"slide\""), std::string::npos);
}

}  // namespace
}  // namespace crosslink::sim
