#include "analytic/physics/dynamics.h"

#include <fmt/format.h>

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Cholesky>

#include "analytic/kinematics/continuation.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/units_text.h"
#include "analytic/physics/kinetostatics.h"

namespace crosslink {
namespace {

constexpr double kFirstStep = 1e-5;  // [s]: the integrator's first trial step

// Why a run stopped: the chain could not close, or only another branch was near.
struct Stopped {
  double time;
  PoseStatus status;
  std::string message;
  bool over_budget = false;  // the run reached SimulationOptions::max_solves
};

// The free coordinates' values: one (double) or several (a vector, one per driver).
void place(KinematicState& state, double t, double d) {
  state.swept() = {t, d, 1.0, 0.0};
}
void place(KinematicState& state, double t, const Eigen::VectorXd& d) {
  for (int i = 0; i < d.size(); ++i) state.drivers[static_cast<size_t>(i)] = {t, d(i), 0.0, 0.0};
}
// The continuation steps a span of the coordinates takes, one coordinate per driver: none moves
// more than its driver's continuation step between two solves.
double steps_over(const Mechanism& m, double span) {
  return std::abs(span) / continuation_step(m.swept(), m.size());
}
double steps_over(const Mechanism& m, const Eigen::VectorXd& span) {
  double steps = 0.0;
  for (Eigen::Index i = 0; i < span.size(); ++i)
    steps = std::max(
        steps, std::abs(span(i)) / continuation_step(m.drivers[static_cast<size_t>(i)], m.size()));
  return steps;
}
std::string shown(double d, int digits) {
  return fmt::format("{:.{}g}", d, digits);
}
std::string shown(const Eigen::VectorXd& d, int digits) {
  std::string out = "(";
  for (int i = 0; i < d.size(); ++i) out += fmt::format("{}{:.{}g}", i ? ", " : "", d(i), digits);
  return out + ")";
}
// The pose predicted a step h of the coordinates on from q, with dq/dd = s.
void predict(const Eigen::VectorXd& q, double h, const Eigen::VectorXd& s, Eigen::VectorXd& out) {
  out = q + h * s;
}
void predict(const Eigen::VectorXd& q, const Eigen::VectorXd& h, const Eigen::MatrixXd& s,
             Eigen::VectorXd& out) {
  out = q + s * h;
}
double predicted_move(double h, const Eigen::VectorXd& s) {
  return (h * s).lpNorm<Eigen::Infinity>();
}
double predicted_move(const Eigen::VectorXd& h, const Eigen::MatrixXd& s) {
  return (s * h).lpNorm<Eigen::Infinity>();
}

// The pose of the chain followed by continuation along its free coordinates: Coordinates is a
// double (one coordinate, Rates its dq/dd) or a vector (several, Rates dq/dd one column each).
template <class Coordinates, class Rates>
class FollowedChain {
 public:
  FollowedChain(const Mechanism& m, long max_solves)
      : m_(m),
        max_solves_(max_solves),
        solver_(m, NewtonOptions{.tolerance = 1e-15}),
        kinetostatics_(solver_),
        state_(m),
        applied_(m.coordinate_count()),
        q_last_(m.coordinate_count()),
        guess_(m.coordinate_count()) {
    const SolveReport assembled = solver_.assemble(state_);
    if (assembled.status != PoseStatus::ok)
      throw Stopped{0.0, assembled.status,
                    "the chain does not assemble at its start: " + assembled.message};
    // Poses far less well conditioned than the drawn one are next to a singular position (a
    // long chain's Jacobian is ill-conditioned everywhere: A02's rcond is 4e-2 upright at
    // N = 2 and 2e-4 at N = 40).
    if (const std::string why = singular_start(m, assembled.rcond); !why.empty())
      throw Stopped{0.0, PoseStatus::singular, why};
    near_singular_rcond_ = std::min(1e-4, 1e-2 * assembled.rcond);
    interpolated_rcond_ = std::min(1e-3, 3e-2 * assembled.rcond);
    if constexpr (std::is_same_v<Coordinates, double>) {
      d_last_ = state_.swept().value;
    } else {
      d_last_.resize(state_.driver_count());
      for (int i = 0; i < state_.driver_count(); ++i)
        d_last_(i) = state_.drivers[static_cast<size_t>(i)].value;
    }
    q_last_ = state_.q;
    unit_rate();
    s_last_ = s_;
  }

  const NewtonSolver& solver() const { return solver_; }
  const Kinetostatics& kinetostatics() const { return kinetostatics_; }
  KinematicState& state() { return state_; }
  long evaluations() const { return evaluations_; }
  // The reciprocal condition of the pose at the coordinate of the last acceleration().
  double rcond() const { return rcond_; }
  long solves() const { return solves_; }

  // Whether the pose of the last acceleration() is next to a singular position: resolved only to
  // Newton's tolerance over J's condition, a sample there is flagged (the interpolation's zone
  // is wider: its edge serves the integration, where 1e-10 of an acceleration matters).
  bool near_singular() const { return near_singular_; }

 protected:
  // Solves the pose at d from the last regular one, in continuation steps; s_ = dq/dd there.
  // Returns the pose's reciprocal condition; a pose next to a singular one is not taken as the
  // start of the next continuation (its s is not reliable) and its correction is not checked
  // (Newton resolves it only to ~sqrt(tolerance) there).
  double move_to(double t, const Coordinates& d) {
    const Coordinates from = d_last_, span = d - from;
    const double wanted = std::max(1.0, std::ceil(steps_over(m_, span)));
    // Counted before they are taken: one evaluation may ask for billions (a coordinate thrown
    // across 1e9 rad by an effort of 1e12 in a nanosecond).
    if (!(solves_ + wanted <= static_cast<double>(max_solves_)))
      throw Stopped{t, PoseStatus::not_reached,
                    fmt::format("the run has taken {} pose solves and its next evaluation asks "
                                "for {:.0f} more (coordinate {} to {}): the limit is {} "
                                "(raise it with --max-solves N)",
                                solves_, wanted, shown(from, 6), shown(d, 6), max_solves_),
                    true};
    const int steps = static_cast<int>(wanted);
    solves_ += steps;
    double rcond = 1.0;
    for (int i = 1; i <= steps; ++i) {
      const Coordinates target = i == steps ? d
                                            : Coordinates(from + span * static_cast<double>(i) /
                                                                     static_cast<double>(steps)),
                        h = target - d_last_;
      predict(q_last_, h, s_last_, guess_);
      state_.q = guess_;
      place(state_, t, target);
      const SolveReport r = solver_.solve_position(state_);
      if (r.status != PoseStatus::ok && r.status != PoseStatus::singular)
        throw Stopped{t, r.status,
                      fmt::format("at coordinate {}: {}", shown(target, 12), r.message)};
      rcond = r.rcond;
      if (rcond < near_singular_rcond_) {
        // Stepped over: the next pose is predicted from the last regular one, across.
        if (i < steps) continue;
        unit_rate();
        return rcond;
      }
      // Newton may only polish the predicted pose: a large correction is another branch.
      const double predicted = predicted_move(h, s_last_);
      if ((state_.q - guess_).lpNorm<Eigen::Infinity>() >
          0.1 * predicted + 1e-9 * solver_.length_scale())
        throw Stopped{t, PoseStatus::branch_jump,
                      fmt::format("the only pose near coordinate {} is on another branch",
                                  shown(target, 12))};
      unit_rate();
      d_last_ = target;
      q_last_ = state_.q;
      s_last_ = s_;
    }
    return rcond;
  }

