// The value of a sweep at a driver value does not depend on the sweep's step: every method
// (Newton, closed-form dyads, instantaneous centres) follows its branch in substeps as fine as
// continuity needs, whatever grid the user asks for. Each coarse sweep is checked sample by
// sample against a fine sweep whose grid contains it (a 1-degree sweep for integer-degree steps),
// on every bundled mechanism and on the singular catalogue, including grids that land exactly on
// a singular position or 1e-7 of the driver beside it.
//
// Expected values are the fine sweep's own: a branch jump is an O(1) difference (the sewing
// machine's coupler at 315 deg was 130.53 deg on a 90-degree grid against 104.09 deg), so the
// agreement asked for, 1e-8 of each channel's physical scale, is far above the solvers'
// round-off and far below any jump.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "tests/common/exact.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kAgreement = 1e-8;

// A trajectory with the instantaneous centres' velocities in place of the exact ones (positions
// are the exact method's, as the comparator's "ic" method does); samples where the centres do
// not give every velocity are flagged.
Trajectory with_centre_velocities(const Mechanism& m, Trajectory t) {
  t.method = "ic";
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)])) continue;
    const CentreVelocities v = centre_velocities(m, instant_centres(m, t, k), t, k);
    if (!v.complete) {
      t.status[static_cast<size_t>(k)] = PoseStatus::singular;
      continue;
    }
    for (size_t l = 0; l < v.omega.size(); ++l)
      t.omega(k, static_cast<Eigen::Index>(l)) = v.omega[l];
    for (size_t p = 0; p < v.point.size(); ++p) {
      t.vx(k, static_cast<Eigen::Index>(p)) = v.point[p].x();
      t.vy(k, static_cast<Eigen::Index>(p)) = v.point[p].y();
    }
  }
  return t;
}

// Every method's sweep at one grid: the exact ones and the instantaneous centres.
std::map<std::string, Trajectory> sweeps(const Mechanism& m, double step) {
  std::map<std::string, Trajectory> out = test::exact_sweeps(m, step);
  out["ic"] = with_centre_velocities(m, out.at("newton"));
  return out;
}

// The physical scale of each quantity over the fine sweep: the size for positions, 1 rad for
// angles, the largest magnitude of its kind at usable samples for rates, forces and torques.
std::map<Quantity, double> scales(const Mechanism& m, const Trajectory& fine) {
  std::map<Quantity, double> s{{Quantity::position, m.size()}, {Quantity::angle, 1.0},
                               {Quantity::velocity, 0.0},      {Quantity::acceleration, 0.0},
                               {Quantity::force, 0.0},         {Quantity::torque, 0.0}};
  for (const std::string& name : fine.channel_names()) {
    const Quantity q = Trajectory::quantity_of(name);
    if (q == Quantity::position || q == Quantity::angle) continue;
    const Eigen::VectorXd c = *fine.channel(name);
    for (int k = 0; k < fine.samples(); ++k)
      if (usable(fine.status[static_cast<size_t>(k)])) s[q] = std::max(s[q], std::abs(c(k)));
  }
  return s;
}

// Compares every sample of `coarse` with the sample of `fine` at the same driver value; returns
// how many were matched.
int expect_same_samples(const Mechanism& m, const Trajectory& coarse, const Trajectory& fine,
                        const std::string& what) {
  const double unit = m.drivers[0].angular() ? 1.0 : m.size();
  const std::map<Quantity, double> scale = scales(m, fine);
  int matched = 0;
  for (int i = 0; i < coarse.samples(); ++i) {
    int j = -1;
    for (int k = 0; k < fine.samples() && j < 0; ++k)
      if (std::abs(fine.along(k) - coarse.along(i)) <= 1e-9 * unit) j = k;
    if (j < 0) continue;
    ++matched;
    const PoseStatus sc = coarse.status[static_cast<size_t>(i)];
    const PoseStatus sf = fine.status[static_cast<size_t>(j)];
    EXPECT_EQ(to_string(sc), to_string(sf)) << what << " at driver " << coarse.along(i);
    if (!usable(sc) || !usable(sf)) continue;
    for (const std::string& name : coarse.channel_names()) {
      const Quantity q = Trajectory::quantity_of(name);
      const double tolerance = kAgreement * std::max(scale.at(q), 1e-300);
      const double a = (*coarse.channel(name))(i), b = (*fine.channel(name))(j);
      EXPECT_LE(std::abs(a - b), tolerance)
          << what << ": " << name << " at driver " << coarse.along(i) << ": " << a << " vs " << b
          << " on the fine grid";
    }
  }
  return matched;
}

