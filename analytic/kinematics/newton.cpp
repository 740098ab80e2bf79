#include "analytic/kinematics/newton.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "analytic/model/planar.h"

namespace crosslink {

KinematicState::KinematicState(const Mechanism& mechanism) {
  const int n = mechanism.coordinate_count();
  q.setZero(n);
  qdot.setZero(n);
  qddot.setZero(n);
  qdddot.setZero(n);
  phi.setZero(n);
  rhs.setZero(n);
  jacobian = SparseJacobian(ConstraintLayout(mechanism), n);
  lu = SmallLU(n, jacobian.nonzeros());
  q_start.setZero(n);
  estimate.setZero(n);
  estimate_rhs.setZero(n);
  sign.setZero(n);
  previous_sign.setZero(n);
  cos_theta.setOnes(mechanism.moving_count());
  sin_theta.setZero(mechanism.moving_count());
  drivers.resize(mechanism.drivers.size());
  axis = mechanism.axis();
}

void KinematicState::set_parameter(const Mechanism& mechanism, double p) {
  if (axis.timed())
    drive_at(mechanism, p);
  else
    swept().value = p;
}

void KinematicState::drive_at(const Mechanism& mechanism, double t) {
  for (size_t d = 0; d < drivers.size(); ++d) drivers[d] = mechanism.drivers[d].at_time(t);
}

namespace {
// Room for the factors: a matrix this small may fill completely (n (n - 1) / 2 each of L and
// U, as the dense loops had); a larger one is a chain whose factors hold a few times its
// entries, and grows its room the once it needs more.
constexpr int kDenseRoom = 64;
constexpr double kPi = std::numbers::pi;
int factor_room(int n, int nonzeros) {
  return n <= kDenseRoom ? n * (n - 1) / 2 : 4 * nonzeros + n;
}
}  // namespace

SmallLU::SmallLU(int size, int nonzeros) : n_(size) {
  const auto n = static_cast<size_t>(size);
  const auto room = static_cast<size_t>(factor_room(size, nonzeros));
  l_start_.assign(n + 1, 0);
  u_start_.assign(n + 1, 0);
  l_rows_.assign(room, 0);
  u_rows_.assign(room, 0);
  l_values_.assign(room, 0.0);
  u_values_.assign(room, 0.0);
  transpositions_.assign(n, 0);
  diagonal_.assign(n, 0.0);
  inverse_diagonal_.assign(n, 0.0);
  work_.assign(n, 0.0);
  pivot_step_.assign(n, -1);
  place_.assign(n, 0);
  row_at_.assign(n, 0);
  touched_.assign(n, 0);
  heap_.assign(n, 0);
  pivot_row_.assign(n, 0);
  seen_.assign(n, 0);
}

void SmallLU::factorize(const SparseJacobian& a) {
  // Left-looking: for each column j, x = (P A)(:, j) with L's columns k < j applied in
  // increasing k (x_k, final by then, is U(k, j)), then the pivot among the rows not yet
  // pivoted. A right-looking elimination (Eigen's unblocked LU, dgetf2) applies the same
  // updates to each entry in the same order, skipping the same zeros, so the numbers are
  // identical. Rows are kept by their index in A; `place_` follows the swaps, which decide ties.
  const int n = n_;
  double* x = work_.data();
  int* step_of = pivot_step_.data();
  int *place = place_.data(), *row_at = row_at_.data();
  for (int i = 0; i < n; ++i) {
    step_of[i] = -1;
    place[i] = i;
    row_at[i] = i;
  }
  int l_count = 0, u_count = 0;
  for (int j = 0; j < n; ++j) {
    l_start_[static_cast<size_t>(j)] = l_count;
    u_start_[static_cast<size_t>(j)] = u_count;
    // Scatter column j; note the rows it reaches and the pivoted ones' steps.
    int touched = 0, heap = 0;
    auto reach = [&](int row) {
      if (seen_[static_cast<size_t>(row)]) return;
      seen_[static_cast<size_t>(row)] = 1;
      touched_[static_cast<size_t>(touched++)] = row;
      if (step_of[row] >= 0) {
        heap_[static_cast<size_t>(heap++)] = step_of[row];
        std::push_heap(heap_.begin(), heap_.begin() + heap, std::greater<>());
      }
    };
    for (int e = a.column_start(j); e < a.column_start(j + 1); ++e) {
      const int row = a.row_index(e);
      x[row] = a.value(e);
      reach(row);
    }
    // L's earlier columns, in increasing step: each discovers later steps only.
    while (heap > 0) {
      std::pop_heap(heap_.begin(), heap_.begin() + heap, std::greater<>());
      const int k = heap_[static_cast<size_t>(--heap)];
      const double u = x[pivot_row_[static_cast<size_t>(k)]];
      if (u == 0.0) continue;
      if (u_count == static_cast<int>(u_rows_.size())) grow();
      u_rows_[static_cast<size_t>(u_count)] = k;
      u_values_[static_cast<size_t>(u_count++)] = u;
      for (int e = l_start_[static_cast<size_t>(k)]; e < l_start_[static_cast<size_t>(k) + 1];
           ++e) {
        const int row = l_rows_[static_cast<size_t>(e)];
        reach(row);
        x[row] -= l_values_[static_cast<size_t>(e)] * u;
      }
    }
    // The pivot: the largest magnitude among the rows not pivoted, the first place on ties;
    // the row at place j first (dgetf2 starts its search there, even at a zero).
    int pivot = row_at[j];
    double biggest = std::abs(seen_[static_cast<size_t>(pivot)] ? x[pivot] : 0.0);
    for (int t = 0; t < touched; ++t) {
      const int row = touched_[static_cast<size_t>(t)];
      if (step_of[row] >= 0) continue;
      const double magnitude = std::abs(x[row]);
      if (magnitude > biggest || (magnitude == biggest && place[row] < place[pivot])) {
        biggest = magnitude;
        pivot = row;
      }
    }
    const double diagonal = seen_[static_cast<size_t>(pivot)] ? x[pivot] : 0.0;
    transpositions_[static_cast<size_t>(j)] = place[pivot];
    {  // swap the places of the row at j and the pivot row
      const int other = row_at[j], at = place[pivot];
      row_at[at] = other;
      place[other] = at;
      row_at[j] = pivot;
      place[pivot] = j;
    }
    step_of[pivot] = j;
    pivot_row_[static_cast<size_t>(j)] = pivot;
    diagonal_[static_cast<size_t>(j)] = diagonal;
    inverse_diagonal_[static_cast<size_t>(j)] = 1.0 / diagonal;
    // L's column j: the other rows reached, scaled by the pivot's reciprocal (as dgetf2), the
    // nonzeros only. With a zero pivot the column is singular and eliminates nothing.
    if (biggest != 0.0) {
      const double inverse_pivot = 1.0 / diagonal;
      for (int t = 0; t < touched; ++t) {
        const int row = touched_[static_cast<size_t>(t)];
        if (step_of[row] >= 0) continue;
        const double l = x[row] * inverse_pivot;
        if (l == 0.0) continue;
        if (l_count == static_cast<int>(l_rows_.size())) grow();
        l_rows_[static_cast<size_t>(l_count)] = row;
        l_values_[static_cast<size_t>(l_count++)] = l;
      }
    }
    for (int t = 0; t < touched; ++t) {
      const int row = touched_[static_cast<size_t>(t)];
      x[row] = 0.0;
      seen_[static_cast<size_t>(row)] = 0;
    }
  }
  l_start_[static_cast<size_t>(n)] = l_count;
  u_start_[static_cast<size_t>(n)] = u_count;
  // L's rows by their final place, increasing within each column (insertion sort: a column
  // holds a few entries).
  for (int j = 0; j < n; ++j) {
    const int begin = l_start_[static_cast<size_t>(j)], end = l_start_[static_cast<size_t>(j) + 1];
    for (int e = begin; e < end; ++e) {
      const int row = place[l_rows_[static_cast<size_t>(e)]];
      const double value = l_values_[static_cast<size_t>(e)];
      int i = e;
      for (; i > begin && l_rows_[static_cast<size_t>(i) - 1] > row; --i) {
        l_rows_[static_cast<size_t>(i)] = l_rows_[static_cast<size_t>(i) - 1];
        l_values_[static_cast<size_t>(i)] = l_values_[static_cast<size_t>(i) - 1];
      }
      l_rows_[static_cast<size_t>(i)] = row;
      l_values_[static_cast<size_t>(i)] = value;
    }
  }
}

Eigen::MatrixXd SmallLU::packed() const {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(n_, n_);
  for (int j = 0; j < n_; ++j) {
    out(j, j) = diagonal_[static_cast<size_t>(j)];
    for (int e = l_start_[static_cast<size_t>(j)]; e < l_start_[static_cast<size_t>(j) + 1]; ++e)
      out(l_rows_[static_cast<size_t>(e)], j) = l_values_[static_cast<size_t>(e)];
    for (int e = u_start_[static_cast<size_t>(j)]; e < u_start_[static_cast<size_t>(j) + 1]; ++e)
      out(u_rows_[static_cast<size_t>(e)], j) = u_values_[static_cast<size_t>(e)];
  }
  return out;
}

double SmallLU::determinant() const {
  double product = n_ > 0 ? diagonal_[0] : 1.0;
  int swaps = 0;
  for (int j = 0; j < n_; ++j) {
    if (j > 0) product *= diagonal_[static_cast<size_t>(j)];
    swaps += transpositions_[static_cast<size_t>(j)] != j;
  }
  return (swaps % 2 ? -1.0 : 1.0) * product;
}

void SmallLU::grow() {
  const size_t room = 2 * l_rows_.size() + static_cast<size_t>(n_);
  l_rows_.resize(room);
  u_rows_.resize(room);
  l_values_.resize(room);
  u_values_.resize(room);
}

void SmallLU::solve_in_place(double* b) const {
  // P b, then L (unit lower) and U by column-oriented substitution.
  const int n = n_;
  const int *l_start = l_start_.data(), *l_rows = l_rows_.data();
  const int *u_start = u_start_.data(), *u_rows = u_rows_.data();
  const double *l_values = l_values_.data(), *u_values = u_values_.data();
  for (int k = 0; k < n; ++k)
    if (transpositions_[static_cast<size_t>(k)] != k)
      std::swap(b[k], b[transpositions_[static_cast<size_t>(k)]]);
  // As Eigen's column-major triangular solves, a column whose unknown is zero is skipped.
  for (int j = 0; j < n; ++j) {
    const double x = b[j];
    if (x == 0.0) continue;
    for (int e = l_start[j]; e < l_start[j + 1]; ++e) b[l_rows[e]] -= l_values[e] * x;
  }
  for (int j = n - 1; j >= 0; --j) {
    if (b[j] == 0.0) continue;
    const double x = b[j] *= inverse_diagonal_[static_cast<size_t>(j)];
    for (int e = u_start[j]; e < u_start[j + 1]; ++e) b[u_rows[e]] -= u_values[e] * x;
  }
}

void SmallLU::solve_transposed_in_place(double* b) const {
  // A^-T = P^T L^-T U^-T: U^T and L^T by dot products down the columns, then P^T.
  const int n = n_;
  const int *l_start = l_start_.data(), *l_rows = l_rows_.data();
  const int *u_start = u_start_.data(), *u_rows = u_rows_.data();
  const double *l_values = l_values_.data(), *u_values = u_values_.data();
  for (int j = 0; j < n; ++j) {
    double sum = b[j];
    for (int e = u_start[j]; e < u_start[j + 1]; ++e) sum -= u_values[e] * b[u_rows[e]];
    b[j] = sum * inverse_diagonal_[static_cast<size_t>(j)];
  }
  for (int j = n - 1; j >= 0; --j) {
    double sum = b[j];
    for (int e = l_start[j]; e < l_start[j + 1]; ++e) sum -= l_values[e] * b[l_rows[e]];
    b[j] = sum;
  }
  for (int k = n - 1; k >= 0; --k)
    if (transpositions_[static_cast<size_t>(k)] != k)
      std::swap(b[k], b[transpositions_[static_cast<size_t>(k)]]);
}

NewtonSolver::NewtonSolver(const Mechanism& mechanism, NewtonOptions options)
    : mechanism_(mechanism),
      options_(options),
      layout_(mechanism),
      length_scale_(mechanism.size()),
      named_points_(mechanism.named_points()),
      slide_joints_(mechanism.slide_joints()),
      solves_jerk_(!cam_readings(mechanism).empty()) {
  for (size_t j = 0; j < mechanism.joints.size(); ++j)
    if (mechanism.joints[j].type == JointType::pin_in_spline)
      spline_slots_.push_back(static_cast<int>(j));
  // A square system: one driver row per freedom (the loader refuses a mobility other than the
  // number of drivers).
  if (layout_.rows() != mechanism.coordinate_count())
    throw std::invalid_argument(
        fmt::format("the Newton solver takes as many drivers as freedoms: {} rows for {} "
                    "coordinates",
                    layout_.rows(), mechanism.coordinate_count()));
  // Rows that are angle equations are scaled by the mechanism's size and angle columns by its
  // inverse, so every row and column of the solved system is in metres: the LU's pivoting and
  // its condition estimate then do not depend on the file's units.
  const int n = mechanism.coordinate_count();
  row_scale_.setOnes(n);
  col_scale_.setOnes(n);
  for (int k = 0; k < mechanism.moving_count(); ++k) col_scale_(3 * k + 2) = 1.0 / length_scale_;
  for (int r = 0; r < std::min(n, layout_.rows()); ++r)
    if (layout_.angle_row(r)) row_scale_(r) = length_scale_;
  for (int r = 0; r < n; ++r)
    if (row_scale_(r) != 1.0) scaled_rows_.push_back(r);
}

double NewtonSolver::driver_value(const Eigen::VectorXd& q, int d) const {
  return layout_.driver(d).value(LinkFrames{q});
}

void NewtonSolver::update_frames(KinematicState& state) const {
  // sincos: glibc's sin and cos in one call (one argument reduction), the same numbers.
  for (Eigen::Index k = 0; k < state.cos_theta.size(); ++k)
    ::sincos(state.q(3 * k + 2), &state.sin_theta(k), &state.cos_theta(k));
}

void NewtonSolver::residual(const Eigen::VectorXd& q, double driver_value,
                            Eigen::VectorXd& phi) const {
  // One driver's value: a chain of several would read past it (the list overload takes theirs).
  if (layout_.driver_count() != 1)
    throw std::logic_error(
        fmt::format("NewtonSolver::residual: one driver's value for a chain of {} drivers",
                    layout_.driver_count()));
  const DriverState driver{0.0, driver_value, 0.0, 0.0};
  layout_.residual(LinkFrames{q}, {&driver, 1}, phi);
}

void NewtonSolver::residual(const Eigen::VectorXd& q, std::span<const DriverState> drivers,
                            Eigen::VectorXd& phi) const {
  layout_.residual(LinkFrames{q}, drivers, phi);
}

void NewtonSolver::jacobian(const Eigen::VectorXd& q, Eigen::MatrixXd& jac) const {
  layout_.jacobian(LinkFrames{q}, jac);
}

namespace {
// The L1 norm of a column-compressed matrix, max_c sum_r |a_rc|, summed as Eigen sums a dense
// column of n entries (two packets of two doubles: entry i into lane i mod 4 up to the last
// multiple of 4, a packet of two after it, one entry last; the lanes combined as Eigen's redux
// does), so it is the dense cwiseAbs().colwise().sum().maxCoeff() bit for bit: the zeros the
// sparse column leaves out add nothing exactly.
double l1_norm(const SparseJacobian& a) {
  const int n = a.rows();
  const int lanes_end = n / 4 * 4, pair_end = n / 2 * 2;
  double norm = 0.0;
  for (int c = 0; c < a.cols(); ++c) {
    double lane[4] = {0.0, 0.0, 0.0, 0.0}, pair[2] = {0.0, 0.0}, last = 0.0;
    for (int e = a.column_start(c); e < a.column_start(c + 1); ++e) {
      const int r = a.row_index(e);
      const double v = std::abs(a.value(e));
      if (r < lanes_end)
        lane[r % 4] += v;
      else if (r < pair_end)
        pair[r - lanes_end] += v;
      else
        last += v;
    }
    const double sum = (((lane[0] + lane[2]) + pair[0]) + ((lane[1] + lane[3]) + pair[1])) + last;
    norm = std::max(norm, sum);
  }
  return norm;
}
}  // namespace

void NewtonSolver::factorize(KinematicState& state) const {
  // state's frames must be those of state.q (update_frames).
  SparseJacobian& jac = state.jacobian;
  layout_.jacobian(frames(state), jac);
  // S_r J S_c: only angle rows and angle columns have a scale other than 1 (rows first, as the
  // dense matrix was scaled).
  for (int c = 0; c < jac.cols(); ++c)
    for (int e = jac.column_start(c); e < jac.column_start(c + 1); ++e) {
      const int r = jac.row_index(e);
      if (row_scale_(r) != 1.0) jac.value(e) *= row_scale_(r);
      if (c % 3 == 2) jac.value(e) *= col_scale_(c);
    }
  state.jacobian_norm = l1_norm(jac);
  state.lu.factorize(jac);
}

double NewtonSolver::rcond(KinematicState& state) const {
  // Eigen's rcond_estimate_helper and rcond_invmatrix_L1_norm_estimate (Higham's Algorithms 4.1
  // and 5.1, as in LAPACK) step by step, in the state's scratch vectors so that the estimate
  // allocates nothing; it returns exactly what state.lu.rcond() would.
  const Eigen::Index n = state.q.size();
  if (n == 0) return std::numeric_limits<double>::infinity();
  if (state.jacobian_norm == 0.0) return 0.0;
  if (n == 1) return 1.0;
  const SmallLU& lu = state.lu;
  Eigen::VectorXd& v = state.estimate;
  // v = J^-1 b and v = J^-T b, with PJ = LU (b is read from estimate_rhs).
  auto solve = [&] {
    v = state.estimate_rhs;
    lu.solve_in_place(v.data());
  };
  auto solve_transposed = [&] {
    lu.solve_transposed_in_place(state.estimate_rhs.data());
    v = state.estimate_rhs;
  };

  state.estimate_rhs.setConstant(1.0 / static_cast<double>(n));
  solve();
  double lower_bound = v.lpNorm<1>();
  double old_lower_bound = lower_bound;
  Eigen::Index v_max_abs_index = -1, old_v_max_abs_index = -1;
  for (int k = 0; k < 4; ++k) {
    for (Eigen::Index i = 0; i < n; ++i) state.sign(i) = v(i) < 0.0 ? -1.0 : 1.0;
    if (k > 0 && state.sign == state.previous_sign) break;
    state.estimate_rhs = state.sign;
    solve_transposed();
    v.cwiseAbs().maxCoeff(&v_max_abs_index);
    if (v_max_abs_index == old_v_max_abs_index) break;
    state.estimate_rhs.setZero();
    state.estimate_rhs(v_max_abs_index) = 1.0;
    solve();  // v = J^-1 e_j
    lower_bound = v.lpNorm<1>();
    if (lower_bound <= old_lower_bound) break;
    state.previous_sign = state.sign;
    old_v_max_abs_index = v_max_abs_index;
    old_lower_bound = lower_bound;
  }
  double alternating_sign = 1.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    state.estimate_rhs(i) =
        alternating_sign * (1.0 + static_cast<double>(i) / static_cast<double>(n - 1));
    alternating_sign = -alternating_sign;
  }
  solve();
  const double alternate_lower_bound = (2.0 * v.lpNorm<1>()) / (3.0 * static_cast<double>(n));
  // A zero pivot (an exactly singular Jacobian, e.g. a chain drawn all on one line) gives
  // infinite or NaN solves: the condition number is infinite.
  if (!std::isfinite(lower_bound) || !std::isfinite(alternate_lower_bound)) return 0.0;
  const double inverse_norm = std::max(lower_bound, alternate_lower_bound);
  return inverse_norm == 0.0 ? 0.0 : (1.0 / inverse_norm) / state.jacobian_norm;
}

