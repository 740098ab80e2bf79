#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "analytic/kinematics/driver_chains.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/sweep_samples.h"

namespace crosslink::sweeping {
namespace {

// Several drivers: the sweep in time (docs/mechanism-format.md, "Several drivers"), each driver
// at its law's value at t over [0, cycle_period()] in 360 equal intervals. From the assembled
// pose the state follows the drivers by predictor-corrector in time: the predictor is the
// Taylor step q + qdot h + qddot h^2 / 2 with the rates at the last pose, the corrector Newton,
// and a step is taken only when Newton's correction is small against the predicted move (as the
// Follower's), so the chain never changes branch silently: a step that cannot be taken however
// short stops the branch there (an event), and the later samples are flagged. Where the
// Jacobian's determinant changes sign between two poses the path crossed a singular position:
// it is located by bisection in t (an event) and the nearest sample is flagged singular: a
// direct singularity (analytic/kinematics/driver_chains.h). Where the determinant of a driver's
// chain's block changes sign the chain passed a toggle: an inverse singularity, located the same
// way (J stays regular there: the samples keep their rates). Events are located in time.
class TimedFollower {
 public:
  // A located singular position: its time, which determinant changed sign (-1: J's, the direct
  // singularity; else the chain's index), and the conditioning at the located pose.
  struct Crossing {
    double time = 0.0;
    int chain = -1;
    DriverChains::Conditioning conditioning;
  };

  TimedFollower(const NewtonSolver& solver, KinematicState& state)
      : solver_(solver),
        m_(solver.mechanism()),
        state_(state),
        q0_(state.q.size()),
        predicted_(state.q.size()),
        chains_(solver.mechanism(), solver.layout()),
        jac_(solver.layout().rows(), state.q.size()) {}

  const DriverChains& chains() const { return chains_; }

  // Moves the solved state (J factorised, rates solved) from its time to `target` in steps of
  // at most `max_step`. Singular positions crossed on the way are added to `crossings`. On
  // failure the state is left at the last time reached and the report says why.
  SolveReport advance_to(double target, double max_step, double min_step, SolveReport last,
                         std::vector<Crossing>& crossings) {
    double h = max_step;
    if (chain_signs_.empty()) update_chain_signs();
    while (state_.time() < target) {
      const double t0 = state_.time();
      // The last step lands on the target exactly.
      const double t1 = target - t0 <= h ? target : t0 + h;
      h = t1 - t0;
      solver_.solve_velocity(state_);
      solver_.solve_acceleration(state_);
      const bool rates =
          last.status == PoseStatus::ok && state_.qdot.allFinite() && state_.qddot.allFinite();
      const double sign0 = sign_of(state_.lu.determinant());
      q0_ = state_.q;
      predicted_ = q0_;
      if (rates) predicted_ += h * state_.qdot + (0.5 * h * h) * state_.qddot;
      state_.q = predicted_;
      state_.drive_at(m_, t1);
      SolveReport report = solver_.solve_position(state_);
      const bool converged =
          report.status == PoseStatus::ok || report.status == PoseStatus::singular;
      const double move = solver_.size_free_norm(predicted_ - q0_);
      const bool small = rates ? solver_.size_free_norm(state_.q - predicted_) <= 0.1 * move + 1e-10
                               : solver_.size_free_norm(state_.q - q0_) <= 4.0 * std::sqrt(h);
      if (converged && small) {
        const Eigen::VectorXd qdot0 = state_.qdot;  // the rates at t0 (locate moves them on)
        const auto full_sign = [this] { return sign_of(state_.lu.determinant()); };
        if (full_sign() != sign0 && sign0 != 0.0)
          crossings.push_back(locate(t0, t1, sign0, rates, qdot0, -1, full_sign));
        const std::vector<double> before = chain_signs_;
        update_chain_signs();
        for (size_t c = 0; c < before.size(); ++c)
          if (before[c] != 0.0 && chain_signs_[c] != before[c]) {
            const int chain = static_cast<int>(c);
            crossings.push_back(locate(t0, t1, before[c], rates, qdot0, chain,
                                       [this, chain] { return chain_sign(chain); }));
          }
        last = report;
        h = std::min(2.0 * h, max_step);
        continue;
      }
      state_.q = q0_;
      state_.drive_at(m_, t0);
      last = solver_.solve_position(state_);
      h *= 0.5;
      if (h < min_step) {
        // Newton may still converge on the near side of a fold: a fold has no solution at all
        // a little beyond it, another branch has.
        const bool jump = converged && solvable_at(t0 + 1e6 * min_step);
        report.status = jump ? PoseStatus::branch_jump : PoseStatus::cannot_assemble;
        report.message = jump ? fmt::format(
                                    "at t = {:.12g} s{} the only nearby solution is on another "
                                    "branch",
                                    t0, drivers_text())
                              : fmt::format("the chain does not close beyond t = {:.12g} s{}", t0,
                                            drivers_text());
        return report;
      }
    }
    return last;
  }

