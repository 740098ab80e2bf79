#include "analytic/newton.h"

#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analytic/planar.h"

namespace crosslink {

KinematicState::KinematicState(const Mechanism& mechanism) {
  const int n = mechanism.coordinate_count();
  q.setZero(n);
  qdot.setZero(n);
  qddot.setZero(n);
  phi.setZero(n);
  rhs.setZero(n);
  jacobian.setZero(n, n);
  lu = SmallLU(n);
  q_start.setZero(n);
  estimate.setZero(n);
  estimate_rhs.setZero(n);
  sign.setZero(n);
  previous_sign.setZero(n);
  cos_theta.setOnes(mechanism.moving_count());
  sin_theta.setZero(mechanism.moving_count());
}

SmallLU::SmallLU(Eigen::Index size) : Eigen::PartialPivLU<Eigen::MatrixXd>(size) {
  const Eigen::Index triangle = size * (size - 1) / 2;
  l_start_.setZero(size + 1);
  u_start_.setZero(size + 1);
  for (Eigen::Index j = 0; j <= size; ++j) u_start_(j) = static_cast<int>(j * (j - 1) / 2);
  u_end_ = u_start_;
  l_rows_.setZero(triangle);
  u_rows_.setZero(triangle);
  l_values_.setZero(triangle);
  u_values_.setZero(triangle);
  inverse_diagonal_.setZero(size);
  pivot_rows_.setZero(size);
}

void SmallLU::factorize(const Eigen::MatrixXd& a, double l1_norm) {
  // Eigen's unblocked_lu (right-looking, partial pivoting) in plain loops on column-major
  // storage, visiting only the nonzeros of the pivot column and of the pivot row.
  const Eigen::Index n = a.rows();
  m_lu = a;  // same size as constructed: a copy, no allocation
  m_l1_norm = l1_norm;
  double* lu = m_lu.data();
  int* transpositions = m_rowsTranspositions.indices().data();
  int* below = pivot_rows_.data();
  // U's column j has room for j entries from start(j) = j (j - 1) / 2; end(j) moves on as they
  // come.
  int* u_rows = u_rows_.data();
  double* u_values = u_values_.data();
  int* u_end = u_end_.data();
  for (Eigen::Index j = 0; j < n; ++j) u_end[j] = u_start_(j);
  int swaps = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    double* column_k = lu + k * n;
    Eigen::Index pivot_row = k;
    double biggest = std::abs(column_k[k]);
    for (Eigen::Index i = k + 1; i < n; ++i) {
      const double magnitude = std::abs(column_k[i]);
      if (magnitude > biggest) {
        biggest = magnitude;
        pivot_row = i;
      }
    }
    transpositions[k] = static_cast<int>(pivot_row);
    int count = 0;
    if (biggest != 0.0) {
      if (pivot_row != k) {
        for (Eigen::Index j = 0; j < n; ++j) std::swap(lu[k + j * n], lu[pivot_row + j * n]);
        ++swaps;
      }
      // Scaled by the pivot's reciprocal (as LAPACK's dgetf2 does); the nonzeros listed
      // without a branch on each entry.
      const double inverse_pivot = 1.0 / column_k[k];
      for (Eigen::Index i = k + 1; i < n; ++i) {
        column_k[i] *= inverse_pivot;
        below[count] = static_cast<int>(i);
        count += column_k[i] != 0.0;
      }
    }
    // Row k of U is final from here on (later steps and swaps touch rows below k only): its
    // nonzeros go to the end of their columns' lists, in increasing row order.
    for (Eigen::Index j = k + 1; j < n; ++j) {
      double* column_j = lu + j * n;
      const double u = column_j[k];
      if (u == 0.0) continue;
      u_rows[u_end[j]] = static_cast<int>(k);
      u_values[u_end[j]++] = u;
      for (int c = 0; c < count; ++c) column_j[below[c]] -= column_k[below[c]] * u;
    }
  }
  m_det_p = (swaps % 2) ? -1 : 1;
  m_p = m_rowsTranspositions;  // same size: no allocation
  m_isInitialized = true;