  // s_ = dq/dd at the pose factorised last: one velocity solve per coordinate at unit rate, the
  // others' 0.
  void unit_rate() {
    if constexpr (std::is_same_v<Coordinates, double>) {
      state_.swept().rate = 1.0;
      solver_.solve_velocity(state_);
      s_ = state_.qdot;
    } else {
      s_.resize(m_.coordinate_count(), state_.driver_count());
      for (int i = 0; i < state_.driver_count(); ++i) {
        for (int j = 0; j < state_.driver_count(); ++j)
          state_.drivers[static_cast<size_t>(j)].rate = i == j ? 1.0 : 0.0;
        solver_.solve_velocity(state_);
        s_.col(i) = state_.qdot;
      }
    }
  }

  const Mechanism& m_;
  const long max_solves_;
  long solves_ = 0;
  NewtonSolver solver_;
  Kinetostatics kinetostatics_;
  KinematicState state_;
  Eigen::VectorXd applied_, q_last_, guess_;
  Rates s_, s_last_;  // dq/dd at the pose, and at the last regular one
  Coordinates d_last_{};
  double rcond_ = 1.0;
  long evaluations_ = 0;
  bool near_singular_ = false;
  // Poses closer to a singular one than this (reciprocal condition of J; Newton resolves them
  // to its tolerance over it) are stepped over by the continuation, not started from.
  double near_singular_rcond_ = 1e-4;
  // Poses closer than this have their acceleration interpolated (see acceleration()).
  double interpolated_rcond_ = 1e-3;
};

// The minimal-coordinate equation of motion of one free coordinate, with the pose followed by
// continuation.
class EquationOfMotion : public FollowedChain<double, Eigen::VectorXd> {
 public:
  using State = std::array<double, 3>;  // d, ddot, w

  EquationOfMotion(const Mechanism& m, long max_solves)
      : FollowedChain(m, max_solves),
        friction_(!m.friction_joints().empty()),
        forces_(kinetostatics_.make_sample()),
        moving_(state_) {}

  // Joint friction (docs/dynamics.md, "Joint friction"): the motion runs in phases of one
  // direction of sliding, +1 or -1 (0: at rest, held by friction), the friction opposing that
  // direction throughout a phase, so that the instant the rate reaches zero is located on smooth
  // motion (integrate_phases).
  bool friction() const { return friction_; }
  int direction() const { return direction_; }
  void set_direction(int direction) { direction_ = direction; }
  // The pose of the last evaluation moving at unit rate in its phase's direction (null when held
  // or without friction): whose friction signs a state at rest that breaks away takes.
  const KinematicState* phase_motion() const {
    return friction_ && direction_ != 0 ? &moving_ : nullptr;
  }
  // At rest at coordinate d: the direction the mechanism breaks away in, each friction at its
  // static limit against it (+1 or -1), or 0 when friction holds it.
  int breakaway(double t, double d) {
    for (const int direction : {1, -1}) {
      direction_ = direction;
      const double dddot = acceleration(t, d, 0.0, m_.dynamics->effort_at(t), nullptr, true);
      if (direction * dddot > 0.0) return direction;
    }
    direction_ = 0;
    return 0;
  }

  // The state at (t, x): the pose, its rates and accelerations.
  void at(double t, const State& x) { acceleration(t, x[0], x[1], m_.dynamics->effort_at(t)); }
  // The work done so far, of state x.
  static double work(const State& x) { return x[2]; }

  // dd/dt, dddot/dt and dw/dt at (t, x).
  void operator()(const State& x, State& dxdt, double t) {
    ++evaluations_;
    const double effort = m_.dynamics->effort_at(t);
    double power = 0.0;
    const double dddot = acceleration(t, x[0], x[1], effort, &power);
    dxdt = {x[1], dddot, effort * x[1] + power};
  }

  // The coordinate's acceleration at (d, ddot) under `effort`, and the power of the loads and
  // dampers, from the reduced equation of motion m(d) dddot + c(d) ddot^2 = effort + s^T Q.
  // Next to a singular position (a change point, where J loses rank but the motion goes on
  // smoothly) s and ds/dd carry round-off times the square of J's condition, so there the
  // kinematic terms (s, ds/dd, m, c: functions of d alone, smooth along the branch) are
  // interpolated from eight regular poses around the zone (interpolate), while Q (loads, springs,
  // dampers, gravity, which may have a kink there) is taken at d itself. The zone's edge (rcond
  // 1e-3 on A02) balances the two errors: with its edge at 1e-4 and six nodes, a regular evaluation
  // at the edge was off by 1e-8 of the acceleration, and a one-ulp change of the mass moved A02's
  // energy balance over 10 s between 7e-10 and 9e-9 J (docs/dynamics.md).
  double acceleration(double t, double d, double ddot, double effort, double* power = nullptr,
                      bool at_rest = false) {
    rcond_ = move_to(t, d);
    near_singular_ = rcond_ < near_singular_rcond_;
    if (rcond_ < interpolated_rcond_)
      interpolate(t, d);
    else
      reduce(t, d, here_);
    const double dddot = motion(t, d, ddot, effort, power);
    return friction_ ? with_friction(t, ddot, effort, dddot, power, at_rest) : dddot;
  }

 private:
  // The widest spacing of the interpolation's nodes [rad, or of the size]: 0.16, so the nodes
  // span +-0.64 and the interpolation's error, ~(spacing)^8 times the eighth derivative, is still
  // small against the motion's scale.
  static constexpr double kWidestSpread = 0.16;

  // The kinematics of the reduced equation at a pose: s = dq/dd; a = d2q/dd2 (qddot at unit
  // rate and no coordinate acceleration); m = s^T M s, twice the kinetic energy at unit rate (a
  // sum of squares: as the difference of two force evaluations it drowned in a fast coasting
  // chain's centripetal terms, and 1e6 rev/s read a mass of 0); c = s^T M a = m'/2, the kinetic
  // energy's rate at unit rate.
  struct Reduced {
    Eigen::VectorXd s, a;
    double mass = 0.0, velocity_product = 0.0;
  };

