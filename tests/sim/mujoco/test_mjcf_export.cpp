// The exported MJCF (`crosslink compare --export-mjcf`), loaded from its file by libmujoco alone
// and stepped with nothing of crosslink's: it starts at the definition's start, keeps its loops
// closed within the gap crosslink's own runs flag (1e-4 x the mechanism's size), and moves its
// driver as the definition does: at the definition's speed through a whole cycle, or swinging
// between the sweep's ends when the sweep is not a whole cycle. Expected values come from the
// exact sweep and the definition, measured on MuJoCo's bodies (xpos, xmat) only.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"
#include "sim/mujoco/mujoco_engine.h"
#include "tests/common/mechanisms.h"

namespace crosslink::sim {
namespace {

struct Loaded {
  std::unique_ptr<mjModel, void (*)(mjModel*)> model{nullptr, mj_deleteModel};
  std::unique_ptr<mjData, void (*)(mjData*)> data{nullptr, mj_deleteData};
};

// Writes the export to a file and loads it as MuJoCo's own `simulate` would.
Loaded load_export(const std::string& xml, const std::string& stem) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("crosslink_export_" + stem + ".xml");
  std::ofstream(file) << xml;
  std::array<char, 1000> error{};
  Loaded l;
  l.model.reset(mj_loadXML(file.string().c_str(), nullptr, error.data(), error.size()));
  EXPECT_TRUE(l.model) << error.data();
  if (l.model) l.data.reset(mj_makeData(l.model.get()));
  std::filesystem::remove(file);
  return l;
}

double body_angle(const mjData* d, int body) {
  return std::atan2(d->xmat[9 * body + 3], d->xmat[9 * body]);
}

Eigen::Vector2d world_point(const mjData* d, int body, const Eigen::Vector2d& local) {
  const mjtNum* R = d->xmat + 9 * body;
  return {d->xpos[3 * body] + R[0] * local.x() + R[1] * local.y(),
          d->xpos[3 * body + 1] + R[3] * local.x() + R[4] * local.y()};
}

// Largest distance between the two anchors of any <connect> (body1's anchor, body2's as the
// compiler placed it), from the bodies alone.
double loop_gap(const mjModel* mm, const mjData* d) {
  double gap = 0.0;
  for (int e = 0; e < mm->neq; ++e) {
    if (mm->eq_type[e] != mjEQ_CONNECT) continue;
    const mjtNum* anchor = mm->eq_data + mjNEQDATA * e;
    const Eigen::Vector2d a = world_point(d, mm->eq_obj1id[e], {anchor[0], anchor[1]});
    const Eigen::Vector2d b = world_point(d, mm->eq_obj2id[e], {anchor[3], anchor[4]});
    gap = std::max(gap, (a - b).norm());
  }
  return gap;
}

// The definition's driver coordinate (an angle here: every bundled kinematic driver is one),
// measured on the bodies: the direction it measures on its link, in the first link's frame.
double driver_angle(const Mechanism& m, const mjModel* mm, const mjData* d) {
  const Driver& drv = m.drivers[0];
  const auto angle_of = [&](int link) {
    return m.links[static_cast<size_t>(link)].ground
               ? 0.0
               : body_angle(d, mj_name2id(mm, mjOBJ_BODY,
                                          m.links[static_cast<size_t>(link)].name.c_str()));
  };
  if (drv.type == DriverType::link_angle) {
    const auto& points = m.links[static_cast<size_t>(drv.link)].points;
    const Eigen::Vector2d v =
        points[static_cast<size_t>(drv.to)].local - points[static_cast<size_t>(drv.from)].local;
    return angle_of(drv.link) + std::atan2(v.y(), v.x());
  }
  const Joint& j = m.joints[static_cast<size_t>(drv.joint)];
  const auto& points = m.links[static_cast<size_t>(j.link_b)].points;
  const Eigen::Vector2d v =
      points[static_cast<size_t>(drv.to)].local - points[static_cast<size_t>(j.point_b)].local;
  return angle_of(j.link_b) - angle_of(j.link_a) + std::atan2(v.y(), v.x());
}

class ExportedScene : public ::testing::TestWithParam<std::string> {};

TEST_P(ExportedScene, RunsInMuJoCoAlone) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + GetParam() + ".toml");
  ASSERT_TRUE(m.drivers[0].angular());
  const Trajectory exact = sweep(m);
  const std::string xml = mujoco_mjcf(m, exact, {});
  EXPECT_NE(xml.find("<geom"), std::string::npos) << "nothing to see";
  Loaded l = load_export(xml, GetParam());
  ASSERT_TRUE(l.model);
  const mjModel* mm = l.model.get();
  mjData* d = l.data.get();
  for (int g = 0; g < mm->ngeom; ++g) {  // drawn only: no contacts, no mass
    EXPECT_EQ(mm->geom_contype[g], 0);
    EXPECT_EQ(mm->geom_conaffinity[g], 0);
  }
  mj_forward(mm, d);

  // The start: every named point where the exact sweep has it at the definition's start.
  int first = 0, start_row = -1;
  while (!usable(exact.status[static_cast<size_t>(first)])) ++first;
  for (int i = 0; i < exact.samples(); ++i)
    if (usable(exact.status[static_cast<size_t>(i)]) &&
        std::abs(exact.along(i) - m.drivers[0].start) < 1e-9)
      start_row = i;
  ASSERT_GE(start_row, 0) << "the sweep has a sample at the start";
  const double size = m.size();
  for (const Link& link : m.links) {
    if (link.ground) continue;
    const int body = mj_name2id(mm, mjOBJ_BODY, link.name.c_str());
    ASSERT_GE(body, 0) << link.name;
    for (const Point& p : link.points) {
      const auto name = std::find(exact.point_names.begin(), exact.point_names.end(), p.name);
      const auto k = name - exact.point_names.begin();
      const Eigen::Vector2d expected(exact.x(start_row, k), exact.y(start_row, k));
      EXPECT_LT((world_point(d, body, p.local) - expected).norm(), 1e-9 * size)
          << link.name << "." << p.name;
    }
  }

  // Run: the driver as the definition moves it, the loops closed.
  int last = exact.samples() - 1;
  while (!usable(exact.status[static_cast<size_t>(last)])) --last;
  const double low = exact.driver_values.col(0).segment(first, last - first + 1).minCoeff();
  const double high = exact.driver_values.col(0).segment(first, last - first + 1).maxCoeff();
  const bool whole_cycle = high - low > 2 * std::numbers::pi - 0.1;
  const double speed = m.drivers[0].law.speed;  // constant speed: every bundled kinematic driver
  const double turn = 2 * std::numbers::pi / std::abs(speed);
  // A swing (from rest over at most the sweep, back to rest) takes pi x amplitude / peak rate.
  const double swing = std::numbers::pi * 0.5 * (high - low) / std::abs(speed);
  const double duration = whole_cycle ? 3 * turn : 2 * swing;
  const double start = driver_angle(m, mm, d);
  double unwrapped = start, gap = 0.0, reached_low = start, reached_high = start;
  double at_one_turn = 0.0, one_turn_time = 0.0, lag = 0.0;
  const long steps = std::lround(duration / mm->opt.timestep);
  for (long k = 1; k <= steps; ++k) {
    mj_step(mm, d);
    const double a = driver_angle(m, mm, d);
    unwrapped += std::remainder(a - unwrapped, 2 * std::numbers::pi);
    gap = std::max(gap, loop_gap(mm, d));
    reached_low = std::min(reached_low, unwrapped);
    reached_high = std::max(reached_high, unwrapped);
    if (whole_cycle && d->time <= turn) {
      at_one_turn = unwrapped;
      one_turn_time = d->time;
    } else if (whole_cycle) {  // behind or ahead of turning at the definition's speed
      lag = std::max(lag, std::abs(unwrapped - at_one_turn - speed * (d->time - one_turn_time)));
    }
  }
  ASSERT_TRUE(std::isfinite(unwrapped));
  EXPECT_LT(gap, 1e-4 * size) << "the loops opened beyond crosslink's gap threshold";
  if (whole_cycle) {
    // After one turn's spin-up (twenty time constants), two turns at the definition's speed.
    const double mean = (unwrapped - at_one_turn) / (d->time - one_turn_time);
    EXPECT_NEAR(mean / speed, 1.0, 1e-4) << "mean speed " << mean << " rad/s";
    // The clock outweighs the linkage's load 1e4 to 1 (kClockLoad): its speed is the
    // definition's to 1e-4, so its angle keeps to the definition's within 1e-4 x 2 pi per turn.
    EXPECT_LT(lag, 2 * std::numbers::pi * 1e-4) << "rad";
  } else {
    // Swinging inside the sweep (whose ends are limits), over at least the part of it between
    // the start and the farther end's side of the middle, and back.
    EXPECT_GT(reached_low, low);
    EXPECT_LT(reached_high, high);
    EXPECT_GT(reached_high - reached_low, 0.4 * (high - low))
        << "reached [" << reached_low << ", " << reached_high << "] of [" << low << ", " << high
        << "]";
  }
}

