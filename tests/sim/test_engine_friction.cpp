// Each engine's joint friction (docs/engines.md, "Joint friction") against independent answers:
// the closed form of a block sliding to rest on a slope, the exact forward dynamics of a pendulum
// with pivot friction and the exact kinetostatics of linkages with friction at every joint (both
// checked in tests/analytic/test_friction.cpp), with the order of each error in the step and
// ODE's creep against its own formulation.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/trust.h"
#include "methods/engines.h"
#include "tests/common/mechanisms.h"

namespace crosslink::sim {
namespace {

Mechanism friction_mechanism(const std::string& name) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/friction/" + name +
                        ".toml");
}

EngineRun run_engine(const std::string& name, const Mechanism& m, const Trajectory& exact,
                     const Settings& settings = {}) {
  const auto engine = methods::find_engine(name)->make();
  std::string why;
  EXPECT_TRUE(engine->supports(m, &why)) << why;
  EngineRun run = engine->run(m, exact, settings);
  EXPECT_TRUE(run.ok) << run.message;
  return run;
}

// The creep a run reports (creep_note) [rad or m].
double creep_of(const EngineRun& run) {
  const size_t at = run.message.find("creep: ");
  EXPECT_NE(at, std::string::npos) << run.message;
  return at == std::string::npos ? 0.0 : std::stod(run.message.substr(at + 7));
}

// ODE, Bullet and Simbody run every friction definition; MuJoCo those where no friction pin
// closes a loop at a link that slides (a cut pin's friction is a fixed tendon, whose moment on a
// slider MuJoCo's reading would miss: the slider-crank's and Bevan's pin P), and names the joint
// it refuses.
TEST(EngineFriction, EachEngineRunsTheFrictionItModelsAndRefusesTheRestNamingTheJoint) {
  const std::vector<std::string> tree_only = {
      "block_sliding_to_rest", "pendulum_pin_friction", "fourbar_friction_circles",
      "gear_pair_bearing_friction", "block_and_pendulum_two_coordinates"};
  for (const methods::EngineEntry& e : methods::engine_table()) {
    const auto engine = e.make();
    for (const std::string& path : test::friction_files()) {
      const Mechanism m = load_mechanism(path);
      const std::string name = std::filesystem::path(path).stem().string();
      const bool runs = e.name != "mujoco" ||
                        std::find(tree_only.begin(), tree_only.end(), name) != tree_only.end();
      std::string why;
      EXPECT_EQ(engine->supports(m, &why), runs) << e.name << " on " << name << ": " << why;
      if (!runs) {
        EXPECT_NE(why.find("has friction"), std::string::npos) << why;
      }
    }
  }
}

// The worst difference of the first link's angle over the samples the exact motion trusts and the
// run calls usable [rad].
double angle_error(const Trajectory& exact, const EngineRun& run) {
  double worst = 0.0;
  for (int k = 0; k < run.trajectory.samples(); ++k)
    if (usable(run.trajectory.status[static_cast<size_t>(k)]) && untrusted(exact, k, 0.0).empty())
      worst = std::max(worst, std::abs(run.trajectory.angle(k, 0) - exact.angle(k, 0)));
  return worst;
}

// The energy balance's error (with the friction's work) at every usable sample within `bound` [J].
void expect_energy_balanced(const EngineRun& run, double bound) {
  const Trajectory& t = run.trajectory;
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)])) continue;
    EXPECT_LT(std::abs(t.energy(k, 3)), bound) << t.method << " at " << t.time(k);
  }
}

