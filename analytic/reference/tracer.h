// The configuration-curve tracer (internal to analytic/reference/): pseudo-arclength
// continuation along the joint constraints, which passes toggles and locates singular positions
// on the way; a leg of the curve; where a leg ends. sweep.cpp plans samples and finds the
// assembling range from its legs.
#pragma once

#include <fmt/format.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/sweep_samples.h"

namespace crosslink::sweeping {

// Follows the configuration curve Phi_c(q) = 0 (the joint constraints without the driver row)
// by pseudo-arclength continuation. Unlike the Follower it is not parametrised by the driver, so
// it passes a toggle, where the driver turns back, and it sees both kinds of singular position
// as sign changes of two smooth functions along the curve:
//   det J = t_driver * det [C; t]   (J: the full Jacobian, C: the constraint rows, t: tangent)
// t_driver = d driver / ds changes sign at a toggle (fold); det [C; t] changes sign where two
// branches cross (change point: C loses rank). Each is located by regula falsi in s, where the
// arclength system stays well conditioned. Work is in size-free coordinates z (lengths / size,
// angles in rad) with dimensionless constraint rows.
class Tracer {
 public:
  struct Node {
    Eigen::VectorXd q;         // coordinates (SI)
    Eigen::VectorXd t;         // unit tangent in z
    double driver = 0.0;       // driver value at q [rad or m]
    double t_driver = 0.0;     // d driver / ds
    double orientation = 0.0;  // det [C; t], normalised by the row norms of C
    double s = 0.0;            // arclength from the node it was corrected from
  };

 private:
  // J at q into jac_ (its pattern: the trace's Newton steps cost in proportion to the bodies)
  // and the driver's gradient in z into gradient_.
  void jacobian_at(const Eigen::VectorXd& q) {
    solver_.layout().jacobian(LinkFrames{q}, jac_);
    gradient_.setZero();
    for (int c = 0; c < n_; ++c)
      for (int e = jac_.column_start(c); e < jac_.column_start(c + 1); ++e)
        if (jac_.row_index(e) == driver_row_) gradient_(c) = jac_.value(e) * column_(c);
  }
  // The constraint rows C of jac_ in z, dimensionless, as a dense matrix (for the SVD).
  Eigen::MatrixXd constraint_rows() const {
    return row_.asDiagonal() * jac_.dense().topRows(joints_) * column_.asDiagonal();
  }
  // The unit tangent t at jac_'s pose from the sparse factors of [C; driver row]: C t = 0,
  // driver . t = 1, normalised. False where that system is singular to working precision (a
  // toggle, where the driver does not move along the curve, or a change point).
  bool driver_tangent(Eigen::VectorXd& t) {
    factorise(gradient_);
    t = Eigen::VectorXd::Unit(n_, joints_);
    solve(t);
    const double norm = t.norm();
    if (!std::isfinite(norm) || norm * gradient_.norm() > kTangentLimit) return false;
    t /= norm;
    return true;
  }
  // y = C x, C in z (its first joints_ entries of y).
  void constraint_product(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    y.setZero();
    for (int c = 0; c < n_; ++c)
      for (int e = jac_.column_start(c); e < jac_.column_start(c + 1); ++e)
        if (const int r = jac_.row_index(e); r < joints_)
          y(r) += row_(r) * jac_.value(e) * column_(c) * x(c);
  }
  // |t| |driver row| beyond which [C; driver row] is taken as singular: a driver 1e-8 of a
  // regular pose's rate, far inside the tracer's own toggle zone.
  static constexpr double kTangentLimit = 1e8;
  // Up to 8 moving links [C; last] is factorised as it is, and the start's tangent taken by SVD:
  // there the full row's fill costs about what the bordered form's extra solves do (A02 with
  // N = 2, 15 coordinates: 79 entries in the factors); and so is a last row of a driver's few
  // entries, which fills nothing.
  static constexpr int kDirectSize = 24, kSparseRow = 8;
  static constexpr int kSingularIterations = 30;
  // [C; last] from jac_, factorised. A chain past SmallLU's dense size with a full last row (a
  // tangent) is factorised as B = [C; e_m], m the row's largest entry, and the row put back by
  // Sherman–Morrison: pivoted early, a full row fills every later column (A02 with N = 160:
  // 50,000 entries in the factors against 2,500 for J, and a trace's cost growing as n^2), while
  // B keeps the chain's pattern and is regular wherever [C; last] is, within |last| / |last_m|
  // <= sqrt(n) of its conditioning (the local parametrisation of Rheinboldt's continuation).
  void factorise(const Eigen::VectorXd& last) {
    bordered_ = n_ > kDirectSize && (last.array() != 0.0).count() > kSparseRow;
    if (bordered_) last.cwiseAbs().maxCoeff(&border_);
    for (int c = 0; c < n_; ++c) {
      int a = aug_.column_start(c);
      for (int e = jac_.column_start(c); e < jac_.column_start(c + 1); ++e) {
        const int r = jac_.row_index(e);
        if (r < joints_) aug_.value(a++) = row_(r) * jac_.value(e) * column_(c);
      }
      // the last row, below C's rows
      aug_.value(a) = !bordered_ ? last(c) : c == border_ ? 1.0 : 0.0;
    }
    lu_.factorize(aug_);
    transposed_ready_ = false;
    if (!bordered_) return;
    last_ = last;
    border_solution_ = Eigen::VectorXd::Unit(n_, joints_);  // B u = e_n: C u = 0, u_m = 1
    lu_.solve_in_place(border_solution_.data());
    border_product_ = last.dot(border_solution_);  // 1 + (last - e_m) . u
  }
  // b := [C; last]^-1 b.
  void solve(Eigen::VectorXd& b) const {
    lu_.solve_in_place(b.data());
    if (bordered_) b -= border_solution_ * ((last_.dot(b) - b(border_)) / border_product_);
  }
  // b := [C; last]^-T b.
  void solve_transposed(Eigen::VectorXd& b) {
    lu_.solve_transposed_in_place(b.data());
    if (!bordered_) return;
    if (!transposed_ready_) {  // B^-T (last - e_m)
      border_transposed_ = last_;
      border_transposed_(border_) -= 1.0;
      lu_.solve_transposed_in_place(border_transposed_.data());
      transposed_ready_ = true;
    }
    b -= border_transposed_ * (b(joints_) / border_product_);
  }
  // det [C; last] (matrix determinant lemma for the bordered form).
  double determinant() const {
    return bordered_ ? lu_.determinant() * border_product_ : lu_.determinant();
  }

