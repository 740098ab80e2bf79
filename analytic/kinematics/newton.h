// Exact kinematics by Newton–Raphson on the full constraint equations Phi(q, t) = 0.
//
// q holds (x, y, theta) of every moving link (see mechanism.h). The equations are the rows of
// the constraint layout (constraints.h: each joint's, then each driver's), a square system when
// the mobility is one:
//   position      Phi(q) = 0                 Newton with the analytic Jacobian J = dPhi/dq
//   velocity      J qdot  = nu               nu: each driver's rate in its row
//   acceleration  J qddot = gamma            gamma = -(J qdot)_q qdot + each driver's accel
//   jerk          J q'''  = eta              with a cam: its follower's jerk (constraints.h)
// Velocity and acceleration reuse the LU factorisation of J at the converged position; they are
// never obtained by differencing positions.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "analytic/model/constraints.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

struct NewtonOptions {
  double tolerance = 1e-12;  // on |Phi|_inf relative to the mechanism's size
  int max_iterations = 30;
  double singular_rcond = 1e-9;  // J with a smaller reciprocal condition estimate is singular
};

// Result of one solve, never a NaN: a status and the numbers that explain it.
struct SolveReport {
  PoseStatus status = PoseStatus::ok;
  int iterations = 0;
  double residual = 0.0;  // |Phi|_inf at the end [m or rad]
  double rcond = 1.0;     // reciprocal condition estimate of J (1 = perfect, 0 = singular)
  std::string message;    // empty when ok
};

// LU with partial pivoting of the sparse Jacobian: PA = LU, the same pivots (the largest
// magnitude in the column, the first one on ties), the same transpositions and the same
// arithmetic in the same order as LAPACK's unblocked dgetf2 (Eigen's PartialPivLU on a small
// matrix), so its factors are those of the dense loops bit for bit. It visits only nonzeros: the
// factors are computed column by column (left-looking, as Gilbert and Peierls): column j of A,
// permuted, has the earlier columns of L applied in increasing order (a right-looking
// elimination applies them in that order too), then its pivot is chosen among the rows not yet
// pivoted. A chain's factors have a few entries per row, so a factorisation and a solve cost in
// proportion to the bodies; the dense loops did n^2 work per factorisation (pivot searches,
// row swaps across all columns, scans for U's rows), which dominated at 81 bodies.
class SmallLU {
 public:
  SmallLU() = default;
  // Room for the factors of an n x n matrix with `nonzeros` entries; the factors of a
  // mechanism's Jacobian fit (room grows, once, if a pivot order ever fills more).
  SmallLU(int size, int nonzeros);
  // Factorises `a` (square, of the size given at construction). Allocates nothing.
  void factorize(const SparseJacobian& a);
  // b := A^-1 b and b := A^-T b in place, with PA = LU. No allocation.
  void solve_in_place(double* b) const;
  void solve_transposed_in_place(double* b) const;
  int size() const { return n_; }
  // Entries of L and U below and above the diagonal: the cost of a substitution.
  // The factors packed as LAPACK leaves them (L below the diagonal, U on and above it) and the
  // row swapped with each row: for checks against a dense LU.
  Eigen::MatrixXd packed() const;
  const std::vector<int>& transpositions() const { return transpositions_; }
  // det A: the product of U's diagonal in order, signed by the row swaps (as Eigen's).
  double determinant() const;
  int factor_nonzeros() const {
    return l_start_[static_cast<size_t>(n_)] + u_start_[static_cast<size_t>(n_)];
  }

 private:
  void grow();  // more room for L and U
  int n_ = 0;
  // Strictly lower (L) and strictly upper (U) parts by column: column j's entries are
  // [l_start(j), l_start(j + 1)) and [u_start(j), u_start(j + 1)) of rows/values, rows
  // increasing (the order the transposed solve sums them in). transpositions_[k]: the row
  // swapped with row k at step k.
  std::vector<int> l_start_, l_rows_, u_start_, u_rows_, transpositions_;
  std::vector<double> l_values_, u_values_, diagonal_, inverse_diagonal_;  // U(j, j), 1 / U(j, j)
  // Scratch of a factorisation, indexed by the rows of A: the column being eliminated, the
  // step each row was pivoted at (-1: not yet), each row's place after the swaps so far and
  // the row at each place, the rows the column reaches, the steps to apply (a heap).
  std::vector<double> work_;
  std::vector<int> pivot_step_, place_, row_at_, touched_, heap_, pivot_row_;
  std::vector<char> seen_;
};