  // The reduced kinematics at the pose move_to(t, d) left.
  void reduce(double t, double d, Reduced& r) {
    state_.qdot = s_;
    state_.swept() = {t, d, 1.0, 0.0};
    solver_.solve_acceleration(state_);
    r.s = s_;
    r.a = state_.qddot;
    r.mass = 2.0 * kinetostatics_.kinetic_energy(state_);
    r.velocity_product = kinetostatics_.kinetic_energy_rate(state_);
  }

  // here_ at d inside the zone next to a singular position, by Lagrange interpolation from
  // eight regular poses at lo - k h and hi + k h (k = 1 .. 4), lo and hi the zone's edges (the
  // first regular coordinates found in steps of 0.005 rad, or of the size, outward from the
  // coordinate that entered it) and h = (hi - lo) / 2: at the zone's middle they are the nodes
  // d +- k h, k = 1 .. 4 (error ~0.014 h^8 times the terms' eighth derivative). They are
  // reduced once a zone, not once an evaluation: nodes centred on each evaluation cost A02 with
  // N = 40 67 pose solves an evaluation in the zone, 71 % of its run. (With nodes at the edges
  // themselves, lo - k h and hi + k h for k = 0 .. 3, the terms were continuous at the edges
  // but carried the round-off of the edge poses: A02's energy balance over 10 s under mass
  // perturbations of k ulp, k = -8 .. 8, spread to 5.9e-10 J against 2.7e-10 J; docs/dynamics.md.)
  // The pose stays at d.
  void interpolate(double t, double d) {
    if (!(zone_.lo <= d && d <= zone_.hi)) find_zone(t, d);
    here_.s.setZero(m_.coordinate_count());
    here_.a.setZero(m_.coordinate_count());
    here_.mass = here_.velocity_product = 0.0;
    for (size_t i = 0; i < zone_.nodes.size(); ++i) {
      double weight = 1.0;
      for (size_t j = 0; j < zone_.nodes.size(); ++j)
        if (j != i) weight *= (d - zone_.nodes[j]) / (zone_.nodes[i] - zone_.nodes[j]);
      const Reduced& node = zone_.reduced[i];
      here_.s += weight * node.s;
      here_.a += weight * node.a;
      here_.mass += weight * node.mass;
      here_.velocity_product += weight * node.velocity_product;
    }
  }

  // The zone around d (whose pose is below interpolated_rcond_) and its nodes' kinematics;
  // leaves the pose at d.
  void find_zone(double t, double d) {
    const double unit = m_.swept().angular() ? 1.0 : solver_.length_scale(), step = 5e-3 * unit;
    std::array<double, 2> edge{};
    for (const int side : {0, 1}) {
      double delta = step;
      while (move_to(t, d + (side ? delta : -delta)) < interpolated_rcond_) {
        delta += step;
        if (delta > 2.0 * kWidestSpread * unit)
          throw Stopped{t, PoseStatus::singular,
                        fmt::format("singular on both sides of coordinate {:.12g}", d)};
      }
      edge[static_cast<size_t>(side)] = d + (side ? delta : -delta);
    }
    const double h = 0.5 * (edge[1] - edge[0]);
    if (h > kWidestSpread * unit)
      throw Stopped{t, PoseStatus::singular,
                    fmt::format("singular on both sides of coordinate {:.12g}", d)};
    zone_.lo = edge[0];
    zone_.hi = edge[1];
    for (size_t i = 0; i < 4; ++i) {
      zone_.nodes[i] = edge[0] - static_cast<double>(4 - i) * h;
      zone_.nodes[i + 4] = edge[1] + static_cast<double>(i + 1) * h;
    }
    for (size_t i = 0; i < zone_.nodes.size(); ++i) {
      if (move_to(t, zone_.nodes[i]) < interpolated_rcond_)
        throw Stopped{
            t, PoseStatus::singular,
            fmt::format("no regular poses at {:g} apart around coordinate {:.12g}", h, d)};
      reduce(t, zone_.nodes[i], zone_.reduced[i]);
    }
    move_to(t, d);
  }

  // The acceleration from here_ and Q at the pose at d; leaves the state at (d, ddot, dddot).
  double motion(double t, double d, double ddot, double effort, double* power) {
    if (!(here_.mass > 0.0))
      throw Stopped{
          t, PoseStatus::singular,
          fmt::format("the generalised mass is {:g} at coordinate {:.12g}", here_.mass, d)};
    state_.qdot = here_.s * ddot;
    state_.swept() = {t, d, ddot, 0.0};
    kinetostatics_.generalised_forces(state_, applied_, false);
    const double dddot =
        (effort + here_.s.dot(applied_) - ddot * ddot * here_.velocity_product) / here_.mass;
    state_.qddot = here_.a * (ddot * ddot) + here_.s * dddot;
    state_.swept().accel = dddot;
    if (power) *power = kinetostatics_.load_power(state_);
    return dddot;
  }

  // The acceleration with joint friction, from motion()'s without it (`guess`): the one whose
  // exact kinetostatics needs the applied effort, each friction opposing the phase's direction
  // (at its static limit `at_rest`), by the secant method on that effort (affine in the
  // acceleration but for the friction, whose reactions depend on it). Leaves the state at it,
  // and adds the friction's power to `power`.
  double with_friction(double t, double ddot, double effort, double guess, double* power,
                       bool at_rest) {
    if (direction_ == 0) {  // held at rest
      state_.qddot.setZero();
      state_.swept().accel = 0.0;
      return 0.0;
    }
    if (near_singular_)
      throw Stopped{t, PoseStatus::singular,
                    "joint friction next to a singular position is not modelled: its reactions "
                    "are not resolved there"};
    moving_.q = state_.q;
    moving_.qdot = here_.s * static_cast<double>(direction_);
    moving_.swept() = {t, state_.swept().value, static_cast<double>(direction_), 0.0};
    const auto needed = [&](double dddot) {
      state_.qddot = here_.a * (ddot * ddot) + here_.s * dddot;
      state_.swept().accel = dddot;
      kinetostatics_.solve(state_, forces_, moving_, at_rest);
      if (forces_.status != PoseStatus::ok) throw Stopped{t, forces_.status, forces_.why(m_)};
      return forces_.effort(0) - effort;
    };
    double x0 = guess, r0 = needed(x0);
    double x1 = x0 - r0 / here_.mass;
    for (int it = 0; it < kFrictionSecantSteps; ++it) {
      const double r1 = needed(x1);
      if (r1 == 0.0 || r1 == r0) break;
      const double x2 = x1 - r1 * (x1 - x0) / (r1 - r0);
      x0 = x1;
      r0 = r1;
      x1 = x2;
      if (std::abs(x1 - x0) <= 1e-15 * std::max(std::abs(x1), std::abs(guess))) break;
    }
    (void)needed(x1);  // the state and forces at the solution
    if (power) *power += kinetostatics_.friction_power(state_, forces_);
    return x1;
  }

  // The secant steps of with_friction: the effort is affine in the acceleration but for the
  // friction, so a handful reach round-off.
  static constexpr int kFrictionSecantSteps = 50;