 public:
  explicit Tracer(const NewtonSolver& solver)
      : solver_(solver),
        n_(static_cast<int>(solver.mechanism().coordinate_count())),
        joints_(solver.layout().joint_row_count()),
        swept_(solver.mechanism().axis().driver),
        driver_row_(solver.layout().driver_row(swept_)) {
    const Mechanism& m = solver.mechanism();
    const double L = solver.length_scale();
    column_.setOnes(n_);
    for (int k = 0; k < m.moving_count(); ++k) column_.segment<2>(3 * k).setConstant(L);
    row_.setOnes(joints_);
    for (int r = 0; r < joints_; ++r)
      if (!solver.layout().angle_row(r)) row_(r) = 1.0 / L;
    jac_ = SparseJacobian(solver.layout(), n_);
    aug_ = jac_.with_full_row(joints_);
    lu_ = SmallLU(n_, aug_.nonzeros());
    gradient_.setZero(n_);
    t_.setZero(n_);
    phi_.setZero(n_);
    rhs_.setZero(n_);
    dz_.setZero(n_);
    dq_.setZero(n_);
    tolerance_ = solver.options().tolerance;
    length_ = L;
    angular_ = m.swept().angular();
  }

  // A node at a solved pose; the tangent (null vector of C) is oriented so the driver moves
  // toward `direction`.
  bool start(const Eigen::VectorXd& q, double direction, Node& out) {
    jacobian_at(q);
    Node seed;
    seed.q = q;
    if (n_ <= kDirectSize || !driver_tangent(seed.t)) {
      // A small chain, or one drawn at a toggle or a change point: by SVD, which gives a null
      // vector there too (dense, n^3: for a long chain only when drawn singular).
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(constraint_rows(), Eigen::ComputeFullV);
      seed.t = svd.matrixV().col(n_ - 1);
    }
    if (gradient_.dot(seed.t) * direction < 0.0) seed.t = -seed.t;
    return correct(seed, 0.0, out);
  }

