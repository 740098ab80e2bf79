#include "sim/kinematic_run.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "analytic/model/units_text.h"
#include "analytic/reference/trust.h"
#include "sim/statuses.h"

namespace crosslink::sim {

double fastest_rate(const Trajectory& reference, const Span& span) {
  double fastest = 0.0;
  if (reference.omega.cols() == 0) return fastest;
  for (int i = span.first; i <= span.last; ++i)
    if (usable(reference.status[static_cast<size_t>(i)]))
      fastest = std::max(fastest, reference.omega.row(i).cwiseAbs().maxCoeff());
  return fastest;
}

double step_length(const Trajectory& reference, const Span& span, double dt, double max_step_angle,
                   int steps_per_sample) {
  if (dt != 0.0) return dt;
  double wanted = std::numeric_limits<double>::infinity();
  if (steps_per_sample > 0) {
    double longest = 0.0;
    for (int i = span.first + 1; i <= span.last; ++i)
      longest = std::max(longest, reference.time(i) - reference.time(i - 1));
    wanted = longest / steps_per_sample;
  }
  const double fastest = fastest_rate(reference, span);
  if (max_step_angle > 0.0 && fastest > 0.0) wanted = std::min(wanted, max_step_angle / fastest);
  return std::isinf(wanted) ? reference.time(span.first + 1) - reference.time(span.first) : wanted;
}

DriveTarget DriveTarget::of(const Mechanism& m, const KinematicPlan& plan, size_t d,
                            double coordinate0, double sign) {
  DriveTarget out;
  out.coordinate0 = coordinate0;
  out.driver_offset = plan.driver_offset[d];
  out.driver0 = m.drivers[d].at_time(plan.grid.time.front()).value + out.driver_offset;
  out.sign = sign;
  return out;
}

KinematicPlan plan_kinematic(const Mechanism& scene_mechanism, const Trajectory& reference,
                             double wanted, InnerTimes inner, long preroll, long max_steps,
                             double singular_rcond, bool perturbed) {
  const int n = reference.samples();
  KinematicPlan p;
  const std::vector<double> per_interval =
      planned_steps(reference, p.span, wanted, 2.0 * static_cast<double>(preroll), max_steps);
  const int first = p.span.first;
  const double t0 = reference.time(first);
  const double h = (reference.time(first + 1) - t0) / per_interval.front();
  const std::vector<Driver>& drivers = scene_mechanism.drivers;
  const double period = scene_mechanism.cycle_period();
  const bool periodic =
      first == 0 && p.span.last == n - 1 && period > 0.0 &&
      reference.time(n - 1) - t0 + (reference.time(1) - t0) >= period * (1.0 - 1e-9);

  // The exact state `roll` steps before the first sample, where the chain closes well
  // conditioned.
  const NewtonSolver solver(scene_mechanism);
  KinematicState state(scene_mechanism);
  const auto start = [&](long roll) {
    const double t = t0 - static_cast<double>(roll) * h;
    state.q = reference_coordinates(scene_mechanism, reference, first);
    for (int di = 0; di < state.driver_count(); ++di) {
      const Driver& d = drivers[static_cast<size_t>(di)];
      DriverState& driver = state.drivers[static_cast<size_t>(di)];
      driver = d.at_time(t);
      driver.value = reference.driver_values(first, di) + (driver.value - d.at_time(t0).value);
    }
    const SolveReport report = solver.solve(state);
    return report.status == PoseStatus::ok &&
                   (roll == 0 || report.rcond >= singular_rcond * typical_rcond(reference))
               ? std::string()
           : report.message.empty() ? std::string("conditioned too badly")
                                    : report.message;
  };
  p.preroll = periodic && start(preroll).empty() ? preroll : 0;
  if (p.preroll == 0) {
    if (const std::string why = start(0); !why.empty()) {
      if (!perturbed)
        throw std::runtime_error("cannot assemble the scene at the first usable sample: " + why);
      state.q = reference_coordinates(scene_mechanism, reference, first);
      state.qdot.setZero();
      p.note = "the perturbed chain does not assemble at the first usable sample: started open";
    }
  }
  p.q = state.q;
  p.qdot = state.qdot;
  for (size_t di = 0; di < drivers.size(); ++di)
    p.driver_offset.push_back(reference.driver_values(first, static_cast<int>(di)) -
                              drivers[di].at_time(t0).value);
  p.grid = sample_grid(reference, p.span, per_interval, inner, p.preroll, h);
  return p;
}

JointGap::JointGap(const Mechanism& m, const NewtonSolver& solver)
    : solver_(solver), size_(m.size()), phi_(m.coordinate_count()), drivers_(m.drivers.size()) {
  for (size_t j = 0; j < m.joints.size(); ++j)
    if (m.joints[j].type == JointType::cam && !m.joints[j].form_closed)
      one_sided_.push_back(solver.layout().joint(static_cast<int>(j)).first_row);
}

double JointGap::joints() const {
  const ConstraintLayout& layout = solver_.layout();
  double gap = 0.0;
  for (int r = 0; r < layout.joint_row_count(); ++r) {
    const bool one_sided = std::find(one_sided_.begin(), one_sided_.end(), r) != one_sided_.end();
    const double off = one_sided ? std::max(0.0, -phi_(r)) : std::abs(phi_(r));
    gap = std::max(gap, off * (layout.angle_row(r) ? size_ : 1.0));
  }
  return gap;
}

double JointGap::separation(const Eigen::VectorXd& q) {
  if (one_sided_.empty()) return 0.0;
  measure(q);
  double off = 0.0;
  for (int r : one_sided_) off = std::max(off, phi_(r));
  return off;
}

double JointGap::at(const Eigen::VectorXd& q, const std::vector<double>& driver_values,
                    std::vector<double>& driver_errors) {
  for (size_t d = 0; d < drivers_.size(); ++d) drivers_[d].value = driver_values[d];
  solver_.residual(q, drivers_, phi_);
  double gap = joints();
  driver_errors.resize(drivers_.size());
  for (size_t d = 0; d < drivers_.size(); ++d) {
    driver_errors[d] = std::abs(phi_(solver_.layout().driver_row(static_cast<int>(d))));
    if (!std::isfinite(driver_errors[d])) gap = INFINITY;
  }
  if (!std::isfinite(gap)) gap = INFINITY;
  return gap;
}

void JointGap::measure(const Eigen::VectorXd& q) {
  for (size_t d = 0; d < drivers_.size(); ++d)
    drivers_[d].value = solver_.driver_value(q, static_cast<int>(d));
  solver_.residual(q, drivers_, phi_);
}

double JointGap::at(const Eigen::VectorXd& q) {
  measure(q);
  const double gap = joints();
  return std::isfinite(gap) ? gap : INFINITY;
}

double IntervalGaps::keep(long k, double gap) {
  while (interval_ < last_ && k > grid_.sample_step[static_cast<size_t>(interval_)]) ++interval_;
  gaps_(interval_) = std::max(gaps_(interval_), gap);
  return gap;
}

void judge_projected(
    StatusJudge& judge, const Mechanism& m, const Trajectory& reference, const SampleRows& rows,
    const Eigen::VectorXd& gaps, const std::function<void(int, KinematicState&)>& drive,
    const std::function<PoseStatus(int, const SolveReport&, const KinematicState&)>& judged,
    Trajectory& out) {
  const NewtonSolver solver(m);
  KinematicState probe(m);
  out.loop_gap = gaps;
  for (int i = 0; i < reference.samples(); ++i) {
    if (judge.outside(i, out)) continue;
    PoseStatus& status = out.status[static_cast<size_t>(i)];
    if (!rows.recorded(i)) {
      status = judge.lost(i);
      continue;
    }
    probe.q = rows.configuration(i);
    drive(i, probe);
    const SolveReport projected = solver.solve_position(probe);
    out.rcond(i) = projected.rcond;
    status = judged(i, projected, probe);
  }
}

double driver_watch_unit(const Mechanism& m) {
  return m.axis().timed() || m.swept().angular() ? 1.0 : m.size();
}

void reference_drivers(const Mechanism& m, const Trajectory& reference, int i,
                       KinematicState& state) {
  for (int d = 0; d < state.driver_count(); ++d) {
    DriverState& driver = state.drivers[static_cast<size_t>(d)];
    driver = m.drivers[static_cast<size_t>(d)].at_time(reference.time(i));
    driver.value = reference.driver_values(i, d);
  }
}

namespace {

// What the steps keep for the samples: the poses and force readings of the last kRing steps, by
// step mod kRing (a stencil reaches a few steps back at most).
constexpr long kRing = 16;

// The steps of a run: drive, load, step and read the scene, watch each pose it reaches (NaN, the
// engine's own alarm, the joint gap, the driver), and keep the last poses and force readings.
class Steps {
 public:
  Steps(const Mechanism& definition, const Mechanism& scene_mechanism, const KinematicPlan& plan,
        const KinematicWatch& watch, const SamplePlan& samples, int sample_count,
        KinematicScene& scene)
      : definition_(definition),
        plan_(plan),
        watch_(watch),
        samples_(samples),
        scene_(scene),
        gaps_(scene_mechanism, plan.grid, plan.span, sample_count),
        loads_(definition),
        velocity_(definition.coordinate_count()),
        law_(definition.drivers.size()),
        driver_(definition.drivers.size()),
        driver_errors_(definition.drivers.size()) {
    readings_.fill(ForceReading(definition.joints.size(), definition.drivers.size()));
    pose(0) = plan.q;
  }