// The worst and RMS difference of every friction channel over the samples the reference trusts
// for forces and the run calls usable, as a fraction of the channel's exact peak.
struct FrictionError {
  double worst = 0.0, rms = 0.0;
};
FrictionError friction_error(const Trajectory& exact, const Trajectory& engine) {
  FrictionError out;
  const double force_rcond = kForceConditioning * typical_rcond(exact);
  int n = 0;
  for (Eigen::Index f = 0; f < exact.friction.cols(); ++f) {
    double peak = 0.0;
    for (int k = 0; k < exact.samples(); ++k)
      if (untrusted(exact, k, force_rcond).empty())
        peak = std::max(peak, std::abs(exact.friction(k, f)));
    for (int k = 0; k < exact.samples(); ++k) {
      if (!untrusted(exact, k, force_rcond).empty() ||
          !usable(engine.status[static_cast<size_t>(k)]))
        continue;
      const double e = std::abs(engine.friction(k, f) - exact.friction(k, f)) / peak;
      out.worst = std::max(out.worst, e);
      out.rms += e * e;
      ++n;
    }
  }
  EXPECT_GT(n, 0);
  out.rms = std::sqrt(out.rms / std::max(n, 1));
  return out;
}

// ODE and Bullet bound each friction motor by the load of the steps before, Simbody its
// regularised friction by the reactions at the state a step starts from. The last step's load is
// one step late: the error is first order in the step (halving the step halves it). Extrapolated
// linearly from the last two steps (the default) it is second order and, at the default step,
// within the 0.3 % of peak compare holds ODE's and Bullet's forces to.
TEST(EngineFriction, LoadDependentFrictionIsFirstOrderLateOrSecondOrderExtrapolated) {
  struct Steps {
    std::string engine, coarse, fine;  // max_step_angle
  };
  const std::vector<Steps> engines = {
      {"ode", "0.01", "0.005"}, {"bullet", "0.01", "0.005"}, {"simbody", "0.0025", "0.00125"}};
  for (const char* name : {"slider_crank_friction", "bevan_eccentric_friction"}) {
    const Mechanism m = friction_mechanism(name);
    const Trajectory exact = sweep(m);
    for (const Steps& steps : engines) {
      SCOPED_TRACE(steps.engine + " on " + name);
      const auto late = [&](const std::string& step_angle) {
        return friction_error(
            exact, run_engine(steps.engine, m, exact,
                              {{"friction_load", "last"}, {"max_step_angle", step_angle}})
                       .trajectory);
      };
      const FrictionError coarse = late(steps.coarse), fine = late(steps.fine);
      EXPECT_GT(coarse.rms / fine.rms, 1.7);
      EXPECT_LT(coarse.rms / fine.rms, 2.4);
      const FrictionError extrapolated =
          friction_error(exact, run_engine(steps.engine, m, exact).trajectory);
      EXPECT_LT(extrapolated.rms, coarse.rms / 5);
      EXPECT_LT(extrapolated.worst, 0.3e-2);
    }
  }
  // The four-bar's massless crank between two friction pins (its pins' loads change 95 rad/s
  // fast): extrapolated, within compare's force tolerance too.
  const Mechanism m = friction_mechanism("fourbar_friction_circles");
  const Trajectory exact = sweep(m);
  for (const Steps& steps : engines)
    EXPECT_LT(friction_error(exact, run_engine(steps.engine, m, exact).trajectory).worst, 0.3e-2)
        << steps.engine;
}

// Bullet's Dantzig solve can fail on the loops' redundant friction rows at some steps (on the
// four-bar at steps of 5e-5 to 1.5e-4 s, one step in a run; which one depends on the step); its
// fallback, sequential impulse, once read the four-bar's friction 95 % of peak off in samples
// still marked ok. A failed solve is retried with the friction rows softer instead: over those
// steps no run falls back, each says when it retried, and every friction keeps the error of its
// step (0.075 to 0.33 % of peak, measured; 0.14 % at the default step), far from the fallback's.
TEST(EngineFriction, BulletRetriesAFailedFrictionSolveSofterRatherThanFallBack) {
  for (const char* name : {"fourbar_friction_circles", "slider_crank_friction"}) {
    const Mechanism m = friction_mechanism(name);
    const Trajectory exact = sweep(m);
    int retried = 0;
    for (const char* dt : {"5e-05", "7e-05", "9.186e-05", "1.2e-04", "1.5e-04"}) {
      const EngineRun run = run_engine("bullet", m, exact, {{"dt", dt}});
      EXPECT_EQ(run.message.find("fell back"), std::string::npos) << name << " at " << dt;
      retried += run.message.find("retried softer") != std::string::npos;
      EXPECT_LT(friction_error(exact, run.trajectory).worst, 0.5e-2) << name << " at " << dt;
    }
    EXPECT_GT(retried, 0) << name;
  }
}