  // Newton on [Phi_c; driver row] at q's driver value, from q to round-off. Within the solver's
  // tolerance a pose beside a change point can still lie on the other branch: the residual grows
  // only as the square of the distance along it (a kite drawn 1e-4 deg before its change point
  // was assembled 1.3e-6 rad off its branch with a residual of 5e-13, and its tangent mixed the
  // two branches). Steps are kept below kSettleStep (in z) and must lower the residual, so the
  // pose cannot leap to another assembly. Returns the residual left (|Phi|_inf in z) over its
  // round-off there: above 1 where the chain does not close exactly at that driver value.
  double settle(Eigen::VectorXd& q) {
    const double value = solver_.driver_value(q, swept_);
    const auto residual = [&](const Eigen::VectorXd& at) {
      solver_.residual(at, 0.0, phi_);
      rhs_.head(joints_) = -phi_.head(joints_).cwiseProduct(row_);
      rhs_(joints_) = (value - phi_(driver_row_)) / (angular_ ? 1.0 : length_);
      return rhs_.lpNorm<Eigen::Infinity>();
    };
    double r = residual(q);
    for (int it = 0; it < 8 && r > 0.0; ++it) {
      jacobian_at(q);
      factorise(gradient_);
      dz_ = rhs_;
      solve(dz_);
      if (!dz_.allFinite() || !(dz_.lpNorm<Eigen::Infinity>() <= kSettleStep)) break;
      dq_ = column_.cwiseProduct(dz_);
      const Eigen::VectorXd next = q + dq_;
      const double r_next = residual(next);
      if (!(r_next < r)) break;
      q = next;
      r = r_next;
    }
    const double magnitude = std::max(1.0, q.cwiseQuotient(column_).lpNorm<Eigen::Infinity>());
    return r / (kRoundOffResidual * std::numeric_limits<double>::epsilon() * magnitude);
  }
  // A pose settles to a few eps of its coordinates' magnitude (7e-17 beside the polycentric
  // hinge's toggle); 1e-9 deg beyond that toggle, where it does not close, it stays at 6.5e-13.
  static constexpr double kSettleStep = 1e-3, kRoundOffResidual = 100.0;

  // The smallest singular value of the constraint rows C at q over their largest: 0 at a change
  // point, where C loses rank and two branches cross.
  double crossing_ratio(const Eigen::VectorXd& q) {
    jacobian_at(q);
    Eigen::VectorXd t;
    if (n_ <= kDirectSize || !driver_tangent(t)) {  // small, or next to a singular position
      const Eigen::VectorXd sigma =
          Eigen::JacobiSVD<Eigen::MatrixXd>(constraint_rows()).singularValues();
      return sigma.size() > 0 && sigma(0) > 0.0 ? sigma(sigma.size() - 1) / sigma(0) : 0.0;
    }
    // With t the unit null vector of C, [C; t] has C's singular values and 1 (C^T C + t t^T).
    // Its smallest by inverse iteration on the sparse factors, C's largest by power iteration:
    // both estimates converge from the side that makes the ratio larger, which for a test
    // against 1e-10 (six orders below a regular pose's) is the safe side of a refusal.
    factorise(t);
    Eigen::VectorXd x = Eigen::VectorXd::Ones(n_) / std::sqrt(static_cast<double>(n_)), y(n_);
    double inverse_square = 0.0;  // 1 / sigma_min^2 of [C; t]
    for (int it = 0; it < kSingularIterations; ++it) {
      solve_transposed(x);
      solve(x);
      inverse_square = x.norm();
      if (!std::isfinite(inverse_square) || inverse_square == 0.0) return 0.0;
      x /= inverse_square;
    }
    x.setOnes();
    x /= std::sqrt(static_cast<double>(n_));
    double largest_square = 0.0;  // sigma_max^2 of C
    for (int it = 0; it < kSingularIterations; ++it) {
      constraint_product(x, y);
      x.setZero();
      for (int c = 0; c < n_; ++c)
        for (int e = jac_.column_start(c); e < jac_.column_start(c + 1); ++e)
          if (const int r = jac_.row_index(e); r < joints_)
            x(c) += row_(r) * jac_.value(e) * column_(c) * y(r);
      largest_square = x.norm();
      if (largest_square == 0.0) return 0.0;
      x /= largest_square;
    }
    return 1.0 / std::sqrt(inverse_square * largest_square);
  }

  // The point of the curve on the hyperplane t_from . (z - z_from) = s, by Newton from a
  // tangent prediction made at `near` (a node on the same branch close to it, or `from`).
  bool correct(const Node& from, double s, Node& out, const Node* near = nullptr) {
    const Node& p = near ? *near : from;
    const double along = near ? (s - near->s) / std::max(from.t.dot(near->t), 0.5) : s;
    return newton(p.q + column_.cwiseProduct(along * p.t), from, s, nullptr, p.t, out);
  }