void NewtonSolver::solve_linear(KinematicState& state, Eigen::VectorXd& x) const {
  // J x = rhs  <=>  (S_r J S_c) y = S_r rhs,  x = S_c y
  x = state.rhs.cwiseProduct(row_scale_);
  state.lu.solve_in_place(x.data());
  x.array() *= col_scale_.array();
}

void NewtonSolver::multipliers(KinematicState& state, const Eigen::VectorXd& b,
                               Eigen::VectorXd& lambda) const {
  // J^T lambda = b  <=>  (S_r J S_c)^T mu = S_c b,  lambda = S_r mu
  lambda = b.cwiseProduct(col_scale_);
  state.lu.solve_transposed_in_place(lambda.data());
  lambda.array() *= row_scale_.array();
}

double NewtonSolver::scaled_norm(const Eigen::VectorXd& phi) const {
  return phi.cwiseProduct(row_scale_).lpNorm<Eigen::Infinity>();
}

namespace {

// Chord iterations are tried only from factors at a well-conditioned solved pose, and at most
// this many; each must shrink the residual at least by half, and the first step must be small
// against the mechanism (size-free: lengths / size, angles in rad).
constexpr double kChordRcond = 1e-6;
constexpr int kChordIterations = 5;
constexpr double kChordContraction = 0.5;
constexpr double kChordFirstStep = 0.1;

}  // namespace

