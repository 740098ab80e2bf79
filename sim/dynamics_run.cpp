#include "sim/dynamics_run.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "analytic/kinematics/newton.h"
#include "sim/kinematic_run.h"
#include "sim/statuses.h"

namespace crosslink::sim {

DynamicsPlan plan_dynamics(const Mechanism& definition, const Mechanism& scene_mechanism,
                           const Trajectory& reference, double wanted, InnerTimes inner,
                           long max_steps, bool perturbed) {
  DynamicsPlan p;
  const std::vector<double> per_interval = planned_steps(reference, p.span, wanted, 1.0, max_steps);
  p.grid = sample_grid(reference, p.span, per_interval, inner);
  // Steps past the last sample for its difference stencil, and at least to pose 4 for the
  // start's one-sided one (dynamics_stencil), which the work of the loads needs whichever way a
  // sample is read: in a run of two sample intervals at one step each the start's stencil was
  // never complete, and Simbody's three samples were all flagged diverged in a run it called ok.
  std::vector<double>& time = p.grid.time;
  const double h = time.back() - time[time.size() - 2];  // the last interval's step
  do time.push_back(time.back() + h);
  while (time.size() < 5);

  const int first = p.span.first;
  p.start = reference_state(definition, reference, first);
  if (!perturbed) return p;
  DynamicsLoads balance(definition);
  KinematicState state(scene_mechanism);
  state.q = p.start.q;
  for (int d = 0; d < state.driver_count(); ++d)
    state.drivers[static_cast<size_t>(d)] = {reference.time(first),
                                             reference.driver_values(first, d),
                                             balance.rate(p.start.q, p.start.qdot, d), 0.0};
  const NewtonSolver solver(scene_mechanism);
  const SolveReport report = solver.solve(state);
  if (report.status != PoseStatus::ok)
    throw std::runtime_error("the perturbed chain does not close at the first sample: " +
                             report.message);
  p.start.q = state.q;
  p.start.qdot = state.qdot;
  return p;
}

namespace {

constexpr long kRing = 16;  // steps a stencil reaches back, at most, with room to spare

// What each sample is read from, fixed before the first step: the poses of its differences, the
// poses whose forces it combines, and so the step after which it can be written.
struct DynamicsSamples {
  std::vector<std::vector<long>> stencil;  // per sample (step -1: the pose before the start)
  std::vector<ForceStencil> forces;        // per sample; empty without forces
  std::vector<bool> read_forces;           // per step: whether the step leaving it reads forces
  std::vector<long> complete_at;           // per sample
};

// Pose k's difference stencil: central, but at the start one-sided over poses 1 to 4 when there
// is no pose before it (the start lacks the residual every later step has).
std::vector<long> dynamics_stencil(long k, bool before_start) {
  if (k >= 1 || before_start) return {k - 1, k, k + 1};
  return {1, 2, 3, 4};
}

DynamicsSamples plan_dynamics_samples(const Trajectory& reference, const DynamicsPlan& plan,
                                      bool before_start, bool read_forces) {
  const std::vector<double>& time = plan.grid.time;
  const long last_step = static_cast<long>(time.size()) - 1;
  DynamicsSamples out;
  const auto samples = static_cast<size_t>(reference.samples());
  out.stencil.resize(samples);
  out.forces.resize(samples);
  out.complete_at.assign(samples, -1);
  out.read_forces.assign(static_cast<size_t>(last_step + 1), false);
  for (int i = plan.span.first; i <= plan.span.last; ++i) {
    const auto row = static_cast<size_t>(i);
    const long S = plan.grid.sample_step[row];
    out.stencil[row] = dynamics_stencil(S, before_start);
    long at = out.stencil[row].back();
    if (read_forces) {
      out.forces[row] = before_start ? ForceStencil{{S}, {1.0}}
                                     : force_stencil(reference.time(i), last_step, time);
      for (long k : out.forces[row].steps) {
        out.read_forces[static_cast<size_t>(k)] = true;
        at = std::max(at, k + 1);
      }
    }
    out.complete_at[row] = at;
  }
  return out;
}

// The steps of a dynamics run and what they leave: the last poses, force readings, the power of
// the loads at each pose and the work done up to it, and the joint gap of each sample interval.
class DynamicsSteps {
 public:
  DynamicsSteps(const Mechanism& definition, const Mechanism& scene_mechanism,
                const DynamicsPlan& plan, const DynamicsWatch& watch,
                const DynamicsSamples& samples, int sample_count, DynamicsScene& scene,
                const Eigen::VectorXd* before)
      : plan_(plan),
        watch_(watch),
        samples_(samples),
        scene_(scene),
        time_(plan.grid.time),
        gaps_(scene_mechanism, plan.grid, plan.span, sample_count),
        balance_(definition),
        velocity_(definition.coordinate_count()) {
    readings_.fill(ForceReading(definition.joints.size(), definition.drivers.size()));
    scene_.read_pose(pose_at(0));
    h0_ = time_[1] - time_[0];
    before_start_ = before != nullptr;
    if (before) before_ = *before;
    if (!scene_.evaluates_loads() && balance_.any()) start_velocity_ = scene_.start_velocity();
  }