  Reduced here_;  // at the coordinate
  const bool friction_;
  int direction_ = 0;
  ForceSample forces_;
  KinematicState moving_;  // the pose, moving at unit rate in the phase's direction
  // The last zone next to a singular position: its edges and its nodes (interpolate).
  struct Zone {
    double lo = 0.0, hi = -1.0;  // empty until one is found
    std::array<double, 8> nodes{};
    std::array<Reduced, 8> reduced;
  } zone_;
};

// The equations of motion of several free coordinates d (one per driver). S = dq/dd (one velocity
// solve per driver at unit rate, the others' 0) and qddot0 (the acceleration solve at qdot =
// S ddot with every coordinate's acceleration 0) give qddot = qddot0 + S dddot; projected on S's
// columns, along which the constraint forces do no work,
//   (S^T M S) dddot = efforts(t) + S^T (Q - M qddot0),
// with Q - M qddot0 from Kinetostatics::generalised_forces and S^T M S the kinetic energy's
// bilinear form on S's columns (Kinetostatics::inertia_product). A pose next to a singular
// position stops the run: the one coordinate's interpolation across one (EquationOfMotion) is
// along a line, and several coordinates would need it over a surface.
class SeveralEquations : public FollowedChain<Eigen::VectorXd, Eigen::MatrixXd> {
 public:
  using State = std::vector<double>;  // d (n), ddot (n), w

  SeveralEquations(const Mechanism& m, long max_solves)
      : FollowedChain(m, max_solves),
        n_(static_cast<int>(m.drivers.size())),
        d_(n_),
        rate_(n_),
        effort_(n_),
        dddot_(n_),
        rhs_(n_),
        mass_(n_, n_),
        rough_(m.friction_joints()),
        forces_(kinetostatics_.make_sample()) {
    phase_.direction.assign(rough_.size(), 1);
    phase_.holding.setZero(static_cast<Eigen::Index>(rough_.size()));
  }

  // Joint friction (docs/dynamics.md, "Joint friction"): each friction joint slides in one
  // direction through a phase (its friction opposing it) or is held at rest relative to its first
  // link (its friction what holds it, inside its static limit), so that the instant a phase ends
  // is located on smooth motion (integrate_modes).
  bool friction() const { return !rough_.empty(); }
  const FrictionPhase& phase() const { return phase_; }
  // Whether the last phases chosen hold the whole mechanism at rest (choose_phases).
  bool resting() const { return resting_; }
  const std::vector<int>& friction_joints() const { return rough_; }

  // The first friction joint (its index in friction_joints()) whose phase ends by state (t, x):
  // sliding, its rate no longer has the phase's direction; held, its friction is past its static
  // limit. -1: none.
  int phase_ended(double t, const State& x) {
    at(t, x);
    for (size_t f = 0; f < rough_.size(); ++f) {
      const int direction = phase_.direction[f];
      const auto i = static_cast<int>(f);
      if (direction != 0 && direction * kinetostatics_.relative_rate(state_, i) <= 0.0) return i;
      if (direction == 0 && slips(i, 1.0 + 1e-12)) return i;
    }
    return -1;
  }

  // The phases from state (t, x) on, where the joints `ended` (friction_joints() indices) have
  // just ended theirs, or every joint at the start: a joint that stops relative to its first link
  // is held (its rate is made exactly zero, the other rates changed least in kinetic energy), and
  // a held joint whose static limit cannot hold it slides away from the friction it needed. Each
  // change is written to `changes` as (joint, new direction).
  void choose_phases(double t, State& x, std::vector<int> ended,
                     std::vector<std::pair<int, int>>& changes) {
    at(t, x);
    const bool start = ended.empty();
    for (size_t f = 0; f < rough_.size(); ++f) {
      const auto i = static_cast<int>(f);
      const double w = kinetostatics_.relative_rate(state_, i);
      const bool stopped = std::ranges::find(ended, i) != ended.end() ||
                           !(std::abs(w) > kinetostatics_.rest_rate(state_, i));
      const int direction = stopped ? 0 : w > 0.0 ? 1 : -1;
      if (start || direction != phase_.direction[f]) changes.emplace_back(i, direction);
      phase_.direction[f] = direction;
    }
    hold_still(t, x);
    // A held joint its static limit cannot hold slides, away from the friction that would have
    // held it; then the others are asked again.
    for (size_t round = 0; round <= rough_.size(); ++round) {
      at(t, x);
      int away = -1;
      for (size_t f = 0; f < rough_.size() && away < 0; ++f) {
        const auto i = static_cast<int>(f);
        if (phase_.direction[f] == 0 && slips(i)) away = i;
      }
      if (away < 0) break;
      const int direction = phase_.holding(away) > 0.0 ? -1 : 1;
      phase_.direction[static_cast<size_t>(away)] = direction;
      changes.emplace_back(away, direction);
      resting_ = false;  // one slides away
    }
  }

  // The start: each driver's start value and initial rate, no work done.
  static State start(const Mechanism& m) {
    const int n = static_cast<int>(m.drivers.size());
    State x(static_cast<size_t>(2 * n + 1), 0.0);
    for (int i = 0; i < n; ++i) {
      x[static_cast<size_t>(i)] = m.drivers[static_cast<size_t>(i)].start;
      x[static_cast<size_t>(n + i)] = m.dynamics->coordinate(i).rate;
    }
    return x;
  }

  // dd/dt, dddot/dt and dw/dt at (t, x).
  void operator()(const State& x, State& dxdt, double t) {
    ++evaluations_;
    double power = 0.0;
    at(t, x, &power);
    dxdt.resize(x.size());
    for (int i = 0; i < n_; ++i) {
      dxdt[static_cast<size_t>(i)] = rate_(i);
      dxdt[static_cast<size_t>(n_ + i)] = dddot_(i);
    }
    dxdt[static_cast<size_t>(2 * n_)] = effort_.dot(rate_) + power;
  }