// MuJoCo on the four-bar: its two ground pins' friction on their degrees of freedom, its cut
// pin's on a fixed tendon over the loop's relative rotation, each bound set per step from the
// loads of the steps before: within the 0.05 % of peak compare holds MuJoCo's forces to.
TEST(EngineFriction, MujocosFourBarFrictionAtTreeAndCutPinsMeetsItsForceTolerance) {
  const Mechanism m = friction_mechanism("fourbar_friction_circles");
  const Trajectory exact = sweep(m);
  EXPECT_LT(friction_error(exact, run_engine("mujoco", m, exact).trajectory).worst, 0.05e-2);
}

// A block launched down a slope (the closed form of tests/analytic/test_friction.cpp): a slider
// motor at rest, bounded by mu N, slides it with the friction mu m g cos(alpha) and holds it with
// m g sin(alpha); semi-implicit Euler under a constant force is exact but for where the stop falls
// in its step. Held, the motor's row is softened by its constraint force mixing, so the block
// creeps down at `creep_rate` [m/s] (the engine's law, the test's callers), its friction within
// `held_noise` x m g of the force that holds it.
void expect_block_slides_to_rest(const Simulation& exact, const EngineRun& run, double creep_rate,
                                 double held_noise) {
  const double g = 9.81, mass = 2.0, alpha = std::numbers::pi / 6, v0 = 3.0;
  const double a = g * (0.8 * std::cos(alpha) - std::sin(alpha)), stop = v0 / a;
  const Trajectory& t = run.trajectory;
  const double h = run.cost.time_step;
  int held_first = -1;
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)]) || exact.trajectory.beside_stop(k)) continue;
    const double time = t.time(k);
    if (time < stop) {
      EXPECT_NEAR(t.friction(k, 0), -0.8 * mass * g * std::cos(alpha), 1e-6 * mass * g) << time;
      EXPECT_NEAR(t.s(k, 0), v0 * time - 0.5 * a * time * time, v0 * h) << time;
      continue;
    }
    EXPECT_NEAR(t.friction(k, 0), -mass * g * std::sin(alpha), held_noise * mass * g) << time;
    if (held_first < 0) {
      held_first = k;
      EXPECT_NEAR(t.s(k, 0), v0 * v0 / (2 * a), v0 * h);
      continue;
    }
    const double creep = creep_rate * (time - t.time(held_first));
    EXPECT_NEAR(t.s(k, 0) - t.s(held_first, 0), creep, 0.02 * creep + 1e-14) << time;
  }
  EXPECT_GT(held_first, 0);
  EXPECT_NE(run.message.find("creep:"), std::string::npos) << run.message;
}