  // The step to pose k; "" or why the run stops there.
  std::string step(long k) {
    const std::vector<double>& time = plan_.grid.time;
    const double t = time[static_cast<size_t>(k)];
    for (size_t d = 0; d < law_.size(); ++d) law_[d] = definition_.drivers[d].at_time(t).value;
    scene_.drive(law_);
    apply_loads(k - 1);
    const bool read = samples_.read_forces[static_cast<size_t>(k - 1)];
    std::string alarm =
        scene_.step(t - time[static_cast<size_t>(k - 1)], read ? &reading_at(k - 1) : nullptr);
    ++taken_;
    scene_.read_pose(pose(k));
    // The gap, kept for its sample interval; then what stops the run.
    for (size_t d = 0; d < law_.size(); ++d) driver_[d] = law_[d] + plan_.driver_offset[d];
    const double gap = gaps_.at(k, pose(k), driver_, driver_errors_);
    if (!pose(k).allFinite()) alarm = "NaN in the state";
    if (alarm.empty() && gap > watch_.divergence_gap)
      alarm =
          fmt::format("loop gap {} beyond the divergence limit {}", length_text(definition_, gap),
                      length_text(definition_, watch_.divergence_gap));
    const bool several = definition_.axis().timed();
    if (!alarm.empty())
      return several ? fmt::format("diverged at t = {:.6g} s: {}", t, alarm)
                     : fmt::format(
                           "diverged at t = {:.6g} s (driver {}): {}", t,
                           driver_unit_of(definition_)
                               .text(driver_[static_cast<size_t>(definition_.axis().driver)], 6),
                           alarm);
    for (size_t d = 0; d < law_.size(); ++d) {
      const double threshold = driver_threshold(d);
      if (!(driver_errors_[d] > threshold)) continue;
      // The driver's value and its error in the file's unit of that driver.
      const DriverUnit u = driver_unit_of(definition_.drivers[d], definition_.units);
      if (!several)
        return fmt::format(
            "lost the driver at t = {:.6g} s (driver {}): {} from its law, beyond {} "
            "(loop gap {})",
            t, u.text(driver_[d], 6), u.text(driver_errors_[d], 3), u.text(threshold, 3),
            length_text(definition_, gap));
      return fmt::format(
          "lost the driver '{}' at t = {:.6g} s (its value {}): {} from its law, beyond "
          "{} (loop gap {})",
          definition_.drivers[d].name, t, u.text(driver_[d], 6), u.text(driver_errors_[d], 3),
          u.text(threshold, 3), length_text(definition_, gap));
    }
    return "";
  }