  // The state at (t, x): the pose, its rates and accelerations (and the power of the loads and
  // dampers).
  void at(double t, const State& x, double* power = nullptr) {
    for (int i = 0; i < n_; ++i) {
      d_(i) = x[static_cast<size_t>(i)];
      rate_(i) = x[static_cast<size_t>(n_ + i)];
      effort_(i) = m_.dynamics->coordinate(i).effort_at(t);
    }
    rcond_ = move_to(t, d_);
    near_singular_ = rcond_ < near_singular_rcond_;
    if (rcond_ < interpolated_rcond_)
      throw Stopped{t, PoseStatus::singular,
                    fmt::format("next to a singular position of the coordinates {} (rcond "
                                "{:.1e}): the reference with several free coordinates does not "
                                "integrate through one",
                                shown(d_, 12), rcond_)};
    for (int i = 0; i < n_; ++i) state_.drivers[static_cast<size_t>(i)] = {t, d_(i), rate_(i), 0.0};
    state_.qdot = s_ * rate_;
    solver_.solve_acceleration(state_);
    kinetostatics_.generalised_forces(state_, applied_);
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j <= i; ++j)
        mass_(i, j) = mass_(j, i) = kinetostatics_.inertia_product(state_, s_.col(i), s_.col(j));
    rhs_ = effort_ + s_.transpose() * applied_;
    const Eigen::LLT<Eigen::MatrixXd> llt(mass_);
    if (llt.info() != Eigen::Success)
      throw Stopped{t, PoseStatus::singular,
                    fmt::format("the generalised mass is not positive definite at coordinates {}",
                                shown(d_, 12))};
    dddot_ = llt.solve(rhs_);
    if (friction()) {
      with_friction(t);
    } else {
      state_.qddot += s_ * dddot_;
      for (int i = 0; i < n_; ++i) state_.drivers[static_cast<size_t>(i)].accel = dddot_(i);
    }
    if (power)
      *power = kinetostatics_.load_power(state_) +
               (friction() ? kinetostatics_.friction_power(state_, forces_) : 0.0);
  }
  static double work(const State& x) { return x.back(); }

 private:
  // The accelerations with joint friction, from at()'s without it (dddot_): those whose exact
  // kinetostatics needs the given efforts, each sliding joint's friction against its phase's
  // direction and each held joint's relative acceleration zero, its friction (the phase's
  // holding) an unknown with them. The efforts are affine in both but for the friction's load
  // (|R|, and the tooth force's separating part): Newton with a difference Jacobian, a handful of
  // steps to round-off. Leaves the state and forces_ at the solution.
  void with_friction(double t) {
    const Eigen::VectorXd qddot0 = state_.qddot;  // every coordinate's acceleration 0
    const std::vector<int> held = held_joints();
    const Eigen::Index n = n_, unknowns = n + static_cast<Eigen::Index>(held.size());
    const auto residual = [&](const Eigen::VectorXd& z, Eigen::VectorXd& r) {
      for (size_t i = 0; i < held.size(); ++i)
        phase_.holding(held[i]) = z(n + static_cast<Eigen::Index>(i));
      state_.qddot = qddot0 + s_ * z.head(n);
      for (int i = 0; i < n_; ++i) state_.drivers[static_cast<size_t>(i)].accel = z(i);
      kinetostatics_.solve(state_, forces_, state_, false, &phase_);
      if (forces_.status != PoseStatus::ok) throw Stopped{t, forces_.status, forces_.why(m_)};
      r.head(n) = forces_.effort - effort_;
      for (size_t i = 0; i < held.size(); ++i)
        r(n + static_cast<Eigen::Index>(i)) = kinetostatics_.relative_acceleration(state_, held[i]);
    };
    Eigen::VectorXd z(unknowns), r(unknowns), shifted(unknowns), r_shifted(unknowns);
    z.head(n) = dddot_;
    for (size_t i = 0; i < held.size(); ++i)
      z(n + static_cast<Eigen::Index>(i)) = phase_.holding(held[i]);
    residual(z, r);
    // Each unknown's scale: the accelerations' and the efforts' and frictions' largest.
    const double accel_scale = std::max(dddot_.lpNorm<Eigen::Infinity>(), 1e-12);
    double force_scale = std::max(effort_.lpNorm<Eigen::Infinity>(), 1e-12);
    for (const double f : forces_.friction) force_scale = std::max(force_scale, std::abs(f));
    const auto scale = [&](Eigen::Index j) { return j < n ? accel_scale : force_scale; };
    Eigen::MatrixXd jacobian(unknowns, unknowns);
    for (Eigen::Index j = 0; j < unknowns; ++j) {
      shifted = z;
      const double h = 1e-7 * std::max(std::abs(z(j)), scale(j));
      shifted(j) += h;
      residual(shifted, r_shifted);
      jacobian.col(j) = (r_shifted - r) / h;
    }
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(jacobian);
    for (int it = 0;; ++it) {
      const Eigen::VectorXd step = lu.solve(r);
      if (!step.allFinite())
        throw Stopped{t, PoseStatus::friction_indeterminate,
                      "the joints held by friction do not fix the motion with the sliding ones: "
                      "how they share the load is not determined"};
      z -= step;
      residual(z, r);
      bool small = true;
      for (Eigen::Index j = 0; j < unknowns; ++j)
        small = small && std::abs(step(j)) <= 1e-14 * std::max(std::abs(z(j)), scale(j));
      if (small) break;
      if (it == kFrictionNewtonSteps)
        throw Stopped{t, PoseStatus::no_convergence,
                      "the accelerations with joint friction did not converge"};
    }
    dddot_ = z.head(n);
  }

  // Whether held friction joint f needs more than `margin` times its static limit at the last
  // evaluation: it slides.
  bool slips(int f, double margin = 1.0) const {
    return std::abs(phase_.holding(f)) > margin * kinetostatics_.friction_limit(f, forces_, true);
  }
  // The friction joints held at rest (friction_joints() indices).
  std::vector<int> held_joints() const {
    std::vector<int> held;
    for (size_t f = 0; f < rough_.size(); ++f)
      if (phase_.direction[f] == 0) held.push_back(static_cast<int>(f));
    return held;
  }

  // Newton's steps in with_friction: affine but for the friction's load, a few reach round-off.
  static constexpr int kFrictionNewtonSteps = 50;

  // Makes the held joints' relative rates exactly zero at state (t, x): the coordinates' rates
  // change least in kinetic energy, d' = d - M^-1 G^T (G M^-1 G^T)^-1 G d (G the held joints'
  // relative rates per unit rate of each coordinate, M = S^T M S).
  // Held joints that fix every coordinate (as many as coordinates, independent) hold the whole
  // mechanism at rest: its rates are then exactly zero (resting()).
  void hold_still(double t, State& x) {
    const std::vector<int> held = held_joints();
    resting_ = false;
    if (held.empty()) return;
    at(t, x);
    const auto h = static_cast<Eigen::Index>(held.size());
    Eigen::MatrixXd g(h, n_);
    const Eigen::VectorXd qdot = state_.qdot;
    for (int i = 0; i < n_; ++i) {
      state_.qdot = s_.col(i);
      for (Eigen::Index k = 0; k < h; ++k)
        g(k, i) = kinetostatics_.relative_rate(state_, held[static_cast<size_t>(k)]);
    }
    state_.qdot = qdot;
    const Eigen::LLT<Eigen::MatrixXd> llt(mass_);
    const Eigen::MatrixXd m_inv_gt = llt.solve(g.transpose());
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(g * m_inv_gt);
    if (!lu.isInvertible())
      throw Stopped{t, PoseStatus::friction_indeterminate,
                    fmt::format("{} joints held by friction at once whose relative motions are "
                                "not independent: how they share the load is not determined",
                                held.size())};
    resting_ = h == n_;
    if (resting_)
      rate_.setZero();
    else
      rate_ -= m_inv_gt * lu.solve(g * rate_);
    for (int i = 0; i < n_; ++i) x[static_cast<size_t>(n_ + i)] = rate_(i);
  }