  // " (angle.a = ..., s.b = ...)": every driver's value at the state, in SI.
  std::string drivers_text() const {
    std::string text;
    for (int d = 0; d < state_.driver_count(); ++d) {
      const Driver& driver = m_.drivers[static_cast<size_t>(d)];
      text += fmt::format("{}{}.{} = {:.9g}", text.empty() ? " (" : ", ",
                          driver.angular() ? "angle" : "s", driver.name,
                          state_.drivers[static_cast<size_t>(d)].value);
    }
    return text.empty() ? text : text + ")";
  }

 private:
  // Whether Newton from the current pose closes the chain at time t; the state is restored.
  bool solvable_at(double t) {
    q0_ = state_.q;
    const double t0 = state_.time();
    state_.drive_at(m_, t);
    const PoseStatus s = solver_.solve_position(state_).status;
    state_.q = q0_;
    state_.drive_at(m_, t0);
    solver_.solve_position(state_);
    return s == PoseStatus::ok || s == PoseStatus::singular;
  }

  // Driver chain c's determinant's sign at the state's pose.
  double chain_sign(int c) {
    solver_.jacobian(state_.q, jac_);
    return chains_.sign(c, jac_);
  }
  void update_chain_signs() {
    solver_.jacobian(state_.q, jac_);
    chain_signs_.resize(chains_.chains().size());
    for (size_t c = 0; c < chain_signs_.size(); ++c)
      chain_signs_[c] = chains_.sign(static_cast<int>(c), jac_);
  }

  // The time in (a, b) where `sign()` (det J's, or a chain's block's, at the state) changes from
  // `sign_a`, by bisection (each trial solved by Newton from the poses at a and b and their
  // rates, interpolated by a cubic, or without rates at a by the chord); the state is put back at
  // b. Near a direct singularity two assemblies lie close and Newton takes the one nearer its
  // guess, so the guess's error places the crossing: a chord's (the poses alone) placed it
  // 3.3e-8 s off on the 3-RRR's turning path, the cubic's error is fourth order.
  template <class Sign>
  Crossing locate(double a, double b, double sign_a, bool rates_at_a, const Eigen::VectorXd& qdot_a,
                  int chain, const Sign& sign) {
    const Eigen::VectorXd q_b = state_.q, q_a = q0_;
    Eigen::VectorXd q_located = q_b;
    solver_.solve_velocity(state_);
    const Eigen::VectorXd qdot_b = state_.qdot;
    const bool rates = rates_at_a && qdot_a.allFinite() && qdot_b.allFinite();
    const double h = b - a;
    double lo = a, hi = b;
    for (int it = 0; it < 60 && hi - lo > 1e-13 * std::max(1.0, std::abs(hi)); ++it) {
      const double mid = 0.5 * (lo + hi);
      const double s = (mid - a) / h;
      if (rates)  // cubic Hermite through (q_a, qdot_a) and (q_b, qdot_b)
        state_.q = (2 * s * s * s - 3 * s * s + 1) * q_a +
                   (s * s * s - 2 * s * s + s) * h * qdot_a + (3 * s * s - 2 * s * s * s) * q_b +
                   (s * s * s - s * s) * h * qdot_b;
      else
        state_.q = q_a + s * (q_b - q_a);
      state_.drive_at(m_, mid);
      const SolveReport r = solver_.solve_position(state_);
      if (r.status != PoseStatus::ok && r.status != PoseStatus::singular) break;
      q_located = state_.q;
      if (sign() == sign_a)
        lo = mid;
      else
        hi = mid;
    }
    Crossing out{0.5 * (lo + hi), chain, {}};
    // The blocks' conditioning at the last trial, the pose nearest the located time.
    solver_.jacobian(q_located, jac_);
    out.conditioning = chains_.conditioning(jac_);
    state_.q = q_b;
    state_.drive_at(m_, b);
    solver_.solve_position(state_);
    return out;
  }