// Working storage for one mechanism, sized once; a solve allocates nothing.
struct KinematicState {
  explicit KinematicState(const Mechanism& mechanism);

  Eigen::VectorXd q, qdot, qddot;  // coordinates and their time derivatives
  // Their third derivatives: solved only for a mechanism with a cam (its follower's jerk), else 0.
  Eigen::VectorXd qdddot;
  // The drivers' states, one per driver in Mechanism::drivers order, as the layout takes them.
  std::vector<DriverState> drivers;
  SweepAxis axis;  // the mechanism's (Mechanism::axis())
  int driver_count() const { return static_cast<int>(drivers.size()); }
  // The swept driver's state (Mechanism::swept()); a sweep in time has none (std::logic_error).
  DriverState& swept() { return drivers[swept_index()]; }
  const DriverState& swept() const { return drivers[swept_index()]; }
  // Every driver at time t, by its motion law.
  void drive_at(const Mechanism& mechanism, double t);
  double time() const { return drivers.front().time; }  // every driver's state holds the same
  // The state's place along the sweep's axis: the swept driver's value, or the time (each driver
  // at its law's value then).
  double parameter() const { return axis.timed() ? time() : swept().value; }
  void set_parameter(const Mechanism& mechanism, double p);
  // Scratch: the constraint vector, the Jacobian and its factorisation.
  Eigen::VectorXd phi, rhs;
  SparseJacobian jacobian;  // scaled: S_r J S_c (NewtonSolver::jacobian_entry unscales)
  SmallLU lu;
  // Whether `lu` holds the factorisation of J at a solved pose (the last solve_position's), and
  // that pose's rcond: solve_position then starts with chord iterations on those factors.
  bool factorized = false;
  double factorized_rcond = 0.0;
  Eigen::VectorXd q_start;  // scratch: where a chord iteration started
  // Scratch of the condition estimate (Eigen's rcond() allocates its vectors on every call).
  double jacobian_norm = 0.0;  // L1 norm of the scaled Jacobian that `lu` factorises
  Eigen::VectorXd estimate, estimate_rhs, sign, previous_sign;
  // cos and sin of every moving link's angle at q, computed once per Newton iteration.
  Eigen::VectorXd cos_theta, sin_theta;

 private:
  size_t swept_index() const {
    if (axis.timed()) throw std::logic_error("a sweep in time has no swept driver");
    return static_cast<size_t>(axis.driver);
  }
};

class NewtonSolver {
 public:
  explicit NewtonSolver(const Mechanism& mechanism, NewtonOptions options = {});

  const Mechanism& mechanism() const { return mechanism_; }
  const NewtonOptions& options() const { return options_; }
  double length_scale() const { return length_scale_; }
  // The largest entry of v in size-free coordinates: lengths / size, angles in rad.
  double size_free_norm(const Eigen::VectorXd& v) const;
  // Whether a Newton step dq from q moves it by round-off only. A link turned by many turns
  // with a point drawn far out has a residual floor (eps |angle| arm) that can lie above the
  // tolerance; Newton has converged there all the same.
  bool round_off_step(const Eigen::VectorXd& dq, const Eigen::VectorXd& q) const;

  // Constraint residual Phi(q) with the driver's row less `driver_value`.
  void residual(const Eigen::VectorXd& q, double driver_value, Eigen::VectorXd& phi) const;
  // The same with each driver's row less its state's value (one state per driver).
  void residual(const Eigen::VectorXd& q, std::span<const DriverState> drivers,
                Eigen::VectorXd& phi) const;
  // Analytic Jacobian dPhi/dq (the drivers' rows included).
  void jacobian(const Eigen::VectorXd& q, Eigen::MatrixXd& jac) const;
  // Driver d's coordinate measured at q (its definition, e.g. the angle of E->D), in
  // Mechanism::drivers order.
  double driver_value(const Eigen::VectorXd& q, int d) const;