  // The step to pose k; "" or why the run stops there.
  std::string step(long k) {
    const double t0 = time_[static_cast<size_t>(k - 1)];
    const double h = time_[static_cast<size_t>(k)] - t0;
    if (!scene_.evaluates_loads() && balance_.any()) {
      velocity_ = k == 1 ? start_velocity_
                         : Eigen::VectorXd((pose(k - 1) - pose(k - 2)) /
                                           (t0 - time_[static_cast<size_t>(k - 2)]));
      scene_.apply(balance_.at(t0, pose(k - 1), velocity_));
    }
    const bool read = samples_.read_forces[static_cast<size_t>(k - 1)];
    std::string alarm = scene_.step(t0, h, read ? &reading_at(k - 1) : nullptr);
    ++taken_;
    dissipated_[static_cast<size_t>(k % kRing)] =
        dissipated_[static_cast<size_t>((k - 1) % kRing)] + scene_.friction_work();
    scene_.read_pose(pose_at(k));
    const double gap = gaps_.at(k, pose(k));
    if (!pose(k).allFinite()) alarm = "NaN in the state";
    if (alarm.empty() && !(gap <= watch_.divergence_gap))
      alarm = fmt::format("loop gap {:.3g} m beyond the divergence limit {:.3g} m", gap,
                          watch_.divergence_gap);
    if (!alarm.empty())
      return fmt::format("diverged at t = {:.6g} s: {}", time_[static_cast<size_t>(k)], alarm);
    integrate_work(k);
    return "";
  }

  // Pose k (k = -1: the pose before the start).
  const Eigen::VectorXd& pose(long k) const {
    return k < 0 ? before_ : ring_[static_cast<size_t>(k % kRing)];
  }
  // The time of pose k.
  double time(long k) const { return k < 0 ? time_[0] - h0_ : time_[static_cast<size_t>(k)]; }
  // Velocity and acceleration at pose k from its difference stencil.
  void derivatives(long k, Eigen::VectorXd& qdot, Eigen::VectorXd* qddot) const {
    const std::vector<long> nodes = dynamics_stencil(k, before_start_);
    std::vector<double> offsets;
    for (long n : nodes) offsets.push_back(time(n) - time(k));
    const auto w = stencil_weights(0.0, offsets);
    qdot.setZero();
    if (qddot) qddot->setZero();
    for (size_t n = 0; n < nodes.size(); ++n) {
      qdot += w[1][n] * pose(nodes[n]);
      if (qddot) *qddot += w[2][n] * pose(nodes[n]);
    }
  }
  const ForceReading& reading(long k) const { return readings_[static_cast<size_t>(k % kRing)]; }
  // The work of the loads and of the engine's joint friction up to pose k, when it is known yet.
  bool work_known(long k) const { return !balance_.any() || k <= work_to_; }
  double work(long k) const {
    return (balance_.any() ? work_[static_cast<size_t>(k % kRing)] : 0.0) +
           dissipated_[static_cast<size_t>(k % kRing)];
  }
  const Eigen::VectorXd& gaps() const { return gaps_.gaps(); }
  long taken() const { return taken_; }
  DynamicsLoads& balance() { return balance_; }

 private:
  Eigen::VectorXd& pose_at(long k) { return ring_[static_cast<size_t>(k % kRing)]; }
  ForceReading& reading_at(long k) { return readings_[static_cast<size_t>(k % kRing)]; }