  // The point of the curve at driver value `value`, by Newton from a tangent prediction at
  // `near` (which must not be at a toggle); its s is measured on the hyperplanes of `from`.
  // Where another branch crosses, the driver is the better parameter: that branch cannot lie
  // in a plane of constant driver unless it is itself at a toggle there.
  bool correct_driver(const Node& from, double value, Node& out, const Node& near) {
    if (std::abs(near.t_driver) < 1e-3) return false;
    const double along = (value - near.driver) / near.t_driver;
    return newton(near.q + column_.cwiseProduct(along * near.t), from, 0.0, &value, near.t, out);
  }

 private:
  // Newton on [Phi_c; last row] with the last row either the hyperplane of `from` at s, or
  // driver(q) - *value. At the solution the tangent is oriented like `orient`, and
  // det [C; t/|t|] = det [C; orient] |t| (orient minus its part along t lies in C's rows).
  bool newton(Eigen::VectorXd q, const Node& from, double s, const double* value,
              const Eigen::VectorXd& orient, Node& out) {
    bool round_off = false;  // the last step moved q by round-off only
    // Chord steps: [C; last row] is factorised at the prediction and again only where a step
    // contracts poorly (near a fold) and at the solution, for its tangent. Refactorising at
    // every iterate was most of a trace's work (under the sanitizers, 71 % of a fuzz run).
    bool factorised = false;
    double last_step = std::numeric_limits<double>::infinity();
    for (int it = 0; it <= 12; ++it) {
      solver_.residual(q, 0.0, phi_);
      rhs_.head(joints_) = -phi_.head(joints_).cwiseProduct(row_);
      rhs_(joints_) =
          value ? *value - phi_(driver_row_) : s - from.t.dot((q - from.q).cwiseQuotient(column_));
      if (!rhs_.allFinite()) return false;
      const bool converged =
          rhs_.lpNorm<Eigen::Infinity>() <= tolerance_ * (value && !angular_ ? length_ : 1.0) ||
          round_off;
      if (converged || !factorised) {
        jacobian_at(q);
        factorise(converged ? orient : value ? gradient_ : from.t);
        factorised = true;
      }
      if (converged) {
        t_.setZero();
        t_(joints_) = 1.0;
        solve(t_);
        if (!t_.allFinite() || t_.norm() == 0.0) return false;
        double row_norms = 1.0;
        for (int r = 0; r < joints_; ++r) row_norms *= aug_.row_norm(r);
        out.orientation = determinant() * t_.norm() / row_norms;
        out.t = t_.normalized();
        out.q = q;
        out.s = value ? from.t.dot((q - from.q).cwiseQuotient(column_)) : s;
        out.driver = solver_.driver_value(q, swept_);
        out.t_driver = gradient_.dot(out.t);
        return true;
      }
      dz_ = rhs_;
      solve(dz_);
      if (!dz_.allFinite()) return false;
      const double step = dz_.lpNorm<Eigen::Infinity>();
      if (step > 0.25 * last_step) factorised = false;
      last_step = step;
      dq_ = column_.cwiseProduct(dz_);
      round_off = solver_.round_off_step(dq_, q);
      q += dq_;
    }
    return false;
  }

 public:
  // |z_to - (z_from + h t_from)|: how far Newton moved the prediction.
  double correction(const Node& from, const Node& to, double h) const {
    return ((to.q - from.q).cwiseQuotient(column_) - h * from.t).lpNorm<Eigen::Infinity>();
  }

  // Distance between two poses in z (angles compared as they are, or modulo a turn).
  double distance(const Eigen::VectorXd& a, const Eigen::VectorXd& b, bool modulo_turn) const {
    double worst = 0.0;
    for (int i = 0; i < n_; ++i) {
      double d = (a(i) - b(i)) / column_(i);
      if (modulo_turn && i % 3 == 2) d = std::remainder(d, 2.0 * std::numbers::pi);
      worst = std::max(worst, std::abs(d));
    }
    return worst;
  }