  const int n_;
  Eigen::VectorXd d_, rate_, effort_, dddot_, rhs_;
  Eigen::MatrixXd mass_;          // S^T M S
  const std::vector<int> rough_;  // Mechanism::friction_joints()
  FrictionPhase phase_;
  ForceSample forces_;
  bool resting_ = false;
};

// Writes the samples of a run: the pose, rates and forces at each sample's state, and the energy
// balance's terms.
template <class Equations>
class SampleWriter {
 public:
  SampleWriter(Equations& eom, Simulation& out)
      : eom_(eom), out_(out), forces_(eom.kinetostatics().make_sample()) {}

  int written() const { return written_; }
  // At rest and breaking away (a stop the motion turns back at, or a start from rest): the phase's
  // motion, whose direction gives the friction its sign where the rate itself is zero.
  const KinematicState* breaking_away(const typename Equations::State& y) const {
    if constexpr (requires { eom_.phase_motion(); })
      return y[1] == 0.0 ? eom_.phase_motion() : nullptr;
    else
      return nullptr;
  }
  // Several coordinates with joint friction: each joint's phase (a held joint's friction is
  // what holds it).
  const FrictionPhase* phase() const {
    if constexpr (requires { eom_.phase(); })
      return eom_.friction() ? &eom_.phase() : nullptr;
    else
      return nullptr;
  }
  // At rest, held by joint friction (a phase of no direction).
  bool held() const {
    if constexpr (requires { eom_.direction(); })
      return eom_.friction() && eom_.direction() == 0;
    else
      return false;
  }

  void operator()(const typename Equations::State& y, double time) {
    const int k = written_;  // counted once whole: a stop inside leaves it not_reached
    Trajectory& t = out_.trajectory;
    const Kinetostatics& kinetostatics = eom_.kinetostatics();
    eom_.at(time, y);
    KinematicState& s = eom_.state();
    SolveReport report;
    report.rcond = eom_.rcond();  // the trust rules' conditioning (analytic/reference/trust.h)
    if (eom_.near_singular()) {
      // Its coordinate's motion is exact, the rest of its pose only to round-off.
      report.status = PoseStatus::singular;
      report.message = "next to a singular position";
    }
    eom_.solver().write_sample(s, report, t, k);
    if (!eom_.near_singular()) {
      if (held())
        kinetostatics.solve_held(s, forces_, eom_.solver().mechanism().dynamics->effort_at(time));
      else if (const KinematicState* moving = breaking_away(y))
        kinetostatics.solve(s, forces_, *moving, false);
      else if (const FrictionPhase* p = phase())
        kinetostatics.solve(s, forces_, s, false, p);
      else
        kinetostatics.solve(s, forces_);
      // At rest, held by friction: the pose stands, the friction is somewhere in its cone.
      if (forces_.status != PoseStatus::ok)
        t.status[static_cast<size_t>(k)] = forces_.status;
      else
        kinetostatics.write_sample(forces_, t, k);
    }
    out_.kinetic(k) = kinetostatics.kinetic_energy(s);
    out_.potential(k) = kinetostatics.potential_energy(s);
    out_.work(k) = Equations::work(y);
    out_.energy_scale = std::max({out_.energy_scale, std::abs(out_.kinetic(k)),
                                  std::abs(out_.potential(k)), std::abs(out_.work(k))});
    if (k == 0) out_.initial_energy = out_.kinetic(0) + out_.potential(0);
    ++written_;
  }

 private:
  Equations& eom_;
  Simulation& out_;
  ForceSample forces_;
  int written_ = 0;
};

// Joint friction's steps: controlled steps of `Stepper` (Runge-Kutta-Fehlberg 7(8), or
// Dormand-Prince 5(4)) on a phase's smooth motion; a step at whose end the phase no longer
// `holds` is cut at the first instant it does not, found by bisection on single steps from the
// step's start (to 1e-14 of the time).
// odeint copies a fresh stepper into the controlled one, scratch arrays unset and written before
// they are read: GCC 12 warns (-Wuninitialized, a false positive) once it inlines it.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
template <class Stepper, class State>
class PhaseStepper {
 public:
  enum class Outcome { retried, stepped, phase_ended };
  PhaseStepper(double tolerance, double interval)
      : stepper_(boost::numeric::odeint::make_controlled(tolerance, tolerance, Stepper())),
        interval_(interval) {
    restart();
  }
  // The next step from (t, x) towards `end`: retried (its trial failed: a shorter one next),
  // stepped, or cut where the phase ended (x and t there).
  template <class Equations, class Holds>
  Outcome step(Equations& eom, State& x, double& t, double end, const Holds& holds) {
    namespace odeint = boost::numeric::odeint;
    State trial = x;
    double from = t, h = std::min(dt_, end - t);
    if (stepper_.try_step(std::ref(eom), trial, from, h) == odeint::fail) {
      dt_ = h;
      return Outcome::retried;
    }
    dt_ = h;
    if (end - from <= 1e-13 * end) from = end;
    if (holds(from, trial)) {
      x = trial;
      t = from;
      return Outcome::stepped;
    }
    double lo = 0.0, hi = from - t;
    State y = x;  // do_step writes into a state of the right size
    while (hi - lo > 1e-14 * std::max(t + hi, interval_)) {
      const double mid = 0.5 * (lo + hi);
      forget(single_);
      single_.do_step(std::ref(eom), x, t, y, mid);
      (holds(t + mid, y) ? lo : hi) = mid;
    }
    forget(single_);
    single_.do_step(std::ref(eom), x, t, y, hi);
    t += hi;
    x = y;
    restart();
    return Outcome::phase_ended;
  }
  // A new phase: the next step starts small, with no derivative carried over.
  void restart() {
    forget(stepper_);
    dt_ = std::min(interval_, kFirstStep);
  }