double NewtonSolver::size_free_norm(const Eigen::VectorXd& v) const {
  double largest = 0.0;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    largest = std::max(largest, std::abs(v(i)) / (i % 3 == 2 ? 1.0 : length_scale_));
  return largest;
}

bool NewtonSolver::round_off_step(const Eigen::VectorXd& dq, const Eigen::VectorXd& q) const {
  constexpr double kRoundOffSteps = 16.0;  // eps of the coordinates' magnitude
  return size_free_norm(dq) <=
         kRoundOffSteps * std::numeric_limits<double>::epsilon() * std::max(1.0, size_free_norm(q));
}

bool NewtonSolver::chord(KinematicState& state, double tolerance, SolveReport& report) const {
  // Simplified Newton: J(q0) dq = -Phi(q) with the factors of J at the last solved pose q0.
  // From a sweep's predictor the correction is tiny and J(q0) close to J(q), so this contracts
  // fast and costs a residual and a forward/back substitution per iteration, no factorisation.
  state.q_start = state.q;
  double previous = std::numeric_limits<double>::infinity();
  for (int it = 0;; ++it) {
    update_frames(state);
    layout_.residual(frames(state), state.drivers, state.phi);
    const double residual = scaled_norm(state.phi);
    report.iterations = it;
    report.residual = residual;
    if (residual <= tolerance) return true;
    if (!(residual <= kChordContraction * previous) || it == kChordIterations) break;
    state.rhs = -state.phi;
    solve_linear(state, state.qddot);  // qddot is free scratch until the acceleration solve
    if (!state.qddot.allFinite()) break;
    if (it == 0 && size_free_norm(state.qddot) > kChordFirstStep) break;
    state.q += state.qddot;
    previous = residual;
  }
  // Not contracting: Newton takes over from where the chord iteration began.
  state.q = state.q_start;
  return false;
}

