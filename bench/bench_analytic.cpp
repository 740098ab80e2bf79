// Cost of the exact solver per pose, and against SolveSpace's geometric kernel on a four-bar.
//
//   Pose/<file>            position + velocity + acceleration for every mechanisms/*.toml found
//                          at run time, stepping 1 degree (or the like) along the driver's
//                          cycle, forward then back, with the warm start a sweep uses: the
//                          previous pose extrapolated by its velocity and acceleration.
//   PoseForces/<file>      the same, plus the exact kinetostatics of each pose (driver effort and
//                          joint reactions by Lagrange multipliers,
//                          analytic/physics/kinetostatics.h)
//   FourBarPosition/...    position only, same crank-rocker four-bar (a 0.04, b 0.12, c 0.08,
//                          d 0.10 m), same crank angles (1 degree apart, round and round), each
//                          solve warm-started from the previous solution without extrapolation:
//                          crosslink's Newton (9 unknowns: x, y, theta of 3 links) and
//                          SolveSpace's Slvs_Solve (4 unknowns: B and C in the plane).
//
// Run from the source root (mechanisms/ is found from the working directory):
//   build/bench/bench_analytic --benchmark_min_time=0.2
#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <slvs.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/physics/kinetostatics.h"
#include "tests/common/crank_rocker.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// ---------------------------------------------------------------------------------------------
// Per pose along each bundled mechanism's cycle.

struct PoseCase {
  Mechanism mechanism;
  std::vector<DriverState> drivers;  // poses along the cycle, in order
  Eigen::VectorXd q_first;           // coordinates at the first of them
};

// The warm start of a sweep: q(d + h) ~ q + q' h + q'' h^2 / 2, with q' = dq/dd and
// q'' = d2q/dd2 from the solved pose's time derivatives (qdot = q' rate,
// qddot = q'' rate^2 + q' accel). Without a rate, the last pose as it is.
void predict(const KinematicState& state, const DriverState& next, Eigen::VectorXd& tangent,
             Eigen::VectorXd& curvature, Eigen::VectorXd& q) {
  const double rate = state.swept().rate;
  q = state.q;
  if (rate == 0.0) return;
  const double h = next.value - state.swept().value;
  tangent = state.qdot / rate;
  curvature = (state.qddot - tangent * state.swept().accel) / (rate * rate);
  q += h * tangent + (0.5 * h * h) * curvature;
}

// The poses of one cycle, found by continuation from the assembled drawing in equal time steps
// (1 degree of an angular driver at constant speed, 1/200 of the mechanism's size for a slider,
// 1/360 of a polynomial or table law's duration): forward up to a full cycle, and backward too
// when the forward walk stops early (at a limit of the assembling range). A step whose Newton
// correction is not small against the predicted motion would change branch: the walk stops.
// Self-contained on purpose: it depends on NewtonSolver only, not on the sweep's bookkeeping.
std::shared_ptr<PoseCase> pose_case(const std::string& path, std::string& error) {
  try {
    auto c = std::make_shared<PoseCase>();
    c->mechanism = load_mechanism(path);
    const Mechanism& m = c->mechanism;
    const NewtonSolver solver(m);
    KinematicState state(m);
    const SolveReport assembled = solver.assemble(state);
    if (assembled.status != PoseStatus::ok) {
      error = "does not assemble at its start: " + assembled.message;
      return nullptr;
    }
    const Driver& d = m.swept();
    double dt = d.law.duration / 360.0;
    if (d.law.kind == MotionLaw::Kind::constant_speed)
      dt = (d.angular() ? kDeg : m.size() / 200.0) / std::abs(d.law.speed);
    const Eigen::VectorXd q_start = state.q;
    Eigen::VectorXd tangent(state.q.size()), curvature(state.q.size()), predicted(state.q.size());
    Eigen::VectorXd q_last(state.q.size());

    auto walk = [&](double direction, std::vector<std::pair<DriverState, Eigen::VectorXd>>& out) {
      state.q = q_start;
      state.swept() = d.at_time(0.0);
      solver.solve(state);
      for (int k = 1; k <= 360; ++k) {
        const DriverState next = d.at_time(direction * k * dt);
        predict(state, next, tangent, curvature, predicted);
        q_last = state.q;
        state.q = predicted;
        state.swept() = next;
        if (solver.solve(state).status != PoseStatus::ok) return false;
        const double moved = (predicted - q_last).lpNorm<Eigen::Infinity>();
        if ((state.q - predicted).lpNorm<Eigen::Infinity>() > 0.1 * moved + 1e-12) return false;
        out.emplace_back(state.swept(), state.q);
      }
      return true;
    };
    std::vector<std::pair<DriverState, Eigen::VectorXd>> forward, backward;
    forward.emplace_back(d.at_time(0.0), q_start);
    if (!walk(+1.0, forward)) walk(-1.0, backward);
    std::reverse(backward.begin(), backward.end());
    backward.insert(backward.end(), forward.begin(), forward.end());
    if (backward.size() < 3) {
      error = fmt::format("the cycle walk found only {} poses", backward.size());
      return nullptr;
    }
    c->q_first = backward.front().second;
    for (const auto& [driver, q] : backward) c->drivers.push_back(driver);
    return c;
  } catch (const std::exception& e) {
    error = e.what();
    return nullptr;
  }
}