  // The power of the loads at every pose whose stencil step k completes, and the work up to it by
  // the trapezoid rule.
  void integrate_work(long k) {
    if (!balance_.any()) return;
    for (long n = work_to_ + 1; dynamics_stencil(n, before_start_).back() <= k; ++n) {
      derivatives(n, velocity_, nullptr);
      const double power = balance_.power(time(n), pose(n), velocity_);
      double& work = work_[static_cast<size_t>(n % kRing)];
      work = n == 0 ? 0.0
                    : work_[static_cast<size_t>((n - 1) % kRing)] +
                          0.5 * (time(n) - time(n - 1)) * (power_ + power);
      power_ = power;
      work_to_ = n;
    }
  }

  const DynamicsPlan& plan_;
  const DynamicsWatch& watch_;
  const DynamicsSamples& samples_;
  DynamicsScene& scene_;
  const std::vector<double>& time_;
  IntervalGaps gaps_;
  DynamicsLoads balance_;
  Eigen::VectorXd velocity_, start_velocity_, before_;
  std::array<Eigen::VectorXd, kRing> ring_;
  std::array<ForceReading, kRing> readings_;
  std::array<double, kRing> work_{};
  std::array<double, kRing> dissipated_{};  // the friction's work up to each pose
  double h0_ = 0.0, power_ = 0.0;
  bool before_start_ = false;
  long work_to_ = -1;  // the last pose whose work is known
  long taken_ = 0;
};

// Sample i on step S: its pose, its rates from the differences of the poses around it (or the
// engine's state there), its forces with the applied effort, and its energy balance; "" or why
// the run stops there (the balance beyond divergence_energy).
class DynamicsSampler {
 public:
  DynamicsSampler(const Mechanism& m, const Trajectory& reference, const DynamicsPlan& plan,
                  const DynamicsWatch& watch, bool with_forces, DynamicsSteps& steps)
      : m_(m),
        watch_(watch),
        with_forces_(with_forces),
        steps_(steps),
        rows_(m, reference.samples(), with_forces) {
    DynamicsLoads& balance = steps.balance();
    initial_energy_ =
        balance.kinetic(plan.start.q, plan.start.qdot) + balance.potential(plan.start.q);
  }

  std::string write(int i, long S, const DynamicsSamples& plan, DynamicsScene& scene,
                    Trajectory& out) {
    const double t = steps_.time(S);
    DynamicsLoads& balance = steps_.balance();
    KinematicState& state = rows_.state();
    ForceReading& forces = rows_.forces();
    state.q = steps_.pose(S);
    const bool own = scene.reads_state() || (S == 0 && scene.reads_start_state());
    if (own)
      scene.read_state(S, t, state.qdot, state.qddot, forces);
    else
      steps_.derivatives(S, state.qdot, &state.qddot);
    balance.measure(t, state.q, state.qdot, state);
    if (with_forces_ && !own)
      combine_readings(
          plan.forces[static_cast<size_t>(i)],
          [&](long k) -> const ForceReading& { return steps_.reading(k); }, forces);
    for (int d = 0; d < m_.dynamics->coordinate_count(); ++d)
      forces.effort_of(d) = m_.dynamics->coordinate(d).effort_at(t);
    rows_.write(i, out);
    for (size_t d = 0; d < state.drivers.size(); ++d)  // the engine's own coordinates
      out.driver_values(i, static_cast<Eigen::Index>(d)) = state.drivers[d].value;
    const double kinetic = balance.kinetic(state.q, state.qdot);
    const double potential = balance.potential(state.q);
    const double work = steps_.work(S);
    const double error = kinetic + potential - work - initial_energy_;
    out.energy.row(i) << kinetic, potential, work, error;
    const double scale = watch_.energy_scale;
    if (drift_at_ < 0 && std::abs(error) > watch_.energy_threshold * scale) drift_at_ = i;
    if (std::abs(error) <= watch_.divergence_energy * scale) return "";
    return fmt::format(
        "diverged at t = {:.6g} s: the energy balance is off by {:.3g} J, {:.3g} times the "
        "energy the exact motion moves ({:.3g} J)",
        t, error, std::abs(error) / scale, scale);
  }
  const SampleRows& rows() const { return rows_; }
  int drift_at() const { return drift_at_; }