SolveReport NewtonSolver::solve_position(KinematicState& state) const {
  SolveReport report;
  const double tolerance = options_.tolerance * length_scale_;
  if (state.factorized && state.factorized_rcond >= kChordRcond &&
      chord(state, tolerance, report)) {
    // Converged: one factorisation, at the solution (for rcond, velocity and acceleration).
    factorize(state);
    report.rcond = rcond(state);
    state.factorized_rcond = report.rcond;
    if (report.rcond < options_.singular_rcond) {
      report.status = PoseStatus::singular;
      report.message =
          fmt::format("Jacobian singular at the solution (rcond {:.2e})", report.rcond);
    }
    return report;
  }
  state.factorized = false;
  bool round_off = false;  // the last step moved q by round-off only
  for (int it = 0; it <= options_.max_iterations; ++it) {
    // Phi and J at this q share one evaluation of every link's cos and sin.
    update_frames(state);
    layout_.residual(frames(state), state.drivers, state.phi);
    report.residual = scaled_norm(state.phi);
    report.iterations = it;
    factorize(state);
    // The condition estimate costs several solves: taken only where the loop ends.
    if (!std::isfinite(report.residual)) {
      report.rcond = rcond(state);
      break;
    }
    if (report.residual <= tolerance || round_off) {
      report.rcond = rcond(state);
      state.factorized = true;
      state.factorized_rcond = report.rcond;
      if (report.rcond < options_.singular_rcond) {
        report.status = PoseStatus::singular;
        report.message =
            fmt::format("Jacobian singular at the solution (rcond {:.2e})", report.rcond);
      }
      return report;
    }
    // Newton step: J dq = -Phi
    state.rhs = -state.phi;
    solve_linear(state, state.qddot);  // qddot is free scratch until the acceleration solve
    if (!state.qddot.allFinite()) {
      report.rcond = rcond(state);
      break;
    }
    if (it == options_.max_iterations) report.rcond = rcond(state);
    round_off = round_off_step(state.qddot, state.q);
    state.q += state.qddot;
  }
  report.status = PoseStatus::no_convergence;
  report.message = fmt::format("Newton did not converge in {} iterations (|Phi| = {:.3e})",
                               options_.max_iterations, report.residual);
  return report;
}