class EveryMechanism : public ::testing::TestWithParam<std::string> {};

// Grids of 7, 45, 60, 90 and 120 fine steps (1 degree for a turning driver, 1/360 of the range
// for a slider) against the fine grid.
TEST_P(EveryMechanism, CoarseGridsEqualTheFineGrid) {
  const Mechanism m = load_mechanism(GetParam());
  const std::map<std::string, Trajectory> fine = sweeps(m, 0.0);
  const Trajectory& reference = fine.at("newton");
  ASSERT_GT(reference.samples(), 2);
  // The default grid's step: 1 degree, or for a slider its most common spacing (1/360 of the
  // range; the extra samples at toggles make other spacings).
  double fine_step = std::acos(-1.0) / 180.0;
  if (!m.drivers[0].angular()) {
    std::vector<double> spacing;
    for (int k = 1; k < reference.samples(); ++k)
      spacing.push_back(std::abs(reference.along(k) - reference.along(k - 1)));
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    fine_step = spacing[spacing.size() / 2];
  }
  for (const int multiple : {7, 45, 60, 90, 120}) {
    const std::map<std::string, Trajectory> coarse = sweeps(m, multiple * fine_step);
    for (const auto& [method, t] : coarse) {
      const std::string what = method + " at " + std::to_string(multiple) + " steps";
      const int matched = expect_same_samples(m, t, fine.at(method), what);
      // Toggle samples are extra, and a full cycle's last sample may overshoot the fine grid.
      EXPECT_GE(matched, t.samples() - 3) << what;
      EXPECT_GT(matched, 0) << what;
    }
  }
}

// Grids landing exactly on each singular position of the first pass (toggles, change points), and
// 1e-7 of the driver beside it on either side, against grids 45 times finer. Returns how many
// singular positions were tried.
int check_grids_at_singular_positions(const std::string& file) {
  const Mechanism m = load_mechanism(file);
  std::vector<SingularPosition> singular;
  sweep(m, {}, singular);
  const double unit = m.drivers[0].angular() ? 1.0 : m.size();
  const double reach = m.drivers[0].angular() ? 2.0 * std::acos(-1.0) : 1e9;
  int tried = 0;
  for (const SingularPosition& p : singular) {
    const double gap = p.driver - m.drivers[0].start;
    if (p.kind == SingularKind::branch_jump || std::abs(gap) < 1e-3 * unit || std::abs(gap) > reach)
      continue;
    for (const double beside : {0.0, 1e-7, -1e-7}) {
      // A grid of four steps to the singular position (plus or minus beside).
      const double step = std::abs(gap + beside * unit) / 4.0;
      const std::map<std::string, Trajectory> coarse = sweeps(m, step);
      const std::map<std::string, Trajectory> fine = sweeps(m, step / 45.0);
      for (const auto& [method, t] : coarse) {
        const std::string what =
            fmt::format("{} {}: {} on a grid {:g} beside the {} at {:.12g}", file, method, method,
                        beside, to_string(p.kind), p.driver);
        EXPECT_GT(expect_same_samples(m, t, fine.at(method), what), 0) << what;
      }
    }
    ++tried;
  }
  return tried;
}

TEST(SingularPositions, GridsOnAndBesideThemEqualFinerGrids) {
  int mechanisms = 0;
  for (const std::string& file : test::bundled_files(true))
    if (check_grids_at_singular_positions(file) > 0) ++mechanisms;
  // The change-point four-bars, the non-Grashof four-bar, the slider-driven slider-crank and the
  // polycentric hinge have singular positions in their first pass.
  EXPECT_GE(mechanisms, 5);
}

INSTANTIATE_TEST_SUITE_P(Mechanisms, EveryMechanism, ::testing::ValuesIn(test::bundled_files(true)),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return std::filesystem::path(info.param).stem().string();
                         });

}  // namespace
}  // namespace crosslink
