// Bullet at its most accurate settings: 20 steps per sample (0.04 s; part of the default run).
#include <gtest/gtest.h>

#include <iostream>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"
#include "tests/sim/bullet/agreement.h"

namespace crosslink {
namespace {

TEST(BulletMostAccurate, CrankRockerAccelerationsWithinOneHundredthPercent) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  const Trajectory ref = sweep(m);
  const sim::EngineRun run = sim::make_bullet_engine()->run(m, ref, {{"steps_per_sample", "20"}});
  ASSERT_TRUE(run.ok) << run.message;
  const test::Agreement a = test::agreement(m, ref, run.trajectory);
  std::cout << "most accurate: position " << a.position << ", velocity " << 100 * a.velocity
            << " %, acceleration " << 100 * a.acceleration << " % " << a.worst_acceleration << " ("
            << run.cost.wall_seconds_per_cycle << " s per cycle)\n";
  EXPECT_LT(a.position, 1e-6);
  EXPECT_LT(a.velocity, 1e-5) << a.worst_velocity;
  EXPECT_LT(a.acceleration, 1e-4) << a.worst_acceleration;
}

}  // namespace
}  // namespace crosslink