 private:
  // Dormand-Prince reuses the last step's final derivative as the next step's first (FSAL): a
  // step from any other state must forget it.
  template <class S>
  static void forget(S& fsal) {
    if constexpr (requires { fsal.reset(); }) fsal.reset();
  }
  decltype(boost::numeric::odeint::make_controlled(1.0, 1.0, Stepper())) stepper_;
  Stepper single_;
  double interval_, dt_ = 0.0;
};
#pragma GCC diagnostic pop

// Joint friction's phases (one coordinate): controlled steps of `Stepper` (Runge-Kutta-Fehlberg
// 7(8), or Dormand-Prince 5(4)), each phase's friction opposing its direction of sliding; a step
// over which the rate reaches zero is cut at that instant, found by bisection on single steps from
// the step's start (on the phase's smooth motion, to 1e-14 of the time), and there the mechanism
// either breaks away again (its direction from the static limits) or stays at rest, held. Held,
// only the effort changes in time (its loads are functions of the pose and its rates): it breaks
// away at the first instant the effort, linear between its rows, takes it past a static limit,
// found at its rows and by bisection inside the row interval it first does (to 1e-14 of the time),
// or it stays for good.
template <class Stepper>
void integrate_phases(const Mechanism& mechanism, const SimulationOptions& options,
                      const std::vector<double>& times, double interval, EquationOfMotion& eom,
                      SampleWriter<EquationOfMotion>& observe, Simulation& out,
                      EquationOfMotion::State x) {
  using State = EquationOfMotion::State;
  PhaseStepper<Stepper, State> steps(options.tolerance, interval);
  const auto units = driver_unit_of(mechanism.swept(), mechanism.units);
  const auto at_rest = [&](double t, State& y) {
    y[1] = 0.0;
    const int direction = eom.breakaway(t, y[0]);
    eom.set_direction(direction);
    out.stops.emplace_back(t, y[0]);
    out.trajectory.stops.push_back(t);
    out.held = direction == 0;
    if (out.held) out.trajectory.held.emplace_back(t, times.back());
    // One friction joint holds it with the friction that balances the loads (solve_held); how
    // several divide the load is not determined.
    const bool determined = mechanism.friction_joints().size() == 1;
    if (direction == 0)
      out.trajectory.events.push_back(
          {t, determined ? PoseStatus::ok : PoseStatus::friction_indeterminate,
           fmt::format("at rest from t = {:.12g} s, coordinate {}: friction holds the mechanism{}",
                       t, units.text(y[0], 12),
                       determined ? ""
                                  : " (its forces inside the friction cones are not "
                                    "determined)")});
  };
  // Held at x from t: the first instant in (t, end] the effort breaks it away (its direction
  // set), or none (held to end). The effort is linear between its rows, so the held mechanism's
  // margin to its static limits is monotone between them: each row interval's end is tried, and
  // the first that breaks away is bisected.
  const std::vector<std::pair<double, double>>& effort = mechanism.dynamics->effort;
  const bool effort_changes = std::ranges::any_of(
      effort, [&](const auto& row) { return row.second != effort.front().second; });
  const auto breaks_away = [&](double from, double end, double d) -> std::optional<double> {
    if (!effort_changes) return std::nullopt;
    std::vector<double> ends;
    for (const auto& row : effort)
      if (row.first > from && row.first < end) ends.push_back(row.first);
    ends.push_back(end);
    double lo = from;
    for (const double hi : ends) {
      if (eom.breakaway(hi, d) == 0) {
        lo = hi;
        continue;
      }
      double a = lo, b = hi;
      while (b - a > 1e-14 * std::max(b, interval)) {
        const double mid = 0.5 * (a + b);
        (eom.breakaway(mid, d) == 0 ? a : b) = mid;
      }
      eom.set_direction(eom.breakaway(b, d));
      return b;
    }
    eom.set_direction(0);
    return std::nullopt;
  };
  double t = 0.0;
  if (x[1] == 0.0)
    at_rest(t, x);
  else
    eom.set_direction(x[1] > 0.0 ? 1 : -1);
  observe(x, times[0]);
  for (size_t k = 1; k < times.size(); ++k) {
    const double end = times[k];
    while (t < end) {
      if (eom.direction() == 0) {
        const std::optional<double> away = breaks_away(t, end, x[0]);
        if (!away) break;  // held through this interval
        t = *away;
        out.trajectory.held.back().second = t;
        out.trajectory.stops.push_back(t);
        out.held = false;
        out.trajectory.events.push_back(
            {t, PoseStatus::ok,
             fmt::format("breaks away at t = {:.12g} s, coordinate {}: the effort overcomes the "
                         "static friction",
                         t, units.text(x[0], 12))});
        steps.restart();
        continue;
      }
      // Sliding while the rate keeps the phase's direction; where it stops, at rest.
      if (steps.step(eom, x, t, end, [&](double, const State& y) {
            return eom.direction() * y[1] > 0.0;
          }) == PhaseStepper<Stepper, State>::Outcome::phase_ended)
        at_rest(t, x);
    }
    t = end;
    observe(x, end);
  }
}

// Joint friction's phases with several free coordinates: controlled steps of `Stepper`, each
// friction joint sliding in its phase's direction or held at rest (SeveralEquations); a step by
// whose end a phase has ended (a sliding joint's rate past zero, a held joint's friction past its
// static limit) is cut at the first such instant, found by bisection on single steps from the
// step's start (to 1e-14 of the time), and the phases are chosen again there
// (choose_phases). Each change is an event and a stop.
template <class Stepper>
void integrate_modes(const Mechanism& mechanism, const SimulationOptions& options,
                     const std::vector<double>& times, double interval, SeveralEquations& eom,
                     SampleWriter<SeveralEquations>& observe, Simulation& out,
                     SeveralEquations::State x) {
  using State = SeveralEquations::State;
  PhaseStepper<Stepper, State> steps(options.tolerance, interval);
  std::vector<std::pair<int, int>> changes;
  // Each joint whose phase changed at t is an event (one, whichever ways it went through), and
  // the instant a stop.
  const auto choose = [&](double t, State& y, std::vector<int> ended) {
    const std::vector<int> before = eom.phase().direction;
    changes.clear();
    eom.choose_phases(t, y, std::move(ended), changes);
    bool stop = false;
    for (size_t f = 0; f < before.size(); ++f) {
      const int now = eom.phase().direction[f];
      // From the start a joint slides as it was launched, unless it is held or breaks away.
      const bool changed =
          t == 0.0 ? std::ranges::any_of(changes,
                                         [&](const auto& c) {
                                           return c.first == static_cast<int>(f) && c.second == 0;
                                         })
                   : now != before[f];
      if (!changed) continue;
      stop = true;
      const Joint& j = mechanism.joints[static_cast<size_t>(eom.friction_joints()[f])];
      const char* way = now > 0 ? "forward" : "backward";
      out.trajectory.events.push_back(
          {t, PoseStatus::ok,
           now == 0 ? fmt::format("joint '{}' held at rest by its friction from t = {:.12g} s",
                                  j.name, t)
           : t > 0.0 && before[f] == -now
               ? fmt::format("joint '{}' reverses at t = {:.12g} s, now {}: its friction cannot "
                             "hold it",
                             j.name, t, way)
               : fmt::format("joint '{}' slides {} from t = {:.12g} s: its friction no longer "
                             "holds it",
                             j.name, way, t)});
    }
    if (stop) out.trajectory.stops.push_back(t);
    // Held whole: the span an engine's creep is measured over (creep_note).
    if (eom.resting() && !out.held) {
      out.trajectory.held.emplace_back(t, times.back());
      out.held = true;
    } else if (!eom.resting() && out.held) {
      out.trajectory.held.back().second = t;
      out.held = false;
    }
  };
  double t = 0.0;
  choose(t, x, {});
  observe(x, times[0]);
  for (size_t k = 1; k < times.size(); ++k) {
    const double end = times[k];
    while (t < end) {
      const auto outcome = steps.step(
          eom, x, t, end, [&](double at, const State& y) { return eom.phase_ended(at, y) < 0; });
      // Others that ended at the same instant are found by choose_phases (a rate at rest, a
      // held joint beyond its limit).
      if (outcome == PhaseStepper<Stepper, State>::Outcome::phase_ended)
        choose(t, x, {eom.phase_ended(t, x)});
    }
    t = end;
    observe(x, end);
  }
}

// Integrates `Equations` (EquationOfMotion or SeveralEquations) from `initial` at `times` into
// `out`, its trajectory sized and timed.
template <class Equations>
void integrate(const Mechanism& mechanism, const SimulationOptions& options,
               const std::vector<double>& times, double interval, Simulation& out,
               const typename Equations::State& initial) {
  Trajectory& t = out.trajectory;
  const int n = t.samples();
  std::optional<Equations> started;
  std::optional<SampleWriter<Equations>> writer;
  try {
    Equations& eom = started.emplace(mechanism, options.max_solves);
    SampleWriter<Equations>& observe = writer.emplace(eom, out);
    typename Equations::State x = initial;
    const bool phased = eom.friction();  // joint friction: in phases of sliding and rest
    namespace odeint = boost::numeric::odeint;
    const double tol = options.tolerance;
    // Every trial step evaluates poses along it: the first is small (the controller grows it by
    // up to 5 times a step) and none is longer than an interval, so no trial reaches far past
    // the motion (a first trial of 10 s put A02's crank 986 rad away).
    const double first = std::min(interval, kFirstStep);
    if (phased && options.integrator == "dopri5") {
      if constexpr (std::is_same_v<Equations, EquationOfMotion>)
        integrate_phases<odeint::runge_kutta_dopri5<typename Equations::State>>(
            mechanism, options, times, interval, eom, observe, out, x);
      else
        integrate_modes<odeint::runge_kutta_dopri5<typename Equations::State>>(
            mechanism, options, times, interval, eom, observe, out, x);
    } else if (phased && options.integrator == "rkf78") {
      if constexpr (std::is_same_v<Equations, EquationOfMotion>)
        integrate_phases<odeint::runge_kutta_fehlberg78<typename Equations::State>>(
            mechanism, options, times, interval, eom, observe, out, x);
      else
        integrate_modes<odeint::runge_kutta_fehlberg78<typename Equations::State>>(
            mechanism, options, times, interval, eom, observe, out, x);
    } else if (options.integrator == "dopri5") {
      odeint::integrate_times(
          odeint::make_dense_output(tol, tol,
                                    odeint::runge_kutta_dopri5<typename Equations::State>()),
          std::ref(eom), x, times.begin(), times.end(), first, std::ref(observe));
    } else if (options.integrator == "rkf78") {
      odeint::integrate_times(
          odeint::make_controlled(tol, tol,
                                  odeint::runge_kutta_fehlberg78<typename Equations::State>()),
          std::ref(eom), x, times.begin(), times.end(), first, std::ref(observe));
    } else {
      throw std::invalid_argument("unknown integrator '" + options.integrator +
                                  "' (valid: dopri5, rkf78)");
    }
  } catch (const Stopped& stop) {
    const int written = writer ? writer->written() : 0;
    // No state at all: the case cannot start, bad input at its [dynamics] table, not a result.
    if (written == 0) throw DefinitionError({Diagnostic{mechanism.dynamics->where, stop.message}});
    out.ok = false;
    out.over_budget = stop.over_budget;
    out.message = fmt::format("stopped at t = {:.9g} s: {}", stop.time, stop.message);
    t.events.push_back({stop.time, stop.status, out.message});
    for (int k = written; k < n; ++k) t.status[static_cast<size_t>(k)] = PoseStatus::not_reached;
  }
  if (started) {
    out.evaluations = started->evaluations();
    out.solves = started->solves();
  }
}

}  // namespace