SolveReport NewtonSolver::polish(KinematicState& state, SolveReport report) const {
  if (report.status != PoseStatus::ok && report.status != PoseStatus::singular) return report;
  auto residual_at = [&](const Eigen::VectorXd& q) {
    state.q = q;
    update_frames(state);
    layout_.residual(frames(state), state.drivers, state.phi);
    return scaled_norm(state.phi);
  };
  Eigen::VectorXd best = state.q;
  double best_residual = residual_at(best);
  for (int it = 0; it < 3 && best_residual > 0.0; ++it) {
    factorize(state);  // at `best`, whose Phi is in state.phi
    state.rhs = -state.phi;
    solve_linear(state, state.qddot);
    if (!state.qddot.allFinite()) break;
    // A correction of round-off size only: near a singular position a full step along the
    // Jacobian's near-null direction can leap to another pose with the same residual (a link
    // turned by whole turns).
    if (!(size_free_norm(state.qddot) <= 1e-6)) break;
    const Eigen::VectorXd next = best + state.qddot;
    const double r = residual_at(next);
    if (!(r < best_residual)) break;
    best = next;
    best_residual = r;
  }
  state.q = best;
  update_frames(state);
  factorize(state);
  report.residual = best_residual;
  report.rcond = rcond(state);
  state.factorized = true;
  state.factorized_rcond = report.rcond;
  if (report.rcond < options_.singular_rcond) {
    report.status = PoseStatus::singular;
    report.message = fmt::format("Jacobian singular at the solution (rcond {:.2e})", report.rcond);
  } else if (report.status == PoseStatus::singular) {
    report.status = PoseStatus::ok;
    report.message.clear();
  }
  return report;
}