// Each engine's creep law, from its formulation. ODE's row with constraint force mixing eps
// solves v = eps x lambda: the block creeps at friction_cfm x m g sin(alpha). Bullet's friction
// row has its diagonal (the inverse effective mass, 1/m) grown by the fraction eps: its impulse
// then stops eps / (1 + eps) short of cancelling the step's velocity, h g sin(alpha), so the block
// creeps at eps x h g sin(alpha) (independent of its mass). Simbody's regularised friction,
// -limit tanh(v / v_s) with the static limit mu_s m g cos(alpha), balances m g sin(alpha) at
// v = v_s atanh(tan(alpha) / mu_s), v_s = friction_speed x the block's fastest rate, v0; its
// explicit integrator rides the regularisation's stiff decay (time constant m v_s / limit, about
// 1e-4 s) within its accuracy, so the held force wanders by up to 7e-6 of m g (measured).
TEST(EngineFriction, BlockSlidesToRestAsTheClosedFormSaysAndCreepsByItsEnginesLaw) {
  const Mechanism m = friction_mechanism("block_sliding_to_rest");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok && !exact.trajectory.held.empty()) << exact.message;
  const double mass = 2.0, g_sin_alpha = 9.81 * 0.5, v0 = 3.0;
  const double held = std::atanh(std::tan(std::numbers::pi / 6) / 0.9);
  struct Law {
    std::string engine, setting;
    std::vector<double> values;
    std::function<double(double value, double h)> creep_rate;
    double held_noise = 1e-6;
  };
  const std::vector<Law> laws = {
      {"ode",
       "friction_cfm",
       {1e-8, 1e-6},
       [&](double cfm, double) { return cfm * mass * g_sin_alpha; }},
      {"bullet",
       "friction_cfm",
       {1e-10, 1e-6},
       [&](double cfm, double h) { return cfm * h * g_sin_alpha; }},
      {"simbody",
       "friction_speed",
       {1e-4, 1e-3},
       [&](double fraction, double) { return fraction * v0 * held; },
       2e-5},
  };
  for (const Law& law : laws)
    for (const double value : law.values) {
      SCOPED_TRACE(fmt::format("{} at {} {}", law.engine, law.setting, value));
      const EngineRun run =
          run_engine(law.engine, m, exact.trajectory, {{law.setting, fmt::format("{}", value)}});
      expect_block_slides_to_rest(exact, run, law.creep_rate(value, run.cost.time_step),
                                  law.held_noise);
    }
}

// A pendulum with a constant pivot friction torque, against the exact forward dynamics (whose
// swings tests/analytic/test_friction.cpp holds to their energy balance): ODE's and Bullet's
// error in the angle over the whole decay, through ten reversals and the final hold, falls with
// the step at least as its first power (a quarter of the step: 4.5 and 4.4 times smaller; each
// reversal falls anywhere inside a step, so the order is not clean: halving gave ODE 1.6, 2.7 and
// 1.2), and the energy balance, which counts the friction motor's work, stays closed.
TEST(EngineFriction, PendulumDecaysAsTheExactOneAndConvergesWithTheStep) {
  const Mechanism m = friction_mechanism("pendulum_pin_friction");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  for (const std::string engine : {"ode", "bullet"}) {
    const EngineRun coarse = run_engine(engine, m, exact.trajectory);
    const EngineRun fine =
        run_engine(engine, m, exact.trajectory, {{"max_step_angle", "0.000625"}});
    EXPECT_GT(angle_error(exact.trajectory, coarse) / angle_error(exact.trajectory, fine), 3.0)
        << engine;
    // The friction's work is what the pendulum loses: without it the balance is off by the
    // potential energy of the 60 degree drop (2.45 J).
    expect_energy_balanced(coarse, 1e-3 * exact.energy_scale);
  }
}

// Simbody's regularised friction on the pendulum (-limit tanh(v / v_s)): the angle's error and
// the creep while the exact motion is held are first order in v_s (a tenth of it: 9.8 and 9.9
// times smaller, measured); the energy balance, whose friction work is the friction's power
// integrated as a state of the system, closes to round-off. At the start, at rest, the
// regularised force is zero (tanh 0) where the exact one breaks away with its whole limit: the
// regularisation's own error, 100 % of peak at that one sample.
TEST(EngineFriction, SimbodysRegularisedFrictionConvergesWithItsTransitionSpeed) {
  const Mechanism m = friction_mechanism("pendulum_pin_friction");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  const EngineRun coarse = run_engine("simbody", m, exact.trajectory);
  const EngineRun fine = run_engine("simbody", m, exact.trajectory, {{"friction_speed", "1e-5"}});
  EXPECT_GT(angle_error(exact.trajectory, coarse) / angle_error(exact.trajectory, fine), 7.0);
  EXPECT_GT(creep_of(coarse) / creep_of(fine), 7.0);
  EXPECT_EQ(coarse.trajectory.friction(0, 0), 0.0);
  EXPECT_NEAR(exact.trajectory.friction(0, 0), 0.2, 1e-12);
  expect_energy_balanced(coarse, 1e-7 * exact.energy_scale);
}