void bench_pose(benchmark::State& bench, const std::shared_ptr<PoseCase>& c, bool forces) {
  const Mechanism& m = c->mechanism;
  const NewtonSolver solver(m);
  const Kinetostatics kinetostatics(solver);
  ForceSample sample = kinetostatics.make_sample();
  KinematicState state(m);
  // Start at the first pose of the walk.
  state.q = c->q_first;
  state.swept() = c->drivers.front();
  SolveReport report = solver.solve(state);
  if (report.status != PoseStatus::ok) {
    bench.SkipWithError(("cannot start: " + report.message).c_str());
    return;
  }

  const auto n = static_cast<long>(c->drivers.size());
  long i = 0, direction = 1;
  long failures = 0;
  Eigen::VectorXd tangent(state.q.size()), curvature(state.q.size()), predicted(state.q.size());
  for (auto _ : bench) {
    // Next pose, turning back at either end of the cycle's poses.
    if (i + direction < 0 || i + direction >= n) direction = -direction;
    i += direction;
    const DriverState& next = c->drivers[static_cast<size_t>(i)];
    predict(state, next, tangent, curvature, predicted);
    state.q = predicted;
    state.swept() = next;
    report = solver.solve(state);
    if (report.status != PoseStatus::ok) ++failures;
    benchmark::DoNotOptimize(state.qddot.data());
    if (forces && report.status == PoseStatus::ok) {
      kinetostatics.solve(state, sample);
      benchmark::DoNotOptimize(sample.effort);
    }
  }
  bench.counters["poses"] = static_cast<double>(n);
  bench.counters["coordinates"] = static_cast<double>(state.q.size());
  bench.counters["failures"] = static_cast<double>(failures);
}

// ---------------------------------------------------------------------------------------------
// The crank-rocker four-bar, position only: crosslink vs SolveSpace.

constexpr double kA = 0.04, kB = 0.12, kC = 0.08, kD = 0.10;  // crank, coupler, rocker, ground

// The shared crank-rocker (tests/common/crank_rocker.h), drawn at a crank angle of 0 on the open
// assembly (C above AD), as SolveSpace is given it.
Mechanism four_bar() {
  return parse_mechanism(test::crank_rocker(0.0, "speed = 240\nspeed_unit = \"rpm\"\n").text(),
                         "crank-rocker (tests/common/crank_rocker.h)");
}

// World position of point `name` of link `link` at coordinates q.
Eigen::Vector2d point_at(const Mechanism& m, const Eigen::VectorXd& q, const char* link,
                         const char* name) {
  const int l = m.find_link(link);
  const BodyMotion body = BodyMotion::of(m.moving_index(l), q, nullptr, nullptr);
  return body.position(m.links[l].points[m.links[l].find_point(name)].local);
}