void NewtonSolver::solve_velocity(KinematicState& state) const {
  layout_.velocity_rhs(state.drivers, state.rhs);
  solve_linear(state, state.qdot);
}

void NewtonSolver::solve_acceleration(KinematicState& state) const {
  update_frames(state);  // state.q may have changed since the last factorisation
  acceleration_at_frames(state);
}

void NewtonSolver::acceleration_at_frames(KinematicState& state) const {
  layout_.acceleration_rhs(frames(state), state.qdot, state.drivers, state.rhs);
  solve_linear(state, state.qddot);
  if (!solves_jerk_) return;
  layout_.jerk_rhs(frames(state), state.qdot, state.qddot, state.drivers, state.rhs);
  solve_linear(state, state.qdddot);
}

SolveReport NewtonSolver::solve(KinematicState& state) const {
  SolveReport report = solve_position(state);
  if (report.status == PoseStatus::ok) {
    solve_velocity(state);
    acceleration_at_frames(state);  // solve_position ends with the frames of state.q
  } else {
    state.qdot.setZero();
    state.qddot.setZero();
    state.qdddot.setZero();
  }
  return report;
}

Eigen::VectorXd NewtonSolver::drawn_coordinates() const {
  const Mechanism& m = mechanism_;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m.coordinate_count());
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k >= 0 && m.links[l].pose) q.segment<3>(3 * k) = *m.links[l].pose;
  }
  return q;
}

// A driver's start is taken modulo a turn against the drawing: a link drawn at -87.7 deg with
// its driver starting at 272.3 deg is the drawn pose, not a pose a turn away that Newton would
// reach by a 2 pi step onto any assembly (a 3-RRR landed on another one). The driven link's
// angle is moved by the whole turns between them, where that moves no other row's residual (a
// gear pair's rows do not repeat over one turn of one gear: there it stays as drawn).
void NewtonSolver::unwind_to_drivers(Eigen::VectorXd& q, std::span<const DriverState> at) const {
  const int n = static_cast<int>(q.size());
  Eigen::VectorXd before(n), after(n);
  for (int d = 0; d < layout_.driver_count(); ++d) {
    const ConstraintRows& row = layout_.driver(d);
    if (row.kind != ConstraintRows::Kind::angle_driver) continue;
    const double turns =
        std::round((at[static_cast<size_t>(d)].value - row.value(LinkFrames{q})) / (2.0 * kPi));
    if (turns == 0.0 || (row.a < 0 && row.b < 0)) continue;
    const Eigen::Index angle = row.b >= 0 ? 3 * row.b + 2 : 3 * row.a + 2;
    residual(q, at, before);
    const double saved = q(angle);
    q(angle) += (row.b >= 0 ? 2.0 : -2.0) * kPi * turns;
    residual(q, at, after);
    after(layout_.driver_row(d)) = before(layout_.driver_row(d)) = 0.0;
    if ((after - before).cwiseProduct(row_scale_).lpNorm<Eigen::Infinity>() > 1e-9 * length_scale_)
      q(angle) = saved;
  }
}

