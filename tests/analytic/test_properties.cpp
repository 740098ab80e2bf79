// Properties every bundled mechanism must have, whatever its geometry: it loads with mobility
// one, assembles on the drawn branch and sweeps; the swept positions close the loops; the
// analytic velocities and accelerations are the time derivatives of the swept positions; the
// analytic Jacobian is the derivative of the constraint residual.
//
// The files are globbed at run time (mechanisms/*.toml), so a new definition is covered without
// touching this test. Expected values come from finite differences of the position solution,
// never from the velocity and acceleration solves under test.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

namespace fs = std::filesystem;

// The bundled definitions and the curved slots (mechanisms/cams/).
std::vector<std::string> mechanism_files() {
  std::vector<std::string> files;
  const fs::path folder = fs::path(CROSSLINK_SOURCE_DIR) / "mechanisms";
  for (const fs::path& dir : {folder, folder / "cams"})
    for (const fs::directory_entry& entry : fs::directory_iterator(dir))
      if (entry.is_regular_file() && entry.path().extension() == ".toml")
        files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// The coordinates q = (x, y, theta) per moving link, rebuilt from a trajectory row's outputs:
// theta from the link's angle, the frame origin from the world position of one of its points.
// A row whose outputs disagree with each other (a point read from another link that is not
// where this link's frame puts it) then shows up as a constraint residual.
Eigen::VectorXd coordinates_of(const Mechanism& m, const Trajectory& t, int row) {
  Eigen::VectorXd q(m.coordinate_count());
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const Link& link = m.links[l];
    const double theta = t.angle(row, k);
    const Point& p = link.points.front();
    const auto it = std::find(t.point_names.begin(), t.point_names.end(), p.name);
    const auto c = static_cast<Eigen::Index>(it - t.point_names.begin());
    const Eigen::Vector2d world(t.x(row, c), t.y(row, c));
    q.segment<2>(3 * k) = world - Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local;
    q(3 * k + 2) = theta;
  }
  return q;
}

// Which residual rows are angle equations (prismatic relative angle, angular driver): they are
// compared after multiplying by the mechanism's size, as the solver itself scales them.
Eigen::VectorXd row_lengths(const Mechanism& m) {
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(m.coordinate_count());
  int row = 0;
  for (const Joint& j : m.joints) {
    if (j.type == JointType::prismatic) scale(row + 1) = m.size();
    row += 3 - j.dof();
  }
  if (m.drivers[0].angular()) scale(scale.size() - 1) = m.size();
  return scale;
}

// Each file is loaded and swept once and shared by the tests of its parameter (a sweep with the
// finite-difference checks below is the expensive part).
class EveryMechanism : public testing::TestWithParam<std::string> {
 protected:
  struct Swept {
    Mechanism mechanism;
    Trajectory trajectory;
  };
  void SetUp() override {
    static std::map<std::string, std::unique_ptr<Swept>> cache;
    std::unique_ptr<Swept>& entry = cache[GetParam()];
    if (!entry) {
      entry = std::make_unique<Swept>();
      entry->mechanism = load_mechanism(GetParam());
      entry->trajectory = sweep(entry->mechanism);
    }
    swept_ = entry.get();
  }
  const Swept* swept_ = nullptr;
  const Mechanism& mechanism() const { return swept_->mechanism; }
  const Trajectory& trajectory() const { return swept_->trajectory; }
};

std::string test_name(const testing::TestParamInfo<std::string>& info) {
  return fs::path(info.param).stem().string();
}

INSTANTIATE_TEST_SUITE_P(Bundled, EveryMechanism, testing::ValuesIn(mechanism_files()), test_name);