// The keyframe "start" holds the exact start's velocities: every point moves as the exact
// solution says at its first sample (a [dynamics] case's initial rates, or a turning driver's).
void expect_keyframe_velocities(const Mechanism& m, const Trajectory& exact, int row,
                                const mjModel* mm, mjData* d) {
  const int key = mj_name2id(mm, mjOBJ_KEY, "start");
  ASSERT_GE(key, 0);
  mj_resetDataKeyframe(mm, d, key);
  mj_forward(mm, d);
  double peak = 0.0;
  for (int k = 0; k < static_cast<int>(exact.point_names.size()); ++k)
    peak = std::max(peak, std::hypot(exact.vx(row, k), exact.vy(row, k)));
  for (const Link& link : m.links) {
    if (link.ground) continue;
    const int body = mj_name2id(mm, mjOBJ_BODY, link.name.c_str());
    std::array<mjtNum, 6> v{};  // angular, then linear at the centre of mass (xipos), world axes
    mj_objectVelocity(mm, d, mjOBJ_BODY, body, v.data(), 0);
    const Eigen::Vector2d centre(d->xipos[3 * body], d->xipos[3 * body + 1]);
    for (const Point& p : link.points) {
      const Eigen::Vector2d r = world_point(d, body, p.local) - centre;
      const Eigen::Vector2d velocity(v[3] - v[2] * r.y(), v[4] + v[2] * r.x());
      const auto k = std::find(exact.point_names.begin(), exact.point_names.end(), p.name) -
                     exact.point_names.begin();
      EXPECT_LT((velocity - Eigen::Vector2d(exact.vx(row, k), exact.vy(row, k))).norm(),
                1e-9 * peak)
          << link.name << "." << p.name;
    }
  }
}