// SolveSpace's model of the four-bar in the xy workplane. Group 1 (fixed): the workplane, the
// pivots A and D, and the point P at the crank angle that sets the crank's direction. Group 2
// (solved): B and C, with |AB| = a, B on line AP, |BC| = b, |DC| = c.
class SolveSpaceFourBar {
 public:
  SolveSpaceFourBar(const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    constexpr Slvs_hGroup g1 = 1, g2 = 2;
    // Workplane: origin (0, 0, 0), normal along z (quaternion 1, 0, 0, 0).
    param(g1, 0);
    param(g1, 0);
    param(g1, 0);
    const Slvs_hEntity origin = entity(Slvs_MakePoint3d(0, g1, 1, 2, 3));
    param(g1, 1);
    param(g1, 0);
    param(g1, 0);
    param(g1, 0);
    const Slvs_hEntity normal = entity(Slvs_MakeNormal3d(0, g1, 4, 5, 6, 7));
    const Slvs_hEntity plane = entity(Slvs_MakeWorkplane(0, g1, origin, normal));
    const Slvs_hEntity a_pt = point(g1, plane, 0, 0);
    const Slvs_hEntity d_pt = point(g1, plane, kD, 0);
    p_index_ = params_.size();
    const Slvs_hEntity p_pt = point(g1, plane, kA, 0);
    b_index_ = params_.size();
    const Slvs_hEntity b_pt = point(g2, plane, b.x(), b.y());
    c_index_ = params_.size();
    const Slvs_hEntity c_pt = point(g2, plane, c.x(), c.y());
    const Slvs_hEntity crank_line = entity(Slvs_MakeLineSegment(0, g1, plane, a_pt, p_pt));

    constraint(g2, SLVS_C_PT_PT_DISTANCE, plane, kA, a_pt, b_pt, 0);
    constraint(g2, SLVS_C_PT_ON_LINE, plane, 0, b_pt, 0, crank_line);
    constraint(g2, SLVS_C_PT_PT_DISTANCE, plane, kB, b_pt, c_pt, 0);
    constraint(g2, SLVS_C_PT_PT_DISTANCE, plane, kC, d_pt, c_pt, 0);

    failed_.resize(constraints_.size());
    system_ = {};
    system_.param = params_.data();
    system_.params = static_cast<int>(params_.size());
    system_.entity = entities_.data();
    system_.entities = static_cast<int>(entities_.size());
    system_.constraint = constraints_.data();
    system_.constraints = static_cast<int>(constraints_.size());
    system_.failed = failed_.data();
    system_.faileds = static_cast<int>(failed_.size());
    system_.calculateFaileds = 0;
  }

  // Solves at crank angle theta [rad] from the last solution; true when SolveSpace converged.
  bool solve(double theta) {
    params_[p_index_].val = kA * std::cos(theta);
    params_[p_index_ + 1].val = kA * std::sin(theta);
    Slvs_Solve(&system_, 2);
    return system_.result == SLVS_RESULT_OKAY;
  }
  Eigen::Vector2d b() const { return {params_[b_index_].val, params_[b_index_ + 1].val}; }
  Eigen::Vector2d c() const { return {params_[c_index_].val, params_[c_index_ + 1].val}; }
  int dof() const { return system_.dof; }

 private:
  Slvs_hParam param(Slvs_hGroup g, double value) {
    const auto h = static_cast<Slvs_hParam>(params_.size() + 1);
    params_.push_back(Slvs_MakeParam(h, g, value));
    return h;
  }
  Slvs_hEntity entity(Slvs_Entity e) {
    e.h = static_cast<Slvs_hEntity>(entities_.size() + 1);
    entities_.push_back(e);
    return e.h;
  }
  Slvs_hEntity point(Slvs_hGroup g, Slvs_hEntity plane, double u, double v) {
    const Slvs_hParam hu = param(g, u), hv = param(g, v);
    return entity(Slvs_MakePoint2d(0, g, plane, hu, hv));
  }
  void constraint(Slvs_hGroup g, int type, Slvs_hEntity plane, double value, Slvs_hEntity pa,
                  Slvs_hEntity pb, Slvs_hEntity ea) {
    const auto h = static_cast<Slvs_hConstraint>(constraints_.size() + 1);
    constraints_.push_back(Slvs_MakeConstraint(h, g, type, plane, value, pa, pb, ea, 0));
  }