  PoseAt poses() {
    return [this](long k) -> Eigen::Ref<const Eigen::VectorXd> { return pose(k); };
  }
  const ForceReading& reading(long k) const { return readings_[static_cast<size_t>(k % kRing)]; }
  const Eigen::VectorXd& gaps() const { return gaps_.gaps(); }
  long taken() const { return taken_; }

 private:
  Eigen::VectorXd& pose(long k) { return ring_[static_cast<size_t>(k % kRing)]; }
  // Driver d's watch threshold in its own unit (KinematicWatch::driver).
  double driver_threshold(size_t d) const {
    const double own = definition_.drivers[d].angular() ? 1.0 : definition_.size();
    const double unit = driver_watch_unit(definition_);
    return unit == own ? watch_.driver : watch_.driver / unit * own;
  }
  ForceReading& reading_at(long k) { return readings_[static_cast<size_t>(k % kRing)]; }

  // The definition's loads and springs at pose k, at its velocity: the exact one at the start,
  // then a one-sided difference of the last poses.
  void apply_loads(long k) {
    if (!loads_.any()) return;
    const double t = plan_.grid.time[static_cast<size_t>(k)];
    if (k == 0)
      velocity_ = plan_.qdot;
    else
      recent_velocity(k, plan_.grid.time, poses(), velocity_);
    // A load's table is over the swept driver's value (refused in a sweep in time).
    const SweepAxis axis = definition_.axis();
    const double swept = axis.timed() ? 0.0
                                      : definition_.swept().at_time(t).value +
                                            plan_.driver_offset[static_cast<size_t>(axis.driver)];
    scene_.apply(loads_.at(pose(k), velocity_, swept));
  }