// Loads, has mobility one, assembles at the drawn position, and sweeps: every sample is usable
// unless the sweep recorded why not (a singular position, a limit, a branch change).
TEST_P(EveryMechanism, AssemblesAndSweeps) {
  const Mechanism& m = mechanism();
  EXPECT_EQ(mobility(m).mobility, 1) << mobility(m).explain();
  const NewtonSolver solver(m);
  KinematicState state(m);
  const SolveReport assembled = solver.assemble(state);
  ASSERT_EQ(assembled.status, PoseStatus::ok) << assembled.message;
  // Assembly only polishes the drawing: no link moves more than 5 % of the size or 5 degrees
  // from its pose (a larger move means the poses show another branch than the one solved).
  const Eigen::VectorXd drawn = solver.drawn_coordinates();
  for (int k = 0; k < m.moving_count(); ++k) {
    EXPECT_LT((state.q.segment<2>(3 * k) - drawn.segment<2>(3 * k)).norm(), 0.05 * m.size())
        << "link " << k;
    EXPECT_LT(std::abs(state.q(3 * k + 2) - drawn(3 * k + 2)), 5.0 * std::numbers::pi / 180.0)
        << "link " << k;
  }

  const Trajectory& t = trajectory();
  ASSERT_GT(t.samples(), 1);
  int ok = 0;
  for (PoseStatus s : t.status) ok += usable(s) ? 1 : 0;
  EXPECT_GE(ok, 2);
  if (ok < t.samples()) {
    EXPECT_FALSE(t.events.empty()) << "unusable samples without an event";
  }
}

// The swept positions satisfy every constraint to the solver's accuracy: |Phi| < 1e-10 size
// (the solver converges to 1e-12 size; the margin covers rebuilding q from the outputs).
TEST_P(EveryMechanism, SweptPositionsCloseTheLoops) {
  const Mechanism& m = mechanism();
  const NewtonSolver solver(m);
  const Eigen::VectorXd lengths = row_lengths(m);
  Eigen::VectorXd phi(m.coordinate_count());
  double worst = 0.0;
  int checked = 0;
  for (int r = 0; r < trajectory().samples(); ++r) {
    if (!usable(trajectory().status[static_cast<size_t>(r)])) continue;
    solver.residual(coordinates_of(m, trajectory(), r), trajectory().along(r), phi);
    worst = std::max(worst, phi.cwiseProduct(lengths).lpNorm<Eigen::Infinity>());
    ++checked;
  }
  EXPECT_GT(checked, 0);
  EXPECT_LT(worst, 1e-10 * m.size());
}

// The sweep follows one branch: between adjacent usable samples no link angle changes by more
// than 30 driver steps' worth (30 deg per degree; the square-root growth next to a toggle stays
// well inside that), unless the sweep recorded an event between them. Angles are unwrapped along
// the sweep, so a jump to another turn or another assembly mode shows here.
TEST_P(EveryMechanism, AnglesAreContinuousAlongTheSweep) {
  const Trajectory& t = trajectory();
  for (int r = 1; r < t.samples(); ++r) {
    if (!usable(t.status[static_cast<size_t>(r)]) || !usable(t.status[static_cast<size_t>(r - 1)]))
      continue;
    const double d0 = std::min(t.along(r - 1), t.along(r)),
                 d1 = std::max(t.along(r - 1), t.along(r));
    const bool explained = std::any_of(t.events.begin(), t.events.end(), [&](const auto& e) {
      return e.driver >= d0 - 1e-9 && e.driver <= d1 + 1e-9;
    });
    if (explained) continue;
    const double step = std::abs(t.along(r) - t.along(r - 1));
    const double bound =
        mechanism().drivers[0].angular() ? 30.0 * step : 30.0 * std::numbers::pi / 180.0;
    for (Eigen::Index c = 0; c < t.angle.cols(); ++c)
      EXPECT_LT(std::abs(t.angle(r, c) - t.angle(r - 1, c)), bound)
          << t.link_names[static_cast<size_t>(c)] << " between driver " << t.along(r - 1) << " and "
          << t.along(r) << " with no event";
  }
}

// Position channels and the velocity and acceleration channels that are their derivatives.
struct ChannelTriple {
  const char* position;
  const char* velocity;
  const char* acceleration;
};