TEST(ExportedScene, KeyframeStartsAtSpeed) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/sewing_machine.toml");
  const Trajectory exact = sweep(m);
  Loaded l = load_export(mujoco_mjcf(m, exact, {}), "sewing_machine_key");
  ASSERT_TRUE(l.model);
  expect_keyframe_velocities(m, exact, 0, l.model.get(), l.data.get());
}

// A [dynamics] case's export has no clock (its coordinate moves freely); the keyframe starts it
// at the exact initial rates, and it keeps its loops closed when run alone.
TEST(ExportedScene, DynamicsCaseStartsAtItsInitialRates) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/iftomm_a02_double_fourbar.toml");
  ASSERT_TRUE(m.dynamics);
  const Trajectory exact = simulate(m).trajectory;
  const std::string xml = mujoco_mjcf(m, exact, {});
  EXPECT_EQ(xml.find("clock"), std::string::npos);
  Loaded l = load_export(xml, "a02");
  ASSERT_TRUE(l.model);
  expect_keyframe_velocities(m, exact, 0, l.model.get(), l.data.get());
  double gap = 0.0;
  while (l.data->time < 1.0) {
    mj_step(l.model.get(), l.data.get());
    gap = std::max(gap, loop_gap(l.model.get(), l.data.get()));
  }
  EXPECT_LT(gap, 1e-4 * m.size());
}

// The scene's <size> (issue 22): MuJoCo sizes mjData for the rows the scene's equalities make,
// counted here from the compiled model's own equality list (MuJoCo 2.2.2 makes 3 rows of a
// connect, 1 of a joint or tendon equality; the scene has no limits, friction loss or contacts),
// not for its defaults of 500 rows and 100 contacts (13 MB a mjData). Every integrator and
// solver then steps it with every row in the buffer (no "buffer full" warning) and its stack
// within MuJoCo's own bound (a stack overflow is mju_error).
void expect_sized_from_equalities(mjModel* mm, mjData* d) {
  int rows = 0;
  for (int e = 0; e < mm->neq; ++e) rows += mm->eq_type[e] == mjEQ_CONNECT ? 3 : 1;
  EXPECT_EQ(mm->njmax, rows);
  EXPECT_EQ(mm->nconmax, 0);
  for (int integrator : {mjINT_EULER, mjINT_RK4, mjINT_IMPLICIT})
    for (int solver : {mjSOL_NEWTON, mjSOL_CG, mjSOL_PGS}) {
      mm->opt.integrator = integrator;
      mm->opt.solver = solver;
      mj_resetData(mm, d);
      for (int k = 0; k < 50; ++k) mj_step(mm, d);
      EXPECT_EQ(d->nefc, rows) << integrator << " " << solver;
      EXPECT_EQ(d->warning[mjWARN_CNSTRFULL].number, 0) << integrator << " " << solver;
      EXPECT_LE(d->maxuse_stack, mm->nstack) << integrator << " " << solver;
    }
}

TEST_P(ExportedScene, SizedFromItsEqualities) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + GetParam() + ".toml");
  Loaded l = load_export(mujoco_mjcf(m, sweep(m), {}), GetParam() + "_size");
  ASSERT_TRUE(l.model);
  expect_sized_from_equalities(l.model.get(), l.data.get());
}

TEST(ExportedScene, DynamicsCaseSizedFromItsEqualities) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/iftomm_a02_double_fourbar.toml");
  Loaded l = load_export(mujoco_mjcf(m, simulate(m).trajectory, {}), "a02_size");
  ASSERT_TRUE(l.model);
  EXPECT_GT(l.model->neq, 0);
  expect_sized_from_equalities(l.model.get(), l.data.get());
}

INSTANTIATE_TEST_SUITE_P(Bundled, ExportedScene, ::testing::ValuesIn(test::bundled_stems()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace crosslink::sim
