// The judge cannot be fooled (analytic/reference/trust.h, docs/compare.md "What is kept out of a
// verdict"): a corrupted reference sample is caught by the reference's own second exact method
// and cannot make a wrong method pass; a linkage that never nears a singular position loses no
// sample from any verdict; no threshold depends on the size of a chain or its units.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/trust.h"
#include "compare/comparison.h"
#include "methods/engines.h"
#include "methods/registry.h"
#include "tests/common/mechanisms.h"
#include "tests/common/nfourbar.h"

namespace crosslink::compare {
namespace {

const std::string kRoot = std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/";

// A method that is the exact trajectory with every rate, acceleration and force `factor` times
// too large: wrong by (factor - 1) of each channel's own value everywhere.
MethodRun wrong_method(const Trajectory& exact, double factor) {
  MethodRun run;
  run.name = "mujoco";  // judged at an engine's default tolerances
  run.available = run.ok = true;
  run.trajectory = exact;
  Trajectory& t = run.trajectory;
  for (Eigen::MatrixXd* m : {&t.omega, &t.alpha, &t.vx, &t.vy, &t.ax, &t.ay, &t.sdot, &t.sddot,
                             &t.fx, &t.fy, &t.fn, &t.moment, &t.shaking})
    *m *= factor;
  t.effort *= factor;
  return run;
}

// Whether every channel of `kind` ("force", "torque", "velocity") of method `name` passes.
bool passes(const Comparison& c, const std::string& name, Quantity q) {
  bool any = false;
  for (const ChannelResult& r : c.channels)
    if (r.method == name && r.metrics.quantity == q && r.verdict != Verdict::not_applicable) {
      any = true;
      if (r.verdict == Verdict::fail) return false;
    }
  return any;
}

// The sample of the trust issue's kind: a spike at one sample, as a singular solve left it
// (rocker rate of the wrong sign, forces 1e6 times their size), marked ok.
void corrupt(Trajectory& t, int k) {
  t.omega.row(k) *= -0.7;
  t.alpha.row(k) *= 1e6;
  t.ax.row(k) *= 1e6;
  t.ay.row(k) *= 1e6;
  t.fx.row(k) *= 1e6;
  t.fy.row(k) *= 1e6;
  t.effort(k) *= 1e6;
  t.shaking.row(k) *= 1e6;
}

TEST(Trust, ACorruptedReferenceSampleIsCaughtAndCannotPassAWrongMethod) {
  const Mechanism m = load_mechanism(kRoot + "fourbar_crank_rocker.toml");
  Trajectory exact = sweep(m);
  ASSERT_TRUE(exact.has_forces);
  const int k = 123;
  Trajectory corrupted = exact;
  corrupt(corrupted, k);
  // 5 % off everywhere; like an engine at a change point, it flags the sample itself, so the
  // spike never enters its own differences, only the scales.
  MethodRun wrong = wrong_method(exact, 1.05);
  wrong.trajectory.status[k] = PoseStatus::singular;

  // Unchecked, the spike sets every force channel's scale and the wrong method passes there:
  // what the check is for.
  {
    MethodRun reference;
    reference.name = "analytic";
    reference.available = reference.ok = true;
    reference.trajectory = corrupted;
    const Comparison c = methods::compare_runs(
        m, {reference, wrong}, Tolerances(methods::engine_tolerances(false), m.tolerances));
    EXPECT_TRUE(passes(c, "mujoco", Quantity::force));
    EXPECT_TRUE(passes(c, "mujoco", Quantity::torque));
  }
  // Checked against the dyads, the sample is flagged, kept out, and the wrong method fails
  // every class of channel it is wrong in.
  const CrossCheck check = cross_check(m, corrupted, dyad_sweep(m, corrupted));
  EXPECT_EQ(check.disagree, 1);
  EXPECT_EQ(corrupted.status[k], PoseStatus::exact_methods_disagree);
  EXPECT_LT(check.worst, kExactAgreement);
  MethodRun reference;
  reference.name = "analytic";
  reference.available = reference.ok = true;
  reference.trajectory = corrupted;
  const Comparison c = methods::compare_runs(
      m, {reference, wrong}, Tolerances(methods::engine_tolerances(false), m.tolerances));
  EXPECT_FALSE(c.pass());
  for (Quantity q : {Quantity::velocity, Quantity::acceleration, Quantity::force, Quantity::torque})
    EXPECT_FALSE(passes(c, "mujoco", q)) << to_string(q);
  for (const ChannelResult& r : c.channels) {
    ASSERT_EQ(r.metrics.reason.size(), static_cast<size_t>(exact.samples()));
    EXPECT_EQ(r.metrics.reason[k], "reference:exact_methods_disagree") << r.metrics.channel;
  }
}

// The reference's own check raises no false alarm: on every bundled kinematic definition whose
// chain decomposes, Newton and the dyads agree on every sample both solve, far inside the limit
// (worst 9.4e-9 of the scale, next to a toggle of the slider-crank driven from its slider).
TEST(Trust, ExactMethodsAgreeOnEveryBundledDefinition) {
  int checked = 0;
  for (const std::string& file : test::bundled_files(true, false)) {
    const Mechanism m = load_mechanism(file);
    if (!decompose(m).complete) continue;
    const compare::MethodRun reference = methods::run_reference(m);
    int disagree = 0;
    for (PoseStatus s : reference.trajectory.status)
      disagree += s == PoseStatus::exact_methods_disagree;
    EXPECT_EQ(disagree, 0) << file;
    Trajectory newton = sweep(m);
    const CrossCheck check = cross_check(m, newton, dyad_sweep(m, newton));
    EXPECT_GT(check.compared, 0) << file;
    EXPECT_LT(check.worst, 0.05 * kExactAgreement) << file << " " << check.worst_channel;
    ++checked;
  }
  EXPECT_GE(checked, 10);
}

// The Jansen leg never nears a singular position: no sample of any verdict is kept out, forces
// included (an absolute conditioning limit of 1e-2 dropped 147 to 234 degrees, its torque peak).
TEST(Trust, ALinkageWithNoSingularPositionLosesNoSample) {
  const Mechanism m = load_mechanism(kRoot + "jansen_leg.toml");
  const MethodRun reference = methods::run_reference(m);
  const Trajectory& t = reference.trajectory;
  ASSERT_EQ(t.samples(), 361);
  const double force_rcond = kForceConditioning * typical_rcond(t);
  for (int k = 0; k < t.samples(); ++k) EXPECT_EQ(untrusted(t, k, force_rcond), "") << k;
  const Comparison c =
      methods::compare_runs(m, {reference, wrong_method(t, 1.0)},
                            Tolerances(methods::engine_tolerances(false), m.tolerances));
  EXPECT_TRUE(c.pass());
  for (const ChannelResult& r : c.channels)
    EXPECT_EQ(r.metrics.usable, t.samples()) << r.metrics.channel;
}

// No threshold depends on the size of a chain or its units: IFToMM A02 with 2, 10 and 40
// four-bars, and the 2 four-bars written in mm, keep every sample in the exact reference's
// trust and run both engines to the same verdict with no sample flagged singular (the engines'
// absolute rcond limit of 1e-3 lay above the 40-bar chain's conditioning everywhere).
TEST(Trust, TheNFourBarChainIsJudgedAlikeAtEverySizeAndUnit) {
  struct Case {
    int n;
    std::string unit;
  };
  for (const Case& k : {Case{2, "m"}, Case{2, "mm"}, Case{10, "m"}, Case{40, "m"}}) {
    const Mechanism m = parse_mechanism(test::nfourbar_definition(k.n, 0.5, k.unit), "a02");
    const MethodRun reference = methods::run_reference(m);
    const Trajectory& t = reference.trajectory;
    const double force_rcond = kForceConditioning * typical_rcond(t);
    int kept_out = 0;
    for (int i = 0; i < t.samples(); ++i) kept_out += !untrusted(t, i, force_rcond).empty();
    EXPECT_EQ(kept_out, 0) << k.n << " " << k.unit;
    std::vector<MethodRun> runs = {reference};
    for (const char* engine : {"mujoco", "bullet"})
      runs.push_back(methods::run_method(engine, m, reference));
    const Comparison c =
        methods::compare_runs(m, runs, Tolerances(methods::engine_tolerances(false), m.tolerances));
    EXPECT_TRUE(c.pass()) << k.n << " " << k.unit;
    for (size_t r = 1; r < c.methods.size(); ++r)
      for (PoseStatus s : c.methods[r].trajectory.status)
        EXPECT_NE(s, PoseStatus::singular) << c.methods[r].name << " " << k.n << " " << k.unit;
  }
}

}  // namespace
}  // namespace crosslink::compare