// Velocity and acceleration against central differences in time of the exact position solution
// at t +- h and t +- 2h (h moves the driver by 1e-3 rad, or 1e-3 of the size for a slider).
//
// Tolerance. A central difference D(h) errs by c h^2 + O(h^4) (truncation), so
// D(2h) - D(h) = 3 c h^2: |D(2h) - D(h)| is three times the estimated truncation error of D(h),
// and is the allowance here (the factor 3 covers the O(h^4) remainder). Added to it is the
// round-off of differencing positions solved to 1e-14 of the size: 4 eps / h for a first and
// 16 eps / h^2 for a second difference, eps = 1e-13 of the size (or 1e-13 rad). An analytic
// value off by more than the truncation error cannot pass. Samples whose stencil leaves the
// assembling range (Newton fails) are skipped and counted.
TEST_P(EveryMechanism, VelocityAndAccelerationAreDerivativesOfPosition) {
  const Mechanism& m = mechanism();
  const Trajectory& t = trajectory();
  NewtonOptions tight;
  tight.tolerance = 1e-14;
  const NewtonSolver solver(m, tight);
  KinematicState state(m);
  // Time step: the driver moves by 1e-3 rad (or 1e-3 of the size); a law that is not at
  // constant speed takes the same fraction of its cycle as 1e-3 rad of a turn.
  const double driver_step = m.drivers[0].angular() ? 1e-3 : 1e-3 * m.size();
  const double h = m.drivers[0].law.kind == MotionLaw::Kind::constant_speed
                       ? driver_step / std::abs(m.drivers[0].law.speed)
                       : 1e-3 * m.drivers[0].law.duration / (2.0 * std::numbers::pi);
  ASSERT_GT(h, 0.0);

  std::vector<ChannelTriple> triples;
  std::vector<std::string> names;  // storage for the channel names
  for (const std::string& l : t.link_names)
    for (const char* kind : {"angle.", "omega.", "alpha."}) names.push_back(kind + l);
  for (const std::string& p : t.point_names)
    for (const char* kind : {"x.", "vx.", "ax.", "y.", "vy.", "ay."}) names.push_back(kind + p);
  for (const std::string& s : t.slider_names)
    for (const char* kind : {"s.", "sdot.", "sddot."}) names.push_back(kind + s);
  for (size_t i = 0; i + 2 < names.size(); i += 3)
    triples.push_back({names[i].c_str(), names[i + 1].c_str(), names[i + 2].c_str()});

  Trajectory stencil;
  stencil.resize(m, 5);  // t - 2h, t - h, t, t + h, t + 2h
  const int offsets[5] = {-2, -1, 0, 1, 2};
  int checked = 0, skipped = 0, failures = 0;
  // For the report only: the largest |analytic - D(h)| over the largest value of its kind
  // (angular or linear) anywhere in the sweep.
  double worst_v = 0.0, worst_a = 0.0;
  double peak[2][2] = {{1e-300, 1e-300}, {1e-300, 1e-300}};  // [angular?][velocity, accel]
  for (const ChannelTriple& c : triples) {
    const int angular = Trajectory::quantity_of(c.position) == Quantity::angle ? 1 : 0;
    peak[angular][0] = std::max(peak[angular][0], t.channel(c.velocity)->cwiseAbs().maxCoeff());
    peak[angular][1] = std::max(peak[angular][1], t.channel(c.acceleration)->cwiseAbs().maxCoeff());
  }
  for (int r = 0; r < t.samples(); ++r) {
    if (!usable(t.status[static_cast<size_t>(r)])) continue;
    const Eigen::VectorXd q0 = coordinates_of(m, t, r);
    bool solved = true;
    for (int i = 0; i < 5 && solved; ++i) {
      state.q = q0;
      state.drive_at(m, t.time(r) + offsets[i] * h);
      state.qdot.setZero();
      state.qddot.setZero();
      const SolveReport report = solver.solve_position(state);
      // The stencil must stay on the swept branch: Newton from q0 moves q by O(h) only.
      solved = report.status == PoseStatus::ok &&
               (state.q - q0).lpNorm<Eigen::Infinity>() < 0.1 * std::max(1.0, m.size());
      solver.write_sample(state, report, stencil, i);
    }
    if (!solved) {
      ++skipped;
      continue;
    }
    ++checked;
    for (const ChannelTriple& c : triples) {
      const Eigen::VectorXd f = *stencil.channel(c.position);
      const double analytic_v = (*t.channel(c.velocity))(r);
      const double analytic_a = (*t.channel(c.acceleration))(r);
      const double eps =
          1e-13 * (Trajectory::quantity_of(c.position) == Quantity::angle ? 1.0 : m.size());
      const double d1h = (f(3) - f(1)) / (2 * h), d1_2h = (f(4) - f(0)) / (4 * h);
      const double d2h = (f(3) - 2 * f(2) + f(1)) / (h * h);
      const double d2_2h = (f(4) - 2 * f(2) + f(0)) / (4 * h * h);
      const double tol_v = std::abs(d1_2h - d1h) + 4 * eps / h;
      const double tol_a = std::abs(d2_2h - d2h) + 16 * eps / (h * h);
      const int angular = Trajectory::quantity_of(c.position) == Quantity::angle ? 1 : 0;
      const double peak_v = peak[angular][0], peak_a = peak[angular][1];
      worst_v = std::max(worst_v, std::abs(analytic_v - d1h) / peak_v);
      worst_a = std::max(worst_a, std::abs(analytic_a - d2h) / peak_a);
      if (std::abs(analytic_v - d1h) > tol_v || std::abs(analytic_a - d2h) > tol_a) {
        if (++failures <= 5)
          ADD_FAILURE() << c.velocity << " / " << c.acceleration << " at driver " << t.along(r)
                        << ": analytic " << analytic_v << ", " << analytic_a << "; differences "
                        << d1h << " (tol " << tol_v << "), " << d2h << " (tol " << tol_a << ")";
      }
    }
  }
  RecordProperty("worst_velocity_error_of_peak", std::to_string(worst_v));
  RecordProperty("worst_acceleration_error_of_peak", std::to_string(worst_a));
  EXPECT_EQ(failures, 0);
  // The stencil may only fail next to an assembling limit or a singular position.
  EXPECT_GT(checked, 0);
  EXPECT_LE(skipped, 4) << "stencils that left the branch";
}

