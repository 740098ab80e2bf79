// The first instant of a motion (issue 35, item 5): every bundled forward-dynamics case released
// with nonzero rates, on each engine, its first sample (t = 0: positions, rates, accelerations,
// reactions) against the exact one. The exact acceleration and reactions at t = 0 come from the
// equations of motion at the initial state (analytic/dynamics), an independent source; an engine
// starts on the exact state, so its first sample is its own equations there, or its differences
// over its first steps, never a value taken from the reference. A released case is the bundled
// file with each free coordinate's rate made nonzero (a rate of 0 is set to one of its own: a
// motion released at rest has no velocity terms at t = 0, which is how MuJoCo's missing ones went
// unseen) and its duration cut to two sample intervals.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "sim/bullet/bullet_engine.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"
#include "sim/simbody/simbody_engine.h"

namespace crosslink::sim {
namespace {

namespace fs = std::filesystem;

// The scaling cases (A02 with N = 10 and 40 four-bars) repeat A02's check at a cost: slow.
bool slow_case(const std::string& file) {
  return file.find("scaling/") != std::string::npos;
}

// The bundled definitions with a [dynamics] table, relative to the source folder, sorted.
std::vector<std::string> dynamics_cases() {
  std::vector<std::string> out;
  const fs::path root = fs::path(CROSSLINK_SOURCE_DIR) / "mechanisms";
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (entry.path().extension() != ".toml") continue;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    if (text.str().find("\n[dynamics]") == std::string::npos) continue;
    // Joint friction: no engine runs it yet (compare.friction.engines_refuse).
    if (entry.path().parent_path().filename() == "friction") continue;
    const std::string file = fs::relative(entry.path(), CROSSLINK_SOURCE_DIR).string();
#ifdef CROSSLINK_SLOW_TESTS
    if (slow_case(file)) out.push_back(file);
#else
    if (!slow_case(file)) out.push_back(file);
#endif
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The case released with nonzero rates over two sample intervals: a coordinate released at rest
// gets 3 rad/s (an angle; the second -2 rad/s, the two crossing) or half its size a second (a
// slider), the speeds of the bundled cases' own motions.
Mechanism released(const std::string& file) {
  Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/" + file);
  DynamicsCase& c = *m.dynamics;
  c.duration = 2.0 * c.interval;
  for (int d = 0; d < c.coordinate_count(); ++d) {
    FreeCoordinate& f = d == 0 ? c : c.others[static_cast<size_t>(d - 1)];
    if (f.rate != 0.0) continue;
    const bool slider = m.drivers[static_cast<size_t>(d)].type == DriverType::slider;
    f.rate = slider ? 0.5 * m.size() : (d == 0 ? 3.0 : -2.0);
  }
  return m;
}

std::unique_ptr<Engine> engine_named(const std::string& name) {
  if (name == "mujoco") return make_mujoco_engine();
  if (name == "bullet") return make_bullet_engine();
  if (name == "ode") return make_ode_engine();
  return make_simbody_engine();
}

// The first sample's worst differences, each over the exact sample's own magnitude of its kind
// (positions over the mechanism's size).
struct FirstErrors {
  double position = 0.0, velocity = 0.0, acceleration = 0.0, reaction = 0.0;
  bool reactions = false;
};

double worst_over(int i, const Eigen::MatrixXd& run_a, const Eigen::MatrixXd& run_b,
                  const Eigen::MatrixXd& ref_a, const Eigen::MatrixXd& ref_b, double& peak) {
  double worst = 0.0;
  for (Eigen::Index c = 0; c < ref_a.cols(); ++c) {
    worst = std::max(worst, std::hypot(run_a(i, c) - ref_a(i, c), run_b(i, c) - ref_b(i, c)));
    peak = std::max(peak, std::hypot(ref_a(i, c), ref_b(i, c)));
  }
  return worst;
}

FirstErrors sample_errors(const Mechanism& m, const Trajectory& ref, const Trajectory& run, int i) {
  FirstErrors e;
  double unused = 0.0, v_peak = 0.0, a_peak = 0.0, f_peak = 0.0;
  e.position = worst_over(i, run.x, run.y, ref.x, ref.y, unused) / m.size();
  // Angular rates count as the speed of a point at the mechanism's size from the link's pivot.
  double velocity = worst_over(i, run.vx, run.vy, ref.vx, ref.vy, v_peak);
  double acceleration = worst_over(i, run.ax, run.ay, ref.ax, ref.ay, a_peak);
  for (Eigen::Index l = 0; l < ref.omega.cols(); ++l) {
    e.position = std::max(e.position, std::abs(run.angle(i, l) - ref.angle(i, l)));
    velocity = std::max(velocity, m.size() * std::abs(run.omega(i, l) - ref.omega(i, l)));
    v_peak = std::max(v_peak, m.size() * std::abs(ref.omega(i, l)));
    acceleration = std::max(acceleration, m.size() * std::abs(run.alpha(i, l) - ref.alpha(i, l)));
    a_peak = std::max(a_peak, m.size() * std::abs(ref.alpha(i, l)));
  }
  e.velocity = velocity / v_peak;
  e.acceleration = acceleration / a_peak;
  e.reactions = ref.has_forces && run.has_forces && ref.fx.cols() > 0;
  if (e.reactions) e.reaction = worst_over(i, run.fx, run.fy, ref.fx, ref.fy, f_peak) / f_peak;
  return e;
}

// What each engine's first sample is, and so what it must meet (each a fraction of the exact
// sample's own magnitude of its kind). Every engine starts on the exact pose (Newton to 1e-12).
// MuJoCo and Simbody read t = 0 from their own equations at the state they were given: their
// rates are that state, their accelerations and reactions exact but for MuJoCo's J' v by
// differences (1e-11) and the scene's mass model (IFToMM A01: 7.4e-9 in both engines alike), so
// 1e-7. Bullet and ODE have no state readout: their first sample is one-sided differences over
// poses 1 to 4, past their first step's transient (sim/dynamics_run.h), a discretisation error
// of the step (1e-5 to 1e-2 of the sample at the default steps, measured 2026-12-02): it must fall
// with the step, by at least a factor 0.7 at half the step (order 0.5; measured 0.10 to 0.57),
// where MuJoCo's missing velocity terms did not fall at all. Below 1e-7 it is at that floor.
struct Tolerance {
  double position, velocity, acceleration, reaction;
};
constexpr Tolerance kStateReadout{1e-12, 1e-12, 1e-7, 1e-7};
constexpr double kOrderFloor = 1e-7, kHalfStepFactor = 0.7;

bool reads_its_state(const std::string& engine) {
  return engine == "mujoco" || engine == "simbody";
}

std::string setting(const EngineRun& run, const std::string& name) {
  for (const auto& [key, value] : run.settings)
    if (key == name) return value;
  ADD_FAILURE() << "no setting " << name;
  return "0";
}

struct FirstInstant : testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(FirstInstant, TheFirstSampleIsTheExactOneOrFlaggedWithItsReason) {
  const auto& [file, engine_name] = GetParam();
  const Mechanism m = released(file);
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  const Trajectory& ref = exact.trajectory;
  ASSERT_GT(ref.omega.row(0).cwiseAbs().maxCoeff(), 0.0) << "released with nonzero rates";
  const std::unique_ptr<Engine> engine = engine_named(engine_name);
  std::string why;
  if (!engine->supports(m, &why)) GTEST_SKIP() << engine_name << " does not build it: " << why;
  const EngineRun run = engine->run(m, ref, {});
  const Trajectory& t = run.trajectory;
  if (const PoseStatus status = t.status.front(); !usable(status)) {
    // Kept out of the verdict: then the run says why (a failed run, or an event).
    EXPECT_TRUE(!run.ok || !t.events.empty())
        << engine_name << " flags t = 0 " << to_string(status) << " without a reason";
    return;
  }
  const FirstErrors e = sample_errors(m, ref, t, 0);
  std::printf("%-8s %-48s position %.2e velocity %.2e acceleration %.2e reaction %.2e\n",
              engine_name.c_str(), file.c_str(), e.position, e.velocity, e.acceleration,
              e.reaction);
  if (reads_its_state(engine_name)) {
    EXPECT_LE(e.position, kStateReadout.position);
    EXPECT_LE(e.velocity, kStateReadout.velocity);
    EXPECT_LE(e.acceleration, kStateReadout.acceleration);
    if (e.reactions) {
      EXPECT_LE(e.reaction, kStateReadout.reaction);
    }
    return;
  }
  EXPECT_LE(e.position, kStateReadout.position);
  const double dt = std::stod(setting(run, "dt"));
  const EngineRun half_run = engine->run(m, ref, {{"dt", fmt::format("{:.17g}", dt / 2)}});
  ASSERT_TRUE(usable(half_run.trajectory.status.front())) << half_run.message;
  const FirstErrors half = sample_errors(m, ref, half_run.trajectory, 0);
  std::printf("%-8s %-48s at dt/2:  velocity %.2e acceleration %.2e reaction %.2e\n",
              engine_name.c_str(), file.c_str(), half.velocity, half.acceleration, half.reaction);
  const auto falls = [](double at_h, double at_half) {
    return at_h <= kOrderFloor || at_half <= kHalfStepFactor * at_h;
  };
  EXPECT_TRUE(falls(e.velocity, half.velocity)) << e.velocity << " -> " << half.velocity;
  EXPECT_TRUE(falls(e.acceleration, half.acceleration))
      << e.acceleration << " -> " << half.acceleration;
  if (e.reactions) {
    EXPECT_TRUE(falls(e.reaction, half.reaction)) << e.reaction << " -> " << half.reaction;
  }
}

std::string case_name(const testing::TestParamInfo<FirstInstant::ParamType>& info) {
  std::string name = fs::path(std::get<0>(info.param)).stem().string();
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name + "_" + std::get<1>(info.param);
}

INSTANTIATE_TEST_SUITE_P(BundledCases, FirstInstant,
                         testing::Combine(testing::ValuesIn(dynamics_cases()),
                                          testing::Values("mujoco", "bullet", "ode", "simbody")),
                         case_name);

}  // namespace
}  // namespace crosslink::sim