  const Mechanism& definition_;
  const KinematicPlan& plan_;
  const KinematicWatch& watch_;
  const SamplePlan& samples_;
  KinematicScene& scene_;
  IntervalGaps gaps_;
  AppliedLoads loads_;
  Eigen::VectorXd velocity_;
  std::array<Eigen::VectorXd, kRing> ring_;
  std::array<ForceReading, kRing> readings_;
  // Scratch per driver: its law's value at the step's end, as the reference counts it, its row's
  // error there.
  std::vector<double> law_, driver_, driver_errors_;
  long taken_ = 0;
};

// Sample i, once step `now` is taken: its position, velocity and acceleration from the poses of
// its difference stencil, its forces from the readings of its force stencil.
void write_sample(int i, long now, const Mechanism& m, const Trajectory& reference,
                  const std::vector<double>& time, const SamplePlan& plan, Steps& steps,
                  SampleRows& rows, Trajectory& out) {
  const auto row = static_cast<size_t>(i);
  // The ring holds the last kRing poses and readings: a stencil reaching further back would read
  // a later step's.
  const long oldest =
      std::min(plan.stencil[row].front(), rows.with_forces() && !plan.forces[row].steps.empty()
                                              ? plan.forces[row].steps.front()
                                              : plan.stencil[row].front());
  if (now - oldest >= kRing)
    throw std::logic_error(
        fmt::format("sample {} is written {} steps after its first pose", i, now - oldest));
  KinematicState& state = rows.state();
  difference_state(reference.time(i), plan.stencil[row], time, steps.poses(), state.q, state.qdot,
                   state.qddot);
  reference_drivers(m, reference, i, state);
  if (rows.with_forces())
    combine_readings(
        plan.forces[row], [&](long k) -> const ForceReading& { return steps.reading(k); },
        rows.forces());
  rows.write(i, out);
}

// Statuses: the shared judge over each sample's gap, the conditioning of the definition's
// constraints at the engine's configuration (an engine passes change points and toggles
// silently: Newton from there, at the reference's driver value) and the configuration Newton
// closes from it, which must be the reference's (another solution is another assembly mode; a
// model error does not move it and stays a reported difference); an event on each singular
// sample and on the first jump. A sample whose follower stands off a force-closed cam by more
// than the gap threshold is contact_lost, the follower in flight, with an event on the first.
StatusJudge judge_samples(const Mechanism& m, const Trajectory& reference, const Span& span,
                          const KinematicWatch& watch, const SampleRows& sampled,
                          const Eigen::VectorXd& gaps, Trajectory& out) {
  StatusJudge judge(reference, span, {watch.gap, watch.singular_rcond, watch.branch_distance},
                    true);
  const NewtonSolver solver(m);
  JointGap contact(m, solver);
  bool left = false;
  judge_projected(
      judge, m, reference, sampled, gaps,
      [&](int i, KinematicState& probe) { reference_drivers(m, reference, i, probe); },
      [&](int i, const SolveReport& projected, const KinematicState& closed) {
        const bool own_flag = usable(reference.status[static_cast<size_t>(i)]);
        if (const double apart = contact.separation(sampled.configuration(i));
            own_flag && apart > watch.gap) {
          if (!left)
            out.events.push_back(
                {event_position(reference, i), PoseStatus::contact_lost,
                 fmt::format("the follower leaves the cam ({} off its profile) where the exact "
                             "motion keeps it on",
                             length_text(m, apart))});
          left = true;
          return PoseStatus::contact_lost;
        }
        double off = 0.0;
        const PoseStatus status = judge.judge(
            i, gaps(i), projected.rcond,
            [&] {
              if (projected.status != PoseStatus::ok) return -1.0;
              off = configuration_distance(closed.q, reference_coordinates(m, reference, i),
                                           m.size());
              return off;
            },
            out);
        // The engine's events on the flags it gives itself (a reference's flag kept has its own).
        if (own_flag && status == PoseStatus::singular)
          out.events.push_back({event_position(reference, i), PoseStatus::singular,
                                fmt::format("the constraint Jacobian at the engine's "
                                            "configuration is singular (rcond {:.2g})",
                                            projected.rcond)});
        if (own_flag && status == PoseStatus::branch_jump && judge.jumped() == 1)
          out.events.push_back(
              {event_position(reference, i), PoseStatus::branch_jump,
               fmt::format("the engine closes the loops on another assembly mode than the "
                           "reference (closed configuration {:.3g} of the size or rad away)",
                           off)});
        return status;
      },
      out);
  return judge;
}

// The run's notes and the events of its counts, after the statuses.
void note_samples(const Mechanism& definition, const Trajectory& reference, const Span& span,
                  const StatusJudge& judge, bool stopped, const Eigen::VectorXd& gaps,
                  double gap_threshold, EngineRun& run) {
  Trajectory& out = run.trajectory;
  const int samples = reference.samples();
  if (stopped && judge.first_lost() >= 0)
    out.events.push_back(
        {event_position(reference, judge.first_lost()), PoseStatus::diverged, run.message});
  const int outside = span.first + (samples - 1 - span.last);
  if (outside > 0)
    add_note(
        run.message,
        fmt::format(
            "run over the reference's usable samples {} .. {} ({} .. {}); "
            "the {} samples outside (flagged by the reference: {}) keep its flag and "
            "carry no engine value",
            span.first, span.last,
            sweep_position_text(definition, event_position(reference, span.first), 6),
            sweep_position_text(definition, event_position(reference, span.last), 6), outside,
            to_string(reference.status[static_cast<size_t>(span.first > 0 ? 0 : samples - 1)])));
  add_note(run.message, kept_note(judge.kept(), true));
  add_note(run.message, branch_jump_note(judge.jumped()));
  // The engine's own contact_lost (judge_samples): where its follower flies.
  int flying = 0, first_flying = -1;
  for (int i = 0; i < samples; ++i)
    if (out.status[static_cast<size_t>(i)] == PoseStatus::contact_lost &&
        usable(reference.status[static_cast<size_t>(i)]) && flying++ == 0)
      first_flying = i;
  if (flying > 0)
    add_note(
        run.message,
        fmt::format("the follower is off its cam at {} samples where the exact motion keeps "
                    "it on, first at {} (contact_lost: it flies, docs/cams.md)",
                    flying,
                    sweep_position_text(definition, event_position(reference, first_flying), 6)));
  note_loop_gaps(judge.loop_gaps(), gaps, gap_threshold, reference, run, definition);
}

}  // namespace

void run_kinematic(const Mechanism& definition, const Mechanism& scene_mechanism,
                   const Trajectory& reference, const KinematicPlan& plan,
                   const KinematicWatch& watch, bool with_forces, KinematicScene& scene,
                   Clock::time_point begin, EngineRun& run) {
  Trajectory& out = run.trajectory;
  out.resize_as(definition, reference, with_forces);
  const std::vector<double>& time = plan.grid.time;
  const long last_step = static_cast<long>(time.size()) - 1;
  if (last_step < 3) {
    run.ok = false;
    run.message = fmt::format(
        "only {} steps between the first and last usable samples: too few for differences",
        last_step);
    return;
  }
  const SamplePlan samples =
      plan_samples(reference, plan.span, time, plan.grid.sample_step, with_forces);
  Steps steps(definition, scene_mechanism, plan, watch, samples, reference.samples(), scene);
  SampleRows sampled(definition, reference.samples(), with_forces);

  // Every sample is written as soon as the step completing its stencils is taken.
  SteppingClock stepping;
  std::string stop;
  int pending = plan.span.first;  // the next sample to write
  for (long k = 1; k <= last_step; ++k) {
    if (stop = steps.step(k); !stop.empty()) break;
    for (; pending <= plan.span.last && samples.complete_at(pending) <= k; ++pending)
      write_sample(pending, k, definition, reference, time, samples, steps, sampled, out);
  }
  stepping.stop();

  if (!stop.empty()) {
    run.ok = false;
    run.message = stop;
  }
  const StatusJudge judge =
      judge_samples(definition, reference, plan.span, watch, sampled, steps.gaps(), out);
  note_samples(definition, reference, plan.span, judge, !stop.empty(), steps.gaps(), watch.gap,
               run);
  add_note(run.message, plan.note);
  add_note(run.message, scene.note());
  const double simulated = time[static_cast<size_t>(steps.taken())] - time.front();
  const double period = definition.cycle_period();
  record_cost(steps.taken(), scene.evaluations(), simulated, period > 0.0 ? period : simulated,
              stepping, begin, run.cost);
  run.cost.time_step = plan.grid.dt;
}

}  // namespace crosslink::sim