  // Newton from state.q at state.driver.value. Leaves the LU of J at the solution in state.
  SolveReport solve_position(KinematicState& state) const;
  // Newton steps beyond the tolerance from a pose solve_position converged on (`report` its
  // report), while each lowers |Phi|: to round-off. Near a singular position the rates' error
  // grows as the residual over the square of the Jacobian's smallest singular value (the
  // accelerations' over its cube), so the tolerance's residual is not enough for them. Leaves J
  // factorised at the pose, as solve_position does.
  SolveReport polish(KinematicState& state, SolveReport report) const;
  // Linear solves with the factorisation left by solve_position; the acceleration's is followed
  // by the jerk's where the mechanism has a cam.
  void solve_velocity(KinematicState& state) const;
  void solve_acceleration(KinematicState& state) const;
  // All three; the usual entry point.
  SolveReport solve(KinematicState& state) const;

  // Assemble from the definition's drawn poses at the driver's start value (the branch that the
  // drawing shows); Levenberg–Marquardt tells "cannot assemble" from "did not converge".
  SolveReport assemble(KinematicState& state) const;
  // The coordinates as drawn (poses from the file; links without one at the origin).
  Eigen::VectorXd drawn_coordinates() const;
  // Moves each angular driver's link by the whole turns between its drawn angle and the driver's
  // value in `at` (only where no other row's residual moves: not through a gear pair).
  void unwind_to_drivers(Eigen::VectorXd& q, std::span<const DriverState> at) const;

  // Lagrange multipliers at the pose factorised by the last solve_position: lambda with
  // J^T lambda = b, for generalised forces b (one per coordinate). Uses state.rhs as scratch.
  void multipliers(KinematicState& state, const Eigen::VectorXd& b, Eigen::VectorXd& lambda) const;
  // Entry (row, column) of the unscaled Jacobian at that pose.
  double jacobian_entry(const KinematicState& state, int row, int column) const {
    return state.jacobian.coeff(row, column) / (row_scale_(row) * col_scale_(column));
  }
  // The rows of Phi: each joint's and the driver's, their equations and which are angles.
  const ConstraintLayout& layout() const { return layout_; }

  // The first spline slot whose pin lies past one of its ends at q: `where` names the end and the
  // slot, `message` says it; both empty when every pin is in its slot.
  struct SlotEnd {
    std::string where, message;
  };
  SlotEnd past_slot_end(const Eigen::VectorXd& q) const;

  // Writes sample `row` of a trajectory from a solved state. A pose whose pin lies past an end of
  // its spline slot does not exist (the slot's end stops the motion): the sample is flagged
  // cannot_assemble, and the trajectory's first such sample gets an event.
  void write_sample(const KinematicState& state, const SolveReport& report, Trajectory& out,
                    int row) const;

 private:
  // The frames at state.q with state's cos and sin (update_frames).
  static LinkFrames frames(const KinematicState& state) {
    return {state.q, &state.cos_theta, &state.sin_theta};
  }
  // state.cos_theta, state.sin_theta at state.q.
  void update_frames(KinematicState& state) const;
  // Builds the scaled Jacobian at state.q and factorises it into state.lu.
  void factorize(KinematicState& state) const;
  // Chord (simplified Newton) iterations from state.q with the factors left by the previous
  // solve: true when they reach the tolerance. When they stop contracting, state.q is put back
  // where they started (or left where they got to, if they were contracting but slowly).
  bool chord(KinematicState& state, double tolerance, SolveReport& report) const;
  // The acceleration solve with state's frames already those of state.q.
  void acceleration_at_frames(KinematicState& state) const;
  // x = J^-1 state.rhs with the factorisation in state (state.rhs is overwritten).
  void solve_linear(KinematicState& state, Eigen::VectorXd& x) const;
  double scaled_norm(const Eigen::VectorXd& phi) const;  // |S_r phi|_inf [m]
  // Reciprocal condition estimate of the factorised J, without allocating.
  double rcond(KinematicState& state) const;

  const Mechanism& mechanism_;
  NewtonOptions options_;
  ConstraintLayout layout_;
  double length_scale_;  // Mechanism::size() [m]
  // Diagonal scalings S_r (angle rows * size) and S_c (angle columns / size).
  Eigen::VectorXd row_scale_, col_scale_;
  std::vector<int> scaled_rows_;  // rows whose scale is not 1
  std::vector<Mechanism::NamedPoint> named_points_;
  std::vector<int> slide_joints_;
  bool solves_jerk_ = false;       // a cam's follower has a jerk to report
  std::vector<int> spline_slots_;  // joints whose pin must stay between its slot's ends
};

}  // namespace crosslink