// MuJoCo's frictionloss is a soft row: while the joint is stuck it is a damper up to its bound,
// so the joint creeps, and near a reversal it slides below its bound; its time constant
// (friction_solref) sets both. At auto (two steps, the stiffest MuJoCo honours) against MuJoCo's
// own default 0.02 s on the pendulum: the creep and the angle error fall with it (measured 11 and
// 42 times), and the energy balance, with the rows' work, stays closed either way.
TEST(EngineFriction, MujocosFrictionLossCreepsAndErrsLessWithAShorterTimeConstant) {
  const Mechanism m = friction_mechanism("pendulum_pin_friction");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  const EngineRun stiff = run_engine("mujoco", m, exact.trajectory);
  const EngineRun soft = run_engine("mujoco", m, exact.trajectory, {{"friction_solref", "0.02 1"}});
  EXPECT_GT(creep_of(soft), 5 * creep_of(stiff));
  EXPECT_GT(angle_error(exact.trajectory, soft), 10 * angle_error(exact.trajectory, stiff));
  for (const EngineRun* run : {&stiff, &soft})
    expect_energy_balanced(*run, 1e-3 * exact.energy_scale);
}

// The block on MuJoCo: while it slides fast its frictionloss row is at its bound, set before each
// step from the last step's normal force: mu m g cos(alpha), the closed form's. Stuck, the row is
// in its quadratic zone, f = -(J a - aref) / R, with aref = -B v, B = 2 / (dmax timeconst) and
// R = (1 - d) / d x the dof's inverse mass, d = dmin at the row's zero position (solimp's defaults
// dmin 0.9, dmax 0.95; engine_core_constraint.c, mj_makeImpedance): once its transient (a few
// time constants) has passed, the block creeps at v = R f / B = (1 - d) / d x dmax / 2 x timeconst
// x g sin(alpha), at auto (two steps) and at a time constant of 0.05 s.
TEST(EngineFriction, MujocosBlockSlidesWithTheClosedFormsFrictionAndCreepsByItsRowsLaw) {
  const Mechanism m = friction_mechanism("block_sliding_to_rest");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  const double g = 9.81, mass = 2.0, alpha = std::numbers::pi / 6, v0 = 3.0;
  const double stop = v0 / (g * (0.8 * std::cos(alpha) - std::sin(alpha)));
  const EngineRun run = run_engine("mujoco", m, exact.trajectory);
  const Trajectory& t = run.trajectory;
  int sliding = 0;
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)]) || exact.trajectory.beside_stop(k) ||
        t.time(k) >= stop)
      continue;
    EXPECT_NEAR(t.friction(k, 0), -0.8 * mass * g * std::cos(alpha), 1e-6 * mass * g) << t.time(k);
    ++sliding;
  }
  EXPECT_GT(sliding, 100);
  const double law = (1.0 - 0.9) / 0.9 * 0.95 / 2.0 * g * std::sin(alpha);
  for (const double timeconst : {0.0, 0.05}) {
    const EngineRun held = timeconst > 0.0
                               ? run_engine("mujoco", m, exact.trajectory,
                                            {{"friction_solref", fmt::format("{} 1", timeconst)}})
                               : run;
    const Trajectory& h = held.trajectory;
    const int last = h.samples() - 1, before = last - 10;
    const double rate = (h.s(last, 0) - h.s(before, 0)) / (h.time(last) - h.time(before));
    const double expected = law * (timeconst > 0.0 ? timeconst : 2.0 * held.cost.time_step);
    EXPECT_NEAR(rate, expected, 0.02 * expected) << "timeconst " << timeconst;
  }
}

}  // namespace
}  // namespace crosslink::sim