  const NewtonSolver& solver_;
  const Mechanism& m_;
  KinematicState& state_;
  Eigen::VectorXd q0_, predicted_;
  DriverChains chains_;
  Eigen::MatrixXd jac_;              // the full Jacobian (dense) at a pose
  std::vector<double> chain_signs_;  // each chain's determinant's sign at the state's pose
};

// A crossed singular position's event, classified (analytic/kinematics/driver_chains.h): direct
// where J's determinant changed sign, inverse where a driver's chain's did; the other blocks'
// conditioning at the located pose says whether the other kind coincides with it there.
Trajectory::Event singular_event(const Mechanism& m, const DriverChains& chains,
                                 const TimedFollower::Crossing& c) {
  // A block this near singular at the located pose is singular there too: a located block's own
  // conditioning is of the order of the located time's error (1e-9 s), a regular block's of
  // order 0.01 to 1.
  constexpr double kSingular = 1e-6;
  const std::string output = chains.output().empty() ? "" : " (" + chains.output() + ")";
  std::string also;
  for (size_t k = 0; k < c.conditioning.chain.size(); ++k)
    if (static_cast<int>(k) != c.chain && c.conditioning.chain[k] < kSingular)
      also += fmt::format("; driver {}'s chain is at a toggle too (an inverse singularity)",
                          m.drivers[k].name);
  if (c.chain < 0)
    return {c.time, PoseStatus::singular,
            fmt::format("direct singularity: the Jacobian changes sign, the drivers no longer "
                        "determine the output{}, which gains a freedom{}",
                        output, also),
            ParallelSingularity::direct, std::string()};
  const std::string& name = m.drivers[static_cast<size_t>(c.chain)].name;
  if (c.conditioning.full < kSingular)
    also += "; the Jacobian is singular too (a direct singularity)";
  return {c.time, PoseStatus::singular,
          fmt::format("inverse singularity: driver {}'s chain ({}) at a toggle, the output{} "
                      "loses a direction{}",
                      name, chains.links_text(c.chain), output, also),
          ParallelSingularity::inverse, name};
}

}  // namespace

Trajectory timed_sweep(const NewtonSolver& solver, KinematicState& state,
                       const SolveReport& assembled, const std::vector<double>& times) {
  const Mechanism& m = solver.mechanism();
  Trajectory out;
  out.method = "newton";
  out.resize(m, static_cast<int>(times.size()), true);
  Recorder record(solver);
  TimedFollower follower(solver, state);
  SolveReport failure = assembled;
  bool lost = assembled.status != PoseStatus::ok && assembled.status != PoseStatus::singular;
  if (lost) out.events.push_back({0.0, assembled.status, assembled.message});
  SolveReport last = assembled;
  std::vector<TimedFollower::Crossing> crossings;
  double before = 0.0;  // the time of the last sample
  for (size_t sample = 0; sample < times.size(); ++sample) {
    const int i = static_cast<int>(sample);
    const double t = times[sample];
    if (!lost && t > before) {
      // Substeps: no driver moves more than a continuation step (1 degree, or a slider's
      // arc of the mechanism's size over 1 degree) between two solves.
      last = follower.advance_to(t, (t - before) / timed_substeps(m, before, t), 1e-12 * t, last,
                                 crossings);
      if (last.status != PoseStatus::ok && last.status != PoseStatus::singular) {
        lost = true;
        failure = last;
        out.events.push_back({state.time(), last.status, last.message});
      }
    }
    before = t;
    if (!lost) {
      state.drive_at(m, t);
      last = solver.polish(state, last);
      if (last.status == PoseStatus::singular)
        out.events.push_back(
            {t, last.status, fmt::format("{}{}", last.message, follower.drivers_text())});
      record(state, last, out, i);
      continue;
    }
    KinematicState flagged = without_pose(state);
    flagged.drive_at(m, t);
    solver.write_sample(flagged, failure, out, i);
  }
  drop_rates_beside_singular(out);
  // A crossed singular position: an event; a direct one also flags the sample nearest it.
  for (const TimedFollower::Crossing& c : crossings) {
    const double at = c.time;
    out.events.push_back(singular_event(m, follower.chains(), c));
    if (c.chain >= 0) continue;  // J is regular at an inverse singularity: the rates exist
    const auto nearest = std::min_element(times.begin(), times.end(), [&](double a, double b) {
      return std::abs(a - at) < std::abs(b - at);
    });
    const int k = static_cast<int>(nearest - times.begin());
    if (has_position(out.status[static_cast<size_t>(k)])) drop_rates(out, k);
  }
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const auto& a, const auto& b) { return a.driver < b.driver; });
  return out;
}

}  // namespace crosslink::sweeping