  // The factors' nonzeros, column by column.
  // L's nonzeros, column by column (later swaps move its rows, so only now).
  int l_count = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double* column = lu + j * n;
    l_start_(j) = l_count;
    // Each entry is written and the count moves on past the nonzeros only (no branch).
    inverse_diagonal_(j) = 1.0 / column[j];
    for (Eigen::Index i = j + 1; i < n; ++i) {
      l_rows_(l_count) = static_cast<int>(i);
      l_values_(l_count) = column[i];
      l_count += column[i] != 0.0;
    }
  }
  l_start_(n) = l_count;
}

void SmallLU::solve_in_place(double* b) const {
  // P b, then L (unit lower) and U by column-oriented substitution.
  const Eigen::Index n = m_lu.rows();
  const int* transpositions = m_rowsTranspositions.indices().data();
  const int *l_start = l_start_.data(), *l_rows = l_rows_.data();
  const int *u_start = u_start_.data(), *u_end = u_end_.data(), *u_rows = u_rows_.data();
  const double *l_values = l_values_.data(), *u_values = u_values_.data();
  for (Eigen::Index k = 0; k < n; ++k)
    if (transpositions[k] != k) std::swap(b[k], b[transpositions[k]]);
  // As Eigen's column-major triangular solves, a column whose unknown is zero is skipped.
  for (Eigen::Index j = 0; j < n; ++j) {
    const double x = b[j];
    if (x == 0.0) continue;
    for (int e = l_start[j]; e < l_start[j + 1]; ++e) b[l_rows[e]] -= l_values[e] * x;
  }
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    if (b[j] == 0.0) continue;
    const double x = b[j] *= inverse_diagonal_(j);
    for (int e = u_start[j]; e < u_end[j]; ++e) b[u_rows[e]] -= u_values[e] * x;
  }
}

void SmallLU::solve_transposed_in_place(double* b) const {
  // A^-T = P^T L^-T U^-T: U^T and L^T by dot products down the columns, then P^T.
  const Eigen::Index n = m_lu.rows();
  const int* transpositions = m_rowsTranspositions.indices().data();
  const int *l_start = l_start_.data(), *l_rows = l_rows_.data();
  const int *u_start = u_start_.data(), *u_end = u_end_.data(), *u_rows = u_rows_.data();
  const double *l_values = l_values_.data(), *u_values = u_values_.data();
  for (Eigen::Index j = 0; j < n; ++j) {
    double sum = b[j];
    for (int e = u_start[j]; e < u_end[j]; ++e) sum -= u_values[e] * b[u_rows[e]];
    b[j] = sum * inverse_diagonal_(j);
  }
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    double sum = b[j];
    for (int e = l_start[j]; e < l_start[j + 1]; ++e) sum -= l_values[e] * b[l_rows[e]];
    b[j] = sum;
  }
  for (Eigen::Index k = n - 1; k >= 0; --k)
    if (transpositions[k] != k) std::swap(b[k], b[transpositions[k]]);
}