// The analytic Jacobian against central differences of NewtonSolver::residual, coordinate by
// coordinate, at every usable sample. Step 1e-6 (of the size for x, y; rad for theta):
// truncation ~1e-12 and round-off ~1e-10 relative, so 1e-7 (times the size for angle columns,
// whose entries are lever arms) separates a wrong entry from difference noise.
TEST_P(EveryMechanism, JacobianIsDerivativeOfResidual) {
  const Mechanism& m = mechanism();
  const NewtonSolver solver(m);
  const int n = m.coordinate_count();
  Eigen::MatrixXd analytic(n, n), numeric(n, n);
  Eigen::VectorXd plus(n), minus(n);
  double worst = 0.0;
  int checked = 0;
  for (int r = 0; r < trajectory().samples(); ++r) {
    if (!usable(trajectory().status[static_cast<size_t>(r)])) continue;
    const Eigen::VectorXd q = coordinates_of(m, trajectory(), r);
    const double d = trajectory().along(r);
    solver.jacobian(q, analytic);
    for (int j = 0; j < n; ++j) {
      const bool angle = j % 3 == 2;
      const double step = angle ? 1e-6 : 1e-6 * m.size();
      Eigen::VectorXd qj = q;
      qj(j) += step;
      solver.residual(qj, d, plus);
      qj(j) -= 2 * step;
      solver.residual(qj, d, minus);
      numeric.col(j) = (plus - minus) / (2 * step);
      const double error =
          (analytic.col(j) - numeric.col(j)).lpNorm<Eigen::Infinity>() / (angle ? m.size() : 1.0);
      worst = std::max(worst, error);
    }
    ++checked;
  }
  EXPECT_GT(checked, 0);
  EXPECT_LT(worst, 1e-7);
}

}  // namespace
}  // namespace crosslink
