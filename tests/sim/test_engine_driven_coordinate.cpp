// A link-angle driver read off a ground pivot that the definition writes [link, ground]: the
// pivot's value theta_ground - theta_link runs against the driver (DrivenCoordinate::sign -1).
// Every engine and formulation follows the exact sweep there, and reads the driver's torque, as it
// does with the pivot written [ground, link] (until 2026-11-27 MuJoCo lost the driver at its first
// step, its driver coordinate read as sign x qpos against a target in qpos; Bullet's multibody read
// the tree parent of the ground, out of bounds, and lost it too).
#include <gtest/gtest.h>

#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"
#include "sim/forces.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"

namespace crosslink::sim {
namespace {

// The bundled crank-rocker with its driver turned into the crank's absolute angle (A to B, the
// same values) and its ground pivot A written [crank, ground].
Mechanism reversed_pivot_link_angle() {
  Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  Joint& a = m.joints[static_cast<size_t>(m.drivers[0].joint)];
  EXPECT_EQ(a.type, JointType::revolute);
  EXPECT_TRUE(m.links[static_cast<size_t>(a.link_a)].ground);
  std::swap(a.link_a, a.link_b);
  std::swap(a.point_a, a.point_b);
  m.drivers[0].type = DriverType::link_angle;
  m.drivers[0].link = a.link_a;
  m.drivers[0].from = a.point_a;  // to: B, as the joint-angle driver's
  m.drivers[0].joint = -1;
  return m;
}

// The worst angular velocity of any link off the exact sweep, as a fraction of its peak, over the
// samples the run calls ok.
double worst_omega(const Trajectory& exact, const Trajectory& run) {
  const double peak = exact.omega.cwiseAbs().maxCoeff();
  double worst = 0.0;
  int ok = 0;
  for (int i = 0; i < exact.samples(); ++i) {
    if (run.status[static_cast<size_t>(i)] != PoseStatus::ok) continue;
    ++ok;
    worst = std::max(worst, (run.omega.row(i) - exact.omega.row(i)).cwiseAbs().maxCoeff() / peak);
  }
  EXPECT_GT(ok, exact.samples() * 9 / 10);
  return worst;
}

TEST(EngineDrivenCoordinate, LinkAngleAtAPivotWrittenLinkFirst) {
  const Mechanism m = reversed_pivot_link_angle();
  const Trajectory exact = sweep(m);
  for (const auto& [engine, settings] :
       {std::pair{make_mujoco_engine(), Settings{}}, std::pair{make_bullet_engine(), Settings{}},
        std::pair{make_bullet_engine(), Settings{{"formulation", "multibody"}}},
        std::pair{make_ode_engine(), Settings{}}}) {
    SCOPED_TRACE(engine->name() + (settings.empty() ? "" : " multibody"));
    std::string why;
    ASSERT_TRUE(engine->supports(m, &why)) << why;
    const EngineRun run = engine->run(m, exact, settings);
    ASSERT_TRUE(run.ok) << run.message;
    // The default velocity tolerance, 0.1 % of peak (the bundled crank-rocker: 0.01 %).
    EXPECT_LT(worst_omega(exact, run.trajectory), 1e-3);
    // The driver's torque, read at the pivot, against the exact kinetostatics, within the bounds
    // test_engine_forces holds each engine to (MuJoCo 0.05 %, Bullet and ODE 0.25 % of peak);
    // Bullet's multibody reads no forces.
    if (run.trajectory.has_forces)
      EXPECT_LE(force_agreement(m, exact, run.trajectory).effort,
                engine->name() == "mujoco" ? 0.05e-2 : 0.25e-2);
    else
      EXPECT_FALSE(settings.empty());
  }
}

}  // namespace
}  // namespace crosslink::sim