// The joints' rows at a drawing where J is singular: regular (their singular values in a ratio
// above this) at a toggle, rank-deficient at a change point.
constexpr double kFoldJoints = 1.5e-8;  // sqrt(eps)

SolveReport NewtonSolver::assemble(KinematicState& state) const {
  state.q = drawn_coordinates();
  state.drive_at(mechanism_, 0.0);
  unwind_to_drivers(state.q, state.drivers);
  // Drawn at a singular position, J is singular at the drawing and Newton's first step leaps
  // along its null direction (a Grashof-equality four-bar drawn on its change point and started
  // 1e-4 deg on: the coupler went to 3.5e11 deg). Levenberg–Marquardt's damped steps go first.
  update_frames(state);
  factorize(state);
  const double drawn_rcond = rcond(state);
  const bool drawn_singular = !(drawn_rcond >= options_.singular_rcond);
  SolveReport report;
  report.status = PoseStatus::no_convergence;
  state.factorized = false;
  if (!drawn_singular) report = solve_position(state);
  if (report.status == PoseStatus::no_convergence) {
    // Newton failed from the drawing, or was not tried there. Levenberg–Marquardt minimises
    // |Phi|^2 instead: a minimum with a residual left means the chain cannot close here; a zero
    // residual gets a fresh Newton.
    state.q = drawn_coordinates();
    unwind_to_drivers(state.q, state.drivers);
    const int n = static_cast<int>(state.q.size());
    double lambda = 1e-3;
    Eigen::VectorXd phi(n), trial_phi(n), step(n), trial(n);
    Eigen::MatrixXd jac(n, n);
    residual(state.q, state.drivers, phi);
    for (int it = 0; it < 500; ++it) {
      jacobian(state.q, jac);
      jac.array().colwise() *= row_scale_.array();
      const Eigen::VectorXd scaled_phi = phi.cwiseProduct(row_scale_);
      const Eigen::MatrixXd normal = jac.transpose() * jac;
      const Eigen::VectorXd gradient = jac.transpose() * scaled_phi;
      if (gradient.lpNorm<Eigen::Infinity>() < 1e-14 * length_scale_ * length_scale_) break;
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += lambda * normal.diagonal().cwiseMax(1e-12);
      step = -damped.ldlt().solve(gradient);
      trial = state.q + step;
      residual(trial, state.drivers, trial_phi);
      if (scaled_norm(trial_phi) < scaled_norm(phi) ||
          trial_phi.cwiseProduct(row_scale_).squaredNorm() < scaled_phi.squaredNorm()) {
        state.q = trial;
        phi = trial_phi;
        lambda = std::max(lambda / 3.0, 1e-12);
        if (step.lpNorm<Eigen::Infinity>() < 1e-15 * length_scale_) break;
      } else {
        lambda *= 4.0;
        if (lambda > 1e12) break;
      }
    }
    report = solve_position(state);
    if (report.status == PoseStatus::no_convergence) {
      report.status = PoseStatus::cannot_assemble;
      report.message = fmt::format(
          "the chain cannot be assembled at the driver's start value: the closest it comes "
          "leaves a loop gap of {:.3e} m",
          scaled_norm(phi));
    }
  }
  // Drawn on a toggle (J singular at the drawing, the joints' rows regular: a fold, not a change
  // point) and started off it: two assemblies meet in the drawn pose, so it does not say which
  // one the chain takes at the start (a four-bar drawn on its toggle and started 1e-9 deg inside
  // was swept on its other assembly). Started on the toggle to within the tolerance, the two are
  // one pose there: J's rcond at the start, which grows as the square root of the distance from
  // the fold, is below sqrt(tolerance) (a rocker started at acos(0.1375), drawn to 1e-6 deg).
  const auto started_off_drawing = [&] {
    const Eigen::VectorXd drawn = drawn_coordinates();
    Eigen::VectorXd phi(drawn.size());
    residual(drawn, state.drivers, phi);
    for (int d = 0; d < layout_.driver_count(); ++d) {
      const int row = layout_.driver_row(d);
      if (std::abs(phi(row)) * row_scale_(row) > options_.tolerance * length_scale_) return true;
    }
    return false;
  };
  if (drawn_singular && report.status == PoseStatus::ok &&
      report.rcond >= std::sqrt(options_.tolerance) && started_off_drawing()) {
    Eigen::MatrixXd jac(state.q.size(), state.q.size());
    jacobian(drawn_coordinates(), jac);
    const int joints = layout_.joint_row_count();
    const Eigen::VectorXd sigma =
        Eigen::JacobiSVD<Eigen::MatrixXd>(row_scale_.head(joints).asDiagonal() *
                                          jac.topRows(joints) * col_scale_.asDiagonal())
            .singularValues();
    if (sigma.size() > 0 && sigma(sigma.size() - 1) > kFoldJoints * sigma(0)) {
      report.status = PoseStatus::cannot_assemble;
      report.message = fmt::format(
          "the drawing is on a toggle (the Jacobian's rcond there is {:.1e}, its joints' rows "
          "regular), where two assemblies meet, and the driver starts off it: the drawing does "
          "not say which assembly the chain takes at the start; draw it at the start, or off the "
          "toggle",
          drawn_rcond);
    }
  }
  if (const SlotEnd past = usable(report.status) ? past_slot_end(state.q) : SlotEnd{};
      !past.where.empty()) {  // the drawing's pin is beyond its slot
    report.status = PoseStatus::cannot_assemble;
    report.message = past.message;
  }
  if (report.status == PoseStatus::ok) {
    solve_velocity(state);
    solve_acceleration(state);
  } else {
    // No motion to report, and qddot held Newton's last step as scratch (possibly not finite).
    state.qdot.setZero();
    state.qddot.setZero();
    state.qdddot.setZero();
  }
  return report;
}