 private:
  const Mechanism& m_;
  const DynamicsWatch& watch_;
  bool with_forces_;
  DynamicsSteps& steps_;
  SampleRows rows_;
  double initial_energy_ = 0.0;
  int drift_at_ = -1;
};

// Statuses: the shared judge over each sample's gap and the conditioning of the definition's
// constraints at the engine's configuration (no branch check: the motion is the engine's own).
StatusJudge judge_dynamics(const Mechanism& m, const Trajectory& reference, const Span& span,
                           const DynamicsWatch& watch, const DynamicsSampler& sampled,
                           const Eigen::VectorXd& gaps, Trajectory& out) {
  StatusJudge judge(reference, span, {watch.gap, watch.singular_rcond, 0.0}, false);
  judge_projected(
      judge, m, reference, sampled.rows(), gaps,
      [&](int i, KinematicState& probe) {
        for (int d = 0; d < probe.driver_count(); ++d)
          probe.drivers[static_cast<size_t>(d)] = {0.0, out.driver_values(i, d), 0.0, 0.0};
      },
      [&](int i, const SolveReport& projected, const KinematicState&) {
        return judge.judge(i, gaps(i), projected.rcond, nullptr, out);
      },
      out);
  return judge;
}

}  // namespace

void run_dynamics(const Mechanism& definition, const Mechanism& scene_mechanism,
                  const Trajectory& reference, const DynamicsPlan& plan, const DynamicsWatch& watch,
                  bool with_forces, DynamicsScene& scene, Clock::time_point begin, EngineRun& run) {
  Trajectory& out = run.trajectory;
  out.resize_as(definition, reference, with_forces, true);
  const std::vector<double>& time = plan.grid.time;
  const long last_step = static_cast<long>(time.size()) - 1;

  Eigen::VectorXd before;
  const bool before_start = scene.pose_before_start(time[1] - time[0], before);
  const DynamicsSamples samples =
      plan_dynamics_samples(reference, plan, before_start, with_forces && !scene.reads_state());
  DynamicsSteps steps(definition, scene_mechanism, plan, watch, samples, reference.samples(), scene,
                      before_start ? &before : nullptr);
  DynamicsSampler sampled(definition, reference, plan, watch, with_forces, steps);

  // Every sample is written as soon as its stencils and its work are complete.
  SteppingClock stepping;
  std::string stop;
  int pending = plan.span.first;
  for (long k = 1; k <= last_step && stop.empty(); ++k) {
    if (stop = steps.step(k); !stop.empty()) break;
    for (; pending <= plan.span.last && stop.empty(); ++pending) {
      const auto row = static_cast<size_t>(pending);
      const long S = plan.grid.sample_step[row];
      if (samples.complete_at[row] > k || !steps.work_known(S)) break;
      stop = sampled.write(pending, S, samples, scene, out);
    }
  }
  stepping.stop();

  const StatusJudge judge =
      judge_dynamics(definition, reference, plan.span, watch, sampled, steps.gaps(), out);
  if (!stop.empty()) {
    run.ok = false;
    add_note(run.message, stop);
    const int lost = judge.first_lost();
    out.events.push_back(
        {lost >= 0 ? event_position(reference, lost) : 0.0, PoseStatus::diverged, stop});
  } else if (const int lost = judge.first_lost(); lost >= 0) {
    // Ended cleanly short of a sample's stencil (plan_dynamics extends the grid so none is):
    // flagged with why, never silently.
    const std::string text = fmt::format(
        "samples from t = {:.6g} s not reached: the run's {} steps end before their difference "
        "stencils",
        reference.time(lost), last_step);
    add_note(run.message, text);
    out.events.push_back({event_position(reference, lost), PoseStatus::diverged, text});
  }
  if (const int drift_at = sampled.drift_at(); drift_at >= 0) {
    const std::string text =
        energy_drift_note(watch.energy_threshold, watch.energy_scale, reference, drift_at,
                          out.energy.col(3).cwiseAbs().maxCoeff());
    add_note(run.message, text);
    out.events.push_back({event_position(reference, drift_at), PoseStatus::ok, text});
  }
  add_note(run.message, dynamics_span_note(reference, plan.span));
  add_note(run.message, creep_note(definition, reference, out));
  add_note(run.message, kept_note(judge.kept(), false));
  add_note(run.message, dynamics_singular_note(judge.singular(), judge.singular_limit()));
  note_loop_gaps(judge.loop_gaps(), steps.gaps(), watch.gap, reference, run, definition);
  add_note(run.message, scene.note());
  record_cost(steps.taken(), scene.evaluations(),
              time[static_cast<size_t>(steps.taken())] - time.front(), 1.0, stepping, begin,
              run.cost);
  run.cost.time_step = plan.grid.dt;
}

}  // namespace crosslink::sim