NewtonSolver::NewtonSolver(const Mechanism& mechanism, NewtonOptions options)
    : mechanism_(mechanism),
      options_(options),
      layout_(mechanism),
      length_scale_(mechanism.size()),
      named_points_(mechanism.named_points()),
      slide_joints_(mechanism.slide_joints()) {
  // KinematicState holds one driver's state (see drivers()); the loader accepts one driver.
  if (layout_.driver_count() != 1)
    throw std::invalid_argument("the Newton solver takes a mechanism with one driver");
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

double NewtonSolver::driver_value(const Eigen::VectorXd& q) const {
  return layout_.driver(0).value(LinkFrames{q});
}

void NewtonSolver::update_frames(KinematicState& state) const {
  // sincos: glibc's sin and cos in one call (one argument reduction), the same numbers.
  for (Eigen::Index k = 0; k < state.cos_theta.size(); ++k)
    ::sincos(state.q(3 * k + 2), &state.sin_theta(k), &state.cos_theta(k));
}

void NewtonSolver::residual(const Eigen::VectorXd& q, double driver_value,
                            Eigen::VectorXd& phi) const {
  const DriverState driver{0.0, driver_value, 0.0, 0.0};
  layout_.residual(LinkFrames{q}, {&driver, 1}, phi);
}

void NewtonSolver::jacobian(const Eigen::VectorXd& q, Eigen::MatrixXd& jac) const {
  layout_.jacobian(LinkFrames{q}, jac);
}

void NewtonSolver::factorize(KinematicState& state) const {
  // state's frames must be those of state.q (update_frames).
  layout_.jacobian(frames(state), state.jacobian);
  // S_r J S_c: only angle rows and angle columns have a scale other than 1.
  for (int r : scaled_rows_) state.jacobian.row(r) *= row_scale_(r);
  for (Eigen::Index c = 2; c < state.jacobian.cols(); c += 3)
    state.jacobian.col(c) *= col_scale_(c);
  state.jacobian_norm = state.jacobian.cwiseAbs().colwise().sum().maxCoeff();
  state.lu.factorize(state.jacobian, state.jacobian_norm);
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
    layout_.residual(frames(state), drivers(state), state.phi);
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
    layout_.residual(frames(state), drivers(state), state.phi);
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
    layout_.residual(frames(state), drivers(state), state.phi);
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
  layout_.velocity_rhs(drivers(state), state.rhs);
  solve_linear(state, state.qdot);
}

void NewtonSolver::solve_acceleration(KinematicState& state) const {
  update_frames(state);  // state.q may have changed since the last factorisation
  acceleration_at_frames(state);
}

void NewtonSolver::acceleration_at_frames(KinematicState& state) const {
  layout_.acceleration_rhs(frames(state), state.qdot, drivers(state), state.rhs);
  solve_linear(state, state.qddot);
}

SolveReport NewtonSolver::solve(KinematicState& state) const {
  SolveReport report = solve_position(state);
  if (report.status == PoseStatus::ok) {
    solve_velocity(state);
    acceleration_at_frames(state);  // solve_position ends with the frames of state.q
  } else {
    state.qdot.setZero();
    state.qddot.setZero();
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

SolveReport NewtonSolver::assemble(KinematicState& state) const {
  state.q = drawn_coordinates();
  state.driver = mechanism_.driver().at_time(0.0);
  SolveReport report = solve_position(state);
  if (report.status != PoseStatus::no_convergence) {
    if (report.status == PoseStatus::ok) {
      solve_velocity(state);
      solve_acceleration(state);
    } else {
      state.qdot.setZero();
      state.qddot.setZero();
    }
    return report;
  }
  // Newton failed from the drawing. Levenberg–Marquardt minimises |Phi|^2 instead: a minimum
  // with a residual left means the chain cannot close here; a zero residual gets a fresh Newton.
  state.q = drawn_coordinates();
  const int n = static_cast<int>(state.q.size());
  double lambda = 1e-3;
  Eigen::VectorXd phi(n), trial_phi(n), step(n), trial(n);
  Eigen::MatrixXd jac(n, n);
  residual(state.q, state.driver.value, phi);
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
    residual(trial, state.driver.value, trial_phi);
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
        "the chain cannot be assembled at the driver's start value: the closest it comes leaves "
        "a loop gap of {:.3e} m",
        scaled_norm(phi));
  } else if (report.status == PoseStatus::ok) {
    solve_velocity(state);
    solve_acceleration(state);
  }
  if (report.status != PoseStatus::ok) {
    // No motion to report, and qddot held Newton's last step as scratch (possibly not finite).
    state.qdot.setZero();
    state.qddot.setZero();
  }
  return report;
}

void NewtonSolver::write_sample(const KinematicState& state, const SolveReport& report,
                                Trajectory& out, int row) const {
  const Mechanism& m = mechanism_;
  out.time(row) = state.driver.time;
  out.driver(row) = state.driver.value;
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
  out.flag_non_finite(row);
}

}  // namespace crosslink