NewtonSolver::SlotEnd NewtonSolver::past_slot_end(const Eigen::VectorXd& q) const {
  const Mechanism& m = mechanism_;
  for (int j : spline_slots_) {
    const ConstraintRows& slot = layout_.joint(j);
    const double x = project(BodyMotion::of(slot.a, q, nullptr, nullptr), slot.point_a, slot.axis,
                             BodyMotion::of(slot.b, q, nullptr, nullptr), slot.point_b)
                         .value;
    const double beyond = std::max(slot.slot->first() - x, x - slot.slot->last());
    if (!(beyond > 1e-9 * length_scale_)) continue;
    const Joint& joint = m.joints[static_cast<size_t>(j)];
    const auto name = [&](int link, int point) -> const std::string& {
      return m.links[static_cast<size_t>(link)].points[static_cast<size_t>(point)].name;
    };
    SlotEnd out;
    out.where = fmt::format(
        "past the end {} of spline slot '{}'",
        name(joint.link_a, x < slot.slot->first() ? joint.through.front() : joint.through.back()),
        joint.name);
    out.message = fmt::format(
        "the pin {} is {}, by {:.6g} m along its chord: the slot's end stops the motion, so "
        "there is no pose here",
        name(joint.link_b, joint.point_b), out.where, beyond);
    return out;
  }
  return {};
}

void NewtonSolver::write_sample(const KinematicState& state, const SolveReport& report,
                                Trajectory& out, int row) const {
  const Mechanism& m = mechanism_;
  out.time(row) = state.time();
  for (size_t d = 0; d < state.drivers.size(); ++d)
    out.driver_values(row, static_cast<Eigen::Index>(d)) = state.drivers[d].value;
  out.status[static_cast<size_t>(row)] = report.status;
  out.rcond(row) = report.rcond;
  out.loop_gap(row) = 0.0;
  const Eigen::VectorXd* qd = &state.qdot;
  const Eigen::VectorXd* qdd = &state.qddot;

  int column = 0;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    out.angle(row, column) = state.q(3 * k + 2);
    out.omega(row, column) = state.qdot(3 * k + 2);
    out.alpha(row, column) = state.qddot(3 * k + 2);
    ++column;
  }
  column = 0;
  for (const Mechanism::NamedPoint& p : named_points_) {
    const BodyMotion body = BodyMotion::of(m.moving_index(p.link), state.q, qd, qdd);
    const Eigen::Vector2d& local = m.links[p.link].points[p.point].local;
    const Eigen::Vector2d position = body.position(local), velocity = body.velocity(local),
                          acceleration = body.acceleration(local);
    out.x(row, column) = position.x();
    out.y(row, column) = position.y();
    out.vx(row, column) = velocity.x();
    out.vy(row, column) = velocity.y();
    out.ax(row, column) = acceleration.x();
    out.ay(row, column) = acceleration.y();
    ++column;
  }
  column = 0;
  for (int ji : slide_joints_) {
    const Joint& j = m.joints[ji];
    const Line& line = m.links[j.link_a].lines[j.line];
    const Projection s =
        project(BodyMotion::of(m.moving_index(j.link_a), state.q, qd, qdd), line.origin,
                line.direction, BodyMotion::of(m.moving_index(j.link_b), state.q, qd, qdd),
                m.links[j.link_b].points[j.point_b].local);
    out.s(row, column) = s.value;
    out.sdot(row, column) = s.rate;
    out.sddot(row, column) = s.accel;
    ++column;
  }
  if (out.has_jerk)
    for (size_t c = 0; c < out.cams.size(); ++c)
      out.jerk(row, static_cast<Eigen::Index>(c)) = out.cams[c].reading.follower_jerk(state.qdddot);
  out.flag_non_finite(row);
  if (has_position(out.status[static_cast<size_t>(row)]))
    if (const SlotEnd past = past_slot_end(state.q); !past.where.empty()) {
      out.status[static_cast<size_t>(row)] = PoseStatus::cannot_assemble;
      if (std::none_of(out.events.begin(), out.events.end(), [&](const Trajectory::Event& e) {
            return e.kind == PoseStatus::cannot_assemble &&
                   e.message.find(past.where) != std::string::npos;
          }))
        out.events.push_back({out.along(row), PoseStatus::cannot_assemble, past.message});
    }
}

}  // namespace crosslink
