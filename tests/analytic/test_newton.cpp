// Exact solver checks against the seed notes' printed values and against independent
// properties (loop closure, finite differences).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <Eigen/SVD>

#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Notes 000 (sewing machine) at theta2 = 135 deg. The notes solve with angles rounded to 0.1
// degree (57.3, 8.4, 254.6) and lengths to 0.01 cm, so each printed velocity carries a relative
// error of about 0.2 % (a 0.1 degree shift in a 1.6 cm lever arm) and each acceleration about
// 1.5 % of the largest acceleration term in its equation (the notes' own caveat).
TEST(SewingMachine, ReproducesPrintedValuesAt135) {
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  const Trajectory t = solve_at(m, 135 * kDeg);
  ASSERT_EQ(t.status[0], PoseStatus::ok);
  const double cm = 0.01;
  auto at = [&](const char* channel) { return (*t.channel(channel))(0); };
  // Angles printed to 0.1 degree (vector-loop table): half a unit of the last digit plus the
  // 0.16 degree by which DE differs between the notes' two data sets.
  EXPECT_NEAR(at("angle.coupler") / kDeg, 57.3, 0.1);
  EXPECT_NEAR(at("angle.bell_crank") / kDeg, 8.4, 0.1);
  EXPECT_NEAR(at("angle.needle_link") / kDeg, 254.6, 0.3);
  EXPECT_NEAR(at("s.needle") / cm, 1.12, 0.01);
  // Velocities: 0.2 % of the value (rounded geometry), at least the printed last digit.
  EXPECT_NEAR(at("omega.coupler"), -12.00, 0.03);
  EXPECT_NEAR(at("omega.bell_crank"), -23.27, 0.05);
  EXPECT_NEAR(at("omega.needle_link"), 7.96, 0.02);
  // Needle: the matrix method (65.07) and the closed form (64.71) differ by 0.55 % between
  // themselves; the exact value must lie within that spread of the matrix method.
  EXPECT_NEAR(at("sdot.needle") / cm, 65.07, 0.36);
  EXPECT_NEAR(-at("vy.F") / cm, 65.07, 0.36);
  // Accelerations: 1.5 % of the largest term of the notes' acceleration equations
  // (|alpha3| = 549 rad/s^2 for the four-bar loop, 680 cm/s^2 for the needle loop).
  EXPECT_NEAR(at("alpha.coupler"), 549.3, 0.015 * 549.3);
  EXPECT_NEAR(at("alpha.bell_crank"), 40.4, 0.015 * 549.3);
  EXPECT_NEAR(at("alpha.needle_link"), 327.7, 0.015 * 549.3);
  EXPECT_NEAR(at("sddot.needle") / cm, -680.0, 0.015 * 680.0);
}

// A02 drawn with every link on one line (kept from fuzzing): the Jacobian is exactly singular.
// Its condition estimate must say so (0), not NaN, which compares false with the threshold and
// passed the pose as ok.
TEST(ExactlySingularDrawing, IsSingularWithRcondZero) {
  const Mechanism m = load_mechanism("tests/fuzz/regressions/a02_drawn_collinear_rcond_nan.toml");
  const NewtonSolver solver(m);
  KinematicState state(m);
  const SolveReport r = solver.assemble(state);
  EXPECT_EQ(r.status, PoseStatus::singular) << r.message;
  EXPECT_EQ(r.rcond, 0.0);
  // Independently: the smallest singular value of the Jacobian there, relative to the largest.
  Eigen::MatrixXd jac(state.q.size(), state.q.size());
  solver.jacobian(state.q, jac);
  const Eigen::VectorXd sigma = Eigen::JacobiSVD<Eigen::MatrixXd>(jac).singularValues();
  EXPECT_LT(sigma(sigma.size() - 1), 1e-12 * sigma(0));
}

}  // namespace
}  // namespace crosslink