double Simulation::energy_error(int k) const {
  return std::abs(energy_balance(k)) / std::max(energy_scale, 1e-300);
}

std::string singular_start(const Mechanism& m, double rcond) {
  if (rcond >= kSingularStartRcond) return "";
  if (m.axis().timed()) {
    std::string starts;
    for (const Driver& d : m.drivers)
      starts += fmt::format("{} = {}, ", d.name, driver_unit_of(d, m.units).text(d.start, 9));
    return fmt::format(
        "the start, {}is a singular position of the coordinates (rcond {:.1e}): there the "
        "other coordinates' rates are not determined by the drivers' rates, so no initial "
        "velocity is consistent with it; start the [[driver]]s away from it",
        starts, rcond);
  }
  return fmt::format(
      "the start, {}, is a singular position of the coordinate (rcond {:.1e}): there the other "
      "coordinates' rates are not determined by its rate, so no initial velocity is consistent "
      "with it; start the [driver] away from it",
      start_text(m, 9), rcond);
}

Simulation simulate(const Mechanism& mechanism, const SimulationOptions& options) {
  if (!mechanism.dynamics)
    throw std::invalid_argument(mechanism.file + ": not a dynamics case (no [dynamics] table)");
  const DynamicsCase& c = *mechanism.dynamics;
  const double duration = options.duration > 0.0 ? options.duration : c.duration;
  const double interval = options.interval > 0.0 ? options.interval : c.interval;
  // Samples are stored: a duration far beyond its interval is refused, not attempted.
  constexpr double kMostSamples = 1e6;
  if (!(duration / interval < kMostSamples))
    throw std::invalid_argument(fmt::format(
        "{}: [dynamics] duration / interval = {:g} samples, more than {:g}: lengthen 'interval'",
        mechanism.file, duration / interval, kMostSamples));
  const int n = static_cast<int>(std::floor(duration / interval + 1e-9)) + 1;
  std::vector<double> times(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) times[static_cast<size_t>(k)] = k * interval;

  Simulation out;
  Trajectory& t = out.trajectory;
  t.method = "exact dynamics (" + options.integrator + ")";
  t.resize(mechanism, n, true);
  t.drop_jerk();  // the integrator's state has no third derivative
  for (int k = 0; k < n; ++k) t.time(k) = times[static_cast<size_t>(k)];
  out.kinetic.setZero(n);
  out.potential.setZero(n);
  out.work.setZero(n);

  if (mechanism.axis().timed())
    integrate<SeveralEquations>(mechanism, options, times, interval, out,
                                SeveralEquations::start(mechanism));
  else
    integrate<EquationOfMotion>(mechanism, options, times, interval, out,
                                {mechanism.swept().start, c.rate, 0.0});
  return out;
}

}  // namespace crosslink