 private:
  const NewtonSolver& solver_;
  int n_;
  int joints_;              // the rows of C (the joints'); [C; last row] is square, n_ rows
  int swept_;               // the swept driver (Mechanism::axis(); one driver: the tracer's)
  int driver_row_;          // the driver's row of Phi and J
  Eigen::VectorXd column_;  // q = column_ .* z
  Eigen::VectorXd row_;     // dimensionless constraint rows
  SparseJacobian jac_;      // J at the last q (unscaled)
  SparseJacobian aug_;      // [C; last row] in z: C's pattern and a full last row
  SmallLU lu_;
  // The bordered form (factorise): whether it is in use, m, the last row, u = B^-1 e_n,
  // last . u, and B^-T (last - e_m) once a transposed solve asks for it.
  bool bordered_ = false, transposed_ready_ = false;
  int border_ = 0;
  Eigen::VectorXd last_, border_solution_, border_transposed_;
  double border_product_ = 1.0;
  Eigen::VectorXd gradient_;  // the driver's row of J in z
  Eigen::VectorXd phi_, rhs_, dz_, dq_, t_;
  double tolerance_, length_ = 1.0;
  bool angular_ = true;
};

// A leg of the configuration curve traced from one pose: nodes in order, with the toggles and
// change points located on the way (as nodes too). `base` is the node each was corrected from.
struct Leg {
  std::vector<Tracer::Node> nodes;
  std::vector<int> base;    // index of the node each node was corrected from (self: start)
  std::vector<double> key;  // arclength from the leg's start
  std::vector<SingularPosition> singular;
  std::vector<int> singular_node;    // node index of each singular position (-1: none)
  std::vector<double> singular_key;  // arclength of each singular position
  bool full_cycle = false;           // the driver made a whole turn without a toggle
  bool closed = false;               // came back to the start pose after a toggle
  double end_key = std::numeric_limits<double>::infinity();  // where the leg's path ends
  bool failed = false;  // the tracer lost the curve (branch_jump)
};

// Regula falsi (Illinois) for f(node) = 0 between two nodes where f has opposite signs. The
// parameter is the arclength s on the hyperplanes of `base`, or the driver (by_driver); each
// evaluation predicts from the nearer bracket node, which is on the branch being followed.
template <class F>
Tracer::Node locate(Tracer& tracer, const Tracer::Node& base, Tracer::Node lo, Tracer::Node hi, F f,
                    double f_tolerance, bool by_driver = false) {
  const auto x = [&](const Tracer::Node& n) { return by_driver ? n.driver : n.s; };
  double f_lo = f(lo), f_hi = f(hi);
  // Stop well before the root when it is a change point: a node right at it has no reliable
  // tangent to predict from, and the other branch is as near.
  f_tolerance = std::max(f_tolerance, 1e-10 * std::max(std::abs(f_lo), std::abs(f_hi)));
  int side = 0;
  Tracer::Node best = std::abs(f_lo) < std::abs(f_hi) ? lo : hi;
  for (int it = 0; it < 100; ++it) {
    const double x_lo = x(lo), x_hi = x(hi);
    if (std::abs(x_hi - x_lo) <= 1e-15 * std::max(1.0, std::abs(x_lo))) break;
    double xm = (x_lo * f_hi - x_hi * f_lo) / (f_hi - f_lo);
    if (!(xm > std::min(x_lo, x_hi) && xm < std::max(x_lo, x_hi))) xm = 0.5 * (x_lo + x_hi);
    Tracer::Node mid;
    const Tracer::Node& near = std::abs(xm - x_lo) < std::abs(xm - x_hi) ? lo : hi;
    auto eval = [&](double at) {
      return by_driver ? tracer.correct_driver(base, at, mid, near)
                       : tracer.correct(base, at, mid, &near);
    };
    if (!eval(xm)) {
      xm = 0.5 * (x_lo + x_hi);  // bisect instead
      if (!eval(xm)) break;
    }
    const double f_mid = f(mid);
    best = mid;
    if (std::abs(f_mid) <= f_tolerance) break;
    if ((f_mid < 0) == (f_lo < 0)) {
      lo = mid;
      f_lo = f_mid;
      if (side == -1) f_hi *= 0.5;
      side = -1;
    } else {
      hi = mid;
      f_hi = f_mid;
      if (side == +1) f_lo *= 0.5;
      side = +1;
    }
  }
  return best;
}

struct LegLimits {
  bool stop_at_toggle = true;  // else pass toggles (the driver reverses) until the loop closes
  double reach = 0.0;          // driver travel without a toggle that ends the leg [rad or m]
  bool angular = true;
  int steps = 400000;  // SweepOptions::tracer_steps
};

// Traces from `start` (already oriented) until a toggle (when stopping there), a whole driver
// turn without toggles, the loop closing back on the start pose, or the reach.
Leg trace_leg(const NewtonSolver& solver, const Tracer::Node& start, const LegLimits& limits);

}  // namespace crosslink::sweeping
