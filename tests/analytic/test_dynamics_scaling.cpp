// IFToMM A02 at the benchmark's own size, N = 40 (81 bars, 40 loops; mechanisms/scaling/,
// written by scripts/generate_a02.py): the exact reference against the one-freedom reduction
// (tests/common/nfourbar.h). About half a minute: label slow.
#include <gtest/gtest.h>

#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "tests/common/nfourbar.h"

namespace crosslink {
namespace {

TEST(NFourBar, FortyFourBarsFollowTheOneFreedomEquation) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/scaling/iftomm_a02_nfourbar_40.toml");
  const Simulation sim = simulate(m);
  ASSERT_TRUE(sim.ok) << sim.message;
  const Trajectory& t = sim.trajectory;
  int b0 = 0;
  while (t.point_names[static_cast<size_t>(b0)] != "B0") ++b0;
  const double worst = test::nfourbar_b0_difference(t, b0, 40);
  double drift = 0.0;
  for (int k = 0; k < t.samples(); ++k)
    if (usable(t.status[static_cast<size_t>(k)])) drift = std::max(drift, sim.energy_error(k));
  std::printf(
      "[ A02 N=40 ] B0 at 10 s (%.11f, %.11f), within %.2e of the one-freedom equation; energy "
      "balance %.2e; %ld evaluations\n",
      t.x(t.samples() - 1, b0), t.y(t.samples() - 1, b0), worst, drift, sim.evaluations);
  EXPECT_GE(worst, 0.0) << "a flagged sample";
  EXPECT_LT(worst, 1e-7);
  // 81 bars: rcond 2e-4 upright, so each pose is resolved to ~5e-12 of the size, and the
  // balance (1.8e-10) is above the 1e-10 the smaller cases reach.
  EXPECT_LT(drift, 1e-9);
}

}  // namespace
}  // namespace crosslink