  std::vector<Slvs_Param> params_;
  std::vector<Slvs_Entity> entities_;
  std::vector<Slvs_Constraint> constraints_;
  std::vector<Slvs_hConstraint> failed_;
  size_t p_index_ = 0, b_index_ = 0, c_index_ = 0;
  Slvs_System system_{};
};

// Crank angles of the comparison: 1 degree apart from the drawn start, round and round.
double crank_angle(const Mechanism& m, long step) {
  return m.swept().start + static_cast<double>(step % 360) * kDeg;
}

void bench_four_bar_crosslink(benchmark::State& bench) {
  const Mechanism m = four_bar();
  const NewtonSolver solver(m);
  KinematicState state(m);
  if (solver.assemble(state).status != PoseStatus::ok) {
    bench.SkipWithError("four-bar does not assemble");
    return;
  }
  long step = 0, failures = 0;
  for (auto _ : bench) {
    ++step;
    // The crank angle itself is continuous: one more degree each pose.
    state.swept().value = m.swept().start + static_cast<double>(step) * kDeg;
    if (solver.solve_position(state).status != PoseStatus::ok) ++failures;
    benchmark::DoNotOptimize(state.q.data());
  }
  bench.counters["failures"] = static_cast<double>(failures);
  bench.counters["unknowns"] = static_cast<double>(state.q.size());
}

void bench_four_bar_solvespace(benchmark::State& bench) {
  const Mechanism m = four_bar();
  const NewtonSolver solver(m);
  KinematicState state(m);
  if (solver.assemble(state).status != PoseStatus::ok) {
    bench.SkipWithError("four-bar does not assemble");
    return;
  }
  // Same start as crosslink (the drawn branch); then check once round the cycle that both
  // follow the same branch: the largest distance between their C positions.
  SolveSpaceFourBar slvs(point_at(m, state.q, "crank", "B"), point_at(m, state.q, "coupler", "C"));
  double largest_difference = 0.0;
  long failures = 0;
  for (long step = 1; step <= 360; ++step) {
    state.swept().value = crank_angle(m, step) + (step == 360 ? 2 * std::numbers::pi : 0.0);
    if (solver.solve_position(state).status != PoseStatus::ok) ++failures;
    if (!slvs.solve(crank_angle(m, step))) ++failures;
    largest_difference =
        std::max(largest_difference, (slvs.c() - point_at(m, state.q, "coupler", "C")).norm());
  }
  long step = 0;
  for (auto _ : bench) {
    ++step;
    if (!slvs.solve(crank_angle(m, step))) ++failures;
    benchmark::DoNotOptimize(slvs.c());
  }
  bench.counters["failures"] = static_cast<double>(failures);
  bench.counters["dof_left"] = static_cast<double>(slvs.dof());
  bench.counters["max_C_diff_m"] = largest_difference;
}

}  // namespace
}  // namespace crosslink

int main(int argc, char** argv) {
  using namespace crosslink;
  // One pose benchmark per definition found at run time.
  std::vector<std::string> files;
  if (std::filesystem::is_directory("mechanisms"))
    for (const auto& entry : std::filesystem::directory_iterator("mechanisms"))
      if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  if (files.empty())
    fmt::print(stderr, "bench_analytic: no mechanisms/*.toml here; run from the source root\n");
  for (const std::string& path : files) {
    const std::string name = "Pose/" + std::filesystem::path(path).stem().string();
    std::string error;
    std::shared_ptr<PoseCase> c = pose_case(path, error);
    if (c) {
      benchmark::RegisterBenchmark(name.c_str(),
                                   [c](benchmark::State& s) { bench_pose(s, c, false); });
      const std::string with_forces = "PoseForces/" + std::filesystem::path(path).stem().string();
      benchmark::RegisterBenchmark(with_forces.c_str(),
                                   [c](benchmark::State& s) { bench_pose(s, c, true); });
    } else {
      benchmark::RegisterBenchmark(name.c_str(), [error](benchmark::State& s) {
        for (auto _ : s) break;
        s.SkipWithError(error.c_str());
      });
    }
  }
  benchmark::RegisterBenchmark("FourBarPosition/crosslink_newton", bench_four_bar_crosslink);
  benchmark::RegisterBenchmark("FourBarPosition/solvespace", bench_four_bar_solvespace);

  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
