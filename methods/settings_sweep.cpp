// Speed against accuracy (settings_sweep.h, docs/sweep.md): grids, evaluation through
// compare_methods(), Pareto fronts, convergence orders, the cheapest-setting search, CSV.
#include "methods/settings_sweep.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "compare/comparison.h"
#include "compare/report.h"
#include "compare/tolerance.h"
#include "methods/jobs.h"
#include "methods/sweep_ranking.h"

namespace crosslink::methods {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

size_t index_of(ErrorClass c) {
  return static_cast<size_t>(c);
}

std::string format_dt(double dt) {
  return fmt::format("{:.4g}", dt);
}

// Max % of peak per class over the comparison's channels of one method.
ClassValues class_maxima(const Comparison& cmp, std::string_view method) {
  ClassValues out = kNoValues;
  for (const ChannelResult& c : cmp.channels) {
    if (c.method != method || c.metrics.usable == 0) continue;
    const std::optional<ErrorClass> kind = error_class_of(c.metrics.quantity);
    if (!kind) continue;
    double& e = out[index_of(*kind)];
    const double v = c.metrics.max_pct_of_peak;
    // NaN in a channel (a NaN value the engine did not flag) makes the class NaN: not usable.
    if (std::isnan(v))
      e = std::numeric_limits<double>::infinity();
    else
      e = std::isnan(e) ? v : std::max(e, v);
  }
  return out;
}

double seconds_per_cycle(const MethodRun& run) {
  return run.cost.wall_seconds_per_cycle;
}

double cpu_per_cycle(const MethodRun& run) {
  return run.cost.cpu_seconds_per_cycle;
}

double median(std::vector<double> values) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// Dynamics cases: per class, the largest |% of peak| at each channel's last sample in the
// verdict (the end of the run); the largest max % of the energy channels.
void end_and_energy(const Comparison& cmp, std::string_view method, SweepRow& row) {
  for (const ChannelResult& c : cmp.channels) {
    if (c.method != method || c.metrics.usable == 0) continue;
    if (c.metrics.quantity == Quantity::energy) {
      row.energy_pct = std::isnan(row.energy_pct)
                           ? c.metrics.max_pct_of_peak
                           : std::max(row.energy_pct, c.metrics.max_pct_of_peak);
      continue;
    }
    const std::optional<ErrorClass> kind = error_class_of(c.metrics.quantity);
    if (!kind) continue;
    int last = -1;
    for (size_t k = 0; k < c.metrics.in_verdict.size(); ++k)
      if (c.metrics.in_verdict[k]) last = static_cast<int>(k);
    if (last < 0) continue;
    double& e = row.end_pct[index_of(*kind)];
    const double v = std::abs(c.metrics.pct_of_peak(last));
    e = std::isnan(e) ? v : std::max(e, v);
  }
}

void set_tip_errors(const Mechanism& mechanism, const Trajectory& reference, const Trajectory& run,
                    SweepRow& row) {
  const std::array<double, 2> e = benchmark_tip_errors(mechanism, reference, run);
  row.tip_position_error = e[0];
  row.tip_velocity_error = e[1];
}

}  // namespace

std::string_view to_string(ErrorClass c) {
  switch (c) {
    case ErrorClass::position:
      return "position";
    case ErrorClass::velocity:
      return "velocity";
    case ErrorClass::acceleration:
      return "acceleration";
    case ErrorClass::force:
      return "force";
  }
  return "?";
}

std::optional<ErrorClass> error_class_of(Quantity q) {
  switch (q) {
    case Quantity::position:
    case Quantity::angle:
      return ErrorClass::position;
    case Quantity::velocity:
      return ErrorClass::velocity;
    case Quantity::acceleration:
      return ErrorClass::acceleration;
    case Quantity::force:
    case Quantity::torque:
      return ErrorClass::force;
    case Quantity::energy:
      return std::nullopt;  // its own column (energy_pct)
    case Quantity::jerk:
      return std::nullopt;  // no engine reports it
  }
  return std::nullopt;
}

std::string_view to_string(RunStatus s) {
  switch (s) {
    case RunStatus::ok:
      return "ok";
    case RunStatus::flagged:
      return "flagged";
    case RunStatus::diverged:
      return "diverged";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Grids

std::vector<Variant> engine_variants(std::string_view engine, bool dynamics, bool friction) {
  if (const EngineEntry* entry = find_engine(engine)) {
    std::vector<Variant> out = dynamics ? entry->dynamics_variants : entry->variants;
    if (friction)
      out.insert(out.end(), entry->friction_variants.begin(), entry->friction_variants.end());
    return out;
  }
  throw std::invalid_argument(fmt::format("no settings grid for '{}' (engines: {})", engine,
                                          fmt::join(engine_names(), ", ")));
}

std::vector<double> default_time_steps() {
  return {1e-2, 3e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5};
}

std::vector<double> accuracy_time_steps(double interval) {
  std::vector<double> dts;
  for (int n : {1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128}) dts.push_back(interval / n);
  return dts;
}

std::vector<GridPoint> engine_grid(std::string_view engine, const std::vector<double>& dts,
                                   bool dynamics, bool friction) {
  std::vector<double> sorted = dts;
  std::sort(sorted.begin(), sorted.end(), std::greater<>());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  std::vector<GridPoint> grid;
  const std::vector<Variant> variants = engine_variants(engine, dynamics, friction);
  for (double dt : sorted)
    for (const Variant& v : variants)
      grid.push_back({std::string(engine), v.name, dt, v.settings(dt)});
  return grid;
}

// ---------------------------------------------------------------------------------------------
// References on step boundaries

ReferenceLadder::ReferenceLadder(const Mechanism& mechanism, const SweepOptions& options)
    : ReferenceLadder(mechanism, options, run_reference(mechanism, options)) {}

ReferenceLadder::ReferenceLadder(const Mechanism& mechanism, const SweepOptions& options,
                                 MethodRun base)
    : mechanism_(mechanism), options_(options) {
  base_ = std::make_unique<MethodRun>(std::move(base));
  const Trajectory& t = base_->trajectory;
  if (t.samples() < 2) throw std::runtime_error("the reference sweep has fewer than two samples");
  interval_ = t.time(1) - t.time(0);
  base_step_ = std::abs(t.along(1) - t.along(0));
  if (!(interval_ > 0.0))
    throw std::runtime_error("the reference's samples are not spaced in time");
  exact_.emplace(base_.get(), exact_values(mechanism_, *base_));
}

const compare::ExactValues& ReferenceLadder::exact_of(const MethodRun& reference) {
  const std::lock_guard<std::mutex> hold(coarse_lock_);
  const auto it = exact_.find(&reference);
  if (it == exact_.end()) throw std::logic_error("exact_of: not a reference of this ladder");
  return it->second;
}

const MethodRun& ReferenceLadder::for_dt(double dt, double* snapped) {
  const double h = interval_;
  if (!(dt > 0.0)) throw std::invalid_argument("a time step must be positive");
  const long m = std::lround(dt / h);
  if (mechanism_.dynamics && dt > h) {  // an engine never steps past a sample
    *snapped = h;
    return *base_;
  }
  if (dt <= h || m <= 1) {
    const long n = std::max(1L, std::lround(h / dt));
    *snapped = h / static_cast<double>(n);
    return *base_;
  }
  const std::lock_guard<std::mutex> hold(coarse_lock_);
  auto it = coarse_.find(m);
  if (it == coarse_.end()) {
    // A sweep through every m-th driver value: its samples fall every m h.
    SweepOptions coarse = options_;
    coarse.step = static_cast<double>(m) * base_step_;
    auto run = std::make_unique<MethodRun>(run_reference(mechanism_, coarse));
    const Trajectory& t = run->trajectory;
    const bool spaced = t.samples() >= 2 &&
                        std::abs((t.time(1) - t.time(0)) - static_cast<double>(m) * h) <= 1e-6 * h;
    if (!spaced) run.reset();  // a law that does not map steps to times: stay on the base
    if (run) exact_.emplace(run.get(), exact_values(mechanism_, *run));
    it = coarse_.emplace(m, std::move(run)).first;
  }
  if (!it->second) {
    *snapped = h;
    return *base_;
  }
  *snapped = static_cast<double>(m) * h;
  return *it->second;
}

// ---------------------------------------------------------------------------------------------
// Rows

std::string SweepRow::setting_label() const {
  if (engine == "analytic") return variant;
  return fmt::format("{}, dt={}", variant, format_dt(dt));
}

double SweepRow::benchmark_error() const {
  if (std::isnan(tip_position_error)) return tip_velocity_error;
  if (std::isnan(tip_velocity_error)) return tip_position_error;
  return std::max(tip_position_error, tip_velocity_error);
}

std::optional<std::string> benchmark_tip_point(const Mechanism& mechanism) {
  if (mechanism.axis().timed()) return std::nullopt;  // the benchmarks have one coordinate
  const Driver& d = mechanism.swept();
  if (d.link < 0 || d.to < 0) return std::nullopt;
  return mechanism.links[static_cast<size_t>(d.link)].points[static_cast<size_t>(d.to)].name;
}

std::array<double, 2> benchmark_tip_errors(const Mechanism& mechanism, const Trajectory& reference,
                                           const Trajectory& run) {
  std::array<double, 2> out = {kNaN, kNaN};
  const std::optional<std::string> tip_point = benchmark_tip_point(mechanism);
  if (!tip_point || reference.samples() != run.samples()) return out;
  const std::string& tip = *tip_point;
  const auto column = [&](const Trajectory& t) -> Eigen::Index {
    const auto it = std::find(t.point_names.begin(), t.point_names.end(), tip);
    return it == t.point_names.end() ? -1 : it - t.point_names.begin();
  };
  const Eigen::Index p = column(reference), q = column(run);
  if (p < 0 || q < 0) return out;
  const auto worst = [](double& e, double a, double b) {
    if (std::isfinite(a) && std::isfinite(b))
      e = std::isnan(e) ? std::abs(a - b) : std::max(e, std::abs(a - b));
  };
  for (int k = 0; k < run.samples(); ++k) {
    const PoseStatus s = run.status[static_cast<size_t>(k)];
    if (s == PoseStatus::diverged || s == PoseStatus::not_reached || !run.was_run(k)) continue;
    worst(out[0], run.x(k, q), reference.x(k, p));
    worst(out[0], run.y(k, q), reference.y(k, p));
    worst(out[1], run.vx(k, q), reference.vx(k, p));
    worst(out[1], run.vy(k, q), reference.vy(k, p));
  }
  return out;
}

double SweepRow::work() const {
  if (engine == "analytic" || !(dt > 0.0)) return kNaN;
  return evaluations_per_step / dt;
}

bool SweepRow::meets(double accuracy_pct) const {
  return meets(ClassLimits::uniform(accuracy_pct));
}

bool SweepRow::meets(const ClassLimits& limits) const {
  if (status != RunStatus::ok) return false;
  for (ErrorClass c : kErrorClasses) {
    const double e = error(c);
    if (c == ErrorClass::force && std::isnan(e)) continue;  // forces not read
    if (!(e <= limits.pct[index_of(c)])) return false;      // NaN fails
  }
  return std::isnan(energy_pct) || energy_pct <= limits.energy_pct;
}

SweepRow evaluate_setting(const Mechanism& mechanism, ReferenceLadder& ladder,
                          const GridPoint& point, const sim::Settings& base) {
  double dt = 0.0;
  const MethodRun& reference = ladder.for_dt(point.dt, &dt);
  sim::Settings settings = base;
  settings.insert(settings.end(), point.settings.begin(), point.settings.end());
  settings.emplace_back("dt", fmt::format("{:.12g}", dt));

  // An engine that refuses a setting throws: that setting did not run.
  auto attempt = [&]() {
    try {
      return run_method(point.engine, mechanism, reference, settings);
    } catch (const std::invalid_argument&) {
      throw;  // an unknown method: the caller's mistake
    } catch (const std::exception& e) {
      MethodRun failed;
      failed.name = point.engine;
      failed.available = true;
      failed.ok = false;
      failed.message = e.what();
      return failed;
    }
  };
  const MethodRun run = attempt();

  SweepRow row;
  row.engine = point.engine;
  row.variant = point.variant;
  row.dt = dt;
  row.samples = reference.trajectory.samples();
  row.message = run.message;
  row.overrides = settings;
  if (!run.available) {
    row.status = RunStatus::diverged;
    row.settings = settings;
    return row;
  }
  row.settings = run.settings.empty() ? settings : run.settings;
  if (run.cost.time_step > 0.0) row.dt = run.cost.time_step;  // the step in force
  row.wall_s_per_cycle = seconds_per_cycle(run);
  row.cpu_s_per_cycle = cpu_per_cycle(run);
  if (run.cost.steps > 0)
    row.evaluations_per_step =
        static_cast<double>(run.cost.model_evaluations) / static_cast<double>(run.cost.steps);
  const Trajectory& ref = reference.trajectory;
  const Trajectory& tr = run.trajectory;
  const bool shaped = tr.samples() == ref.samples() && tr.status.size() == ref.status.size();
  if (shaped && tr.loop_gap.size() == tr.samples())
    for (Eigen::Index k = 0; k < tr.loop_gap.size(); ++k)
      if (std::isfinite(tr.loop_gap(k)))
        row.max_loop_gap = std::max(row.max_loop_gap, tr.loop_gap(k));
  // A dynamics run passes singular positions under its own momentum; the samples it flags next
  // to them (rcond, the configuration's property) do not make the setting `flagged`: a loop gap
  // or a divergence does.
  int failing = 0;
  if (shaped)
    for (size_t k = 0; k < ref.status.size(); ++k)
      if (usable(ref.status[k]) && !usable(tr.status[k])) {
        ++row.flagged_samples;
        if (!mechanism.dynamics || tr.status[k] != PoseStatus::singular) ++failing;
      }

  // The verdict metric: compare_methods, as `crosslink compare` does.
  const Tolerances tolerances = default_tolerances(mechanism);
  const compare::ExactValues& exact = ladder.exact_of(reference);
  if (run.ok) {
    const Comparison cmp = compare_methods(mechanism, {reference, run}, tolerances, exact);
    row.max_pct = class_maxima(cmp, run.name);
    if (mechanism.dynamics) end_and_energy(cmp, run.name, row);
    if (mechanism.dynamics && shaped) set_tip_errors(mechanism, ref, tr, row);
  }
  // Over every recorded sample, flagged ones included: the same comparison on a copy whose
  // engine-side flags are lifted (samples never reached stay out).
  if (shaped && (!run.ok || failing > 0)) {
    MethodRun lifted = run;
    lifted.ok = true;
    bool any = false;
    for (PoseStatus& st : lifted.trajectory.status)
      if (st != PoseStatus::diverged) {
        st = PoseStatus::ok;
        any = true;
      }
    if (any)
      row.raw_pct = class_maxima(compare_methods(mechanism, {reference, lifted}, tolerances, exact),
                                 run.name);
  }
  if (!run.ok)
    row.status = RunStatus::diverged;
  else if (failing > 0)
    row.status = RunStatus::flagged;
  for (double e : row.max_pct)
    if (std::isinf(e)) row.status = RunStatus::diverged;  // NaN values the engine did not flag
  return row;
}

void retime(const Mechanism& mechanism, ReferenceLadder& ladder, std::vector<SweepRow>& rows,
            size_t first, int repeat, const Progress& progress, int jobs) {
  std::vector<std::vector<double>> wall(rows.size()), cpu(rows.size());
  for (size_t i = first; i < rows.size(); ++i) {
    wall[i] = {rows[i].wall_s_per_cycle};
    cpu[i] = {rows[i].cpu_s_per_cycle};
  }
  // The runs, round by round (every row once per round), each a job; its times go to its own
  // slot, and the medians do not depend on the order they came in.
  struct Rerun {
    int round;
    size_t row;
    double wall = 0.0, cpu = 0.0;
  };
  std::vector<Rerun> reruns;
  for (int round = 1; round < repeat; ++round)
    for (size_t i = first; i < rows.size(); ++i)
      if (rows[i].status != RunStatus::diverged) reruns.push_back({round, i});  // else no timing
  const int count = static_cast<int>(rows.size() - first);
  run_jobs(
      jobs, reruns.size(),
      [&](size_t k) {
        const SweepRow& row = rows[reruns[k].row];
        double dt = 0.0;
        const MethodRun& reference = ladder.for_dt(row.dt, &dt);
        const MethodRun again = run_method(row.engine, mechanism, reference, row.overrides);
        reruns[k].wall = seconds_per_cycle(again);
        reruns[k].cpu = cpu_per_cycle(again);
      },
      [&](size_t k) {
        if (!progress) return;
        const SweepRow& row = rows[reruns[k].row];
        progress(reruns[k].round * count + static_cast<int>(reruns[k].row - first) + 1,
                 repeat * count, {row.engine, row.variant + " (timing)", row.dt, {}});
      });
  for (const Rerun& r : reruns) {
    wall[r.row].push_back(r.wall);
    cpu[r.row].push_back(r.cpu);
  }
  for (size_t i = first; i < rows.size(); ++i) {
    rows[i].wall_s_per_cycle = median(wall[i]);
    rows[i].cpu_s_per_cycle = median(cpu[i]);
    rows[i].repeats = static_cast<int>(cpu[i].size());
  }
}

std::vector<SweepRow> analytic_rows(const Mechanism& mechanism, const SweepOptions& options,
                                    int repeat, std::vector<std::string>* skipped) {
  std::vector<SweepRow> rows;
  MethodRun reference = run_reference(mechanism, options);
  std::vector<double> costs = {seconds_per_cycle(reference)}, cpu = {cpu_per_cycle(reference)};
  for (int r = 1; r < repeat; ++r) {
    const MethodRun again = run_reference(mechanism, options);
    costs.push_back(seconds_per_cycle(again));
    cpu.push_back(cpu_per_cycle(again));
  }
  reference.cost.wall_seconds_per_cycle = median(costs);
  reference.cost.cpu_seconds_per_cycle = median(cpu);
  SweepRow newton;
  newton.engine = "analytic";
  newton.variant = mechanism.dynamics ? "exact" : "newton";
  newton.repeats = static_cast<int>(costs.size());
  // Its settings, not its cost (the reference's check's time: the row's cost columns say it).
  for (const auto& [key, value] : reference.settings)
    if (!key.ends_with("_seconds")) newton.settings.push_back({key, value});
  newton.wall_s_per_cycle = seconds_per_cycle(reference);
  newton.cpu_s_per_cycle = cpu_per_cycle(reference);
  newton.max_pct = {0.0, 0.0, 0.0,  // the reference itself
                    reference.trajectory.has_forces ? 0.0 : kNaN};
  newton.samples = reference.trajectory.samples();
  newton.message = "the reference: error 0 by definition";
  rows.push_back(newton);
  if (mechanism.dynamics) {
    // The exact simulation's second integrator (dopri5, dense output) at looser tolerances,
    // against the reference (rkf78 at 1e-13): the IFToMM ranking's other axis (what a tolerance
    // costs). Not rkf78 itself: stepped to each sample, its steps never exceed the sample
    // interval, and at that step its eighth order is below every tolerance here, so each
    // looser rkf78 run is the same run (docs/sweep.md).
    const Tolerances tolerances = default_tolerances(mechanism);
    const compare::ExactValues exact = exact_values(mechanism, reference);
    for (double tolerance : kSimulationTolerances) {
      SimulationOptions loose;
      loose.integrator = kSimulationTolerancesIntegrator;
      loose.tolerance = tolerance;
      MethodRun run = run_simulation(mechanism, loose);
      std::vector<double> times = {seconds_per_cycle(run)}, cpu_times = {cpu_per_cycle(run)};
      for (int r = 1; r < repeat; ++r) {
        const MethodRun again = run_simulation(mechanism, loose);
        times.push_back(seconds_per_cycle(again));
        cpu_times.push_back(cpu_per_cycle(again));
      }
      SweepRow row;
      row.engine = "analytic";
      row.variant = fmt::format("exact, tolerance {:g}", tolerance);
      row.settings = run.settings;
      row.wall_s_per_cycle = median(times);
      row.cpu_s_per_cycle = median(cpu_times);
      row.repeats = static_cast<int>(times.size());
      row.samples = reference.trajectory.samples();
      row.message = run.message;
      run.name = loose.integrator;  // compared as a method of its own
      const Comparison cmp = compare_methods(mechanism, {reference, run}, tolerances, exact);
      row.max_pct = class_maxima(cmp, run.name);
      end_and_energy(cmp, run.name, row);
      set_tip_errors(mechanism, reference.trajectory, run.trajectory, row);
      row.status = run.ok ? RunStatus::ok : RunStatus::diverged;
      rows.push_back(row);
    }
    return rows;
  }

  MethodRun dyads = run_method("dyads", mechanism, reference);
  if (!dyads.available && skipped) skipped->push_back("dyads: " + dyads.message);
  if (dyads.available) {
    for (int r = 1; r < repeat && dyads.ok; ++r)
      dyads.cost.wall_seconds_per_cycle =
          std::min(dyads.cost.wall_seconds_per_cycle,
                   seconds_per_cycle(run_method("dyads", mechanism, reference)));
    SweepRow row;
    row.engine = "analytic";
    row.variant = "dyads";
    row.settings = dyads.settings;
    row.wall_s_per_cycle = seconds_per_cycle(dyads);
    row.cpu_s_per_cycle = cpu_per_cycle(dyads);
    row.samples = reference.trajectory.samples();
    row.message = dyads.message;
    if (dyads.ok) {
      const Comparison cmp =
          compare_runs(mechanism, {reference, dyads},
                       Tolerances(engine_tolerances(false), mechanism.tolerances));
      row.max_pct = class_maxima(cmp, "dyads");
      for (size_t k = 0; k < reference.trajectory.status.size(); ++k)
        if (usable(reference.trajectory.status[k]) && !usable(dyads.trajectory.status[k]))
          ++row.flagged_samples;
      row.status = row.flagged_samples > 0 ? RunStatus::flagged : RunStatus::ok;
    } else {
      row.status = RunStatus::diverged;
    }
    rows.push_back(row);
  }
  return rows;
}

// ---------------------------------------------------------------------------------------------
// Analysis

std::vector<bool> pareto_front(const std::vector<double>& cost, const std::vector<double>& error,
                               const std::vector<bool>& eligible, double error_tie) {
  const size_t n = cost.size();
  if (error.size() != n || eligible.size() != n)
    throw std::invalid_argument("pareto_front: cost, error and eligible differ in length");
  auto valid = [&](size_t i) {
    return eligible[i] && std::isfinite(cost[i]) && std::isfinite(error[i]);
  };
  std::vector<bool> front(n, false);
  const double band = 1.0 + error_tie;
  for (size_t i = 0; i < n; ++i) {
    if (!valid(i)) continue;
    bool dominated = false;
    for (size_t j = 0; j < n && !dominated; ++j)
      dominated = j != i && valid(j) && cost[j] <= cost[i] && error[j] <= band * error[i] &&
                  (cost[j] < cost[i] || band * error[j] < error[i]);
    front[i] = !dominated;
  }
  return front;
}

ConvergenceFit convergence_order(const std::vector<double>& dt, const std::vector<double>& error,
                                 double saturation_pct, double floor_order) {
  if (dt.size() != error.size())
    throw std::invalid_argument("convergence_order: dt and error differ in length");
  ConvergenceFit fit;
  fit.used.assign(dt.size(), false);
  // Candidates from coarse to fine.
  std::vector<size_t> order(dt.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return dt[a] > dt[b]; });
  std::vector<size_t> kept;
  for (size_t i : order) {
    if (!(dt[i] > 0.0) || !std::isfinite(dt[i]) || !std::isfinite(error[i]) || !(error[i] > 0.0) ||
        error[i] >= saturation_pct)
      continue;
    if (!kept.empty()) {
      const size_t last = kept.back();
      if (dt[i] == dt[last]) continue;  // one point per dt
      const double local = std::log(error[last] / error[i]) / std::log(dt[last] / dt[i]);
      if (local < floor_order) break;  // the floor: finer points stop improving
    }
    kept.push_back(i);
  }
  fit.points = static_cast<int>(kept.size());
  if (kept.size() < 2) return fit;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i : kept) {
    const double x = std::log(dt[i]), y = std::log(error[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    fit.used[i] = true;
  }
  const double n = static_cast<double>(kept.size());
  fit.order = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  fit.dt_max = dt[kept.front()];
  fit.dt_min = dt[kept.back()];
  return fit;
}

bool error_falls(const std::vector<double>& dt, const std::vector<double>& error) {
  // The two finest steps with a finite error: does the finer still buy accuracy?
  const size_t none = dt.size();
  size_t finest = none, next = none;
  for (size_t i = 0; i < dt.size(); ++i) {
    if (!std::isfinite(error[i]) || !std::isfinite(dt[i])) continue;
    if (finest == none || dt[i] < dt[finest]) {
      next = finest;
      finest = i;
    } else if (next == none || dt[i] < dt[next]) {
      next = i;
    }
  }
  if (next == none || !(dt[finest] < dt[next])) return true;
  return (1.0 + kErrorTie) * error[finest] < error[next];
}

std::string OrderRow::not_falling_text() const {
  if (not_falling.empty()) return {};
  std::string classes;
  for (ErrorClass c : not_falling)
    classes += fmt::format("{}{}", classes.empty() ? "" : ", ", to_string(c));
  return classes + " error does not fall as dt shrinks";
}

std::string with_series_note(const SettingsSweep& sweep, const SweepRow& row, std::string text) {
  for (const OrderRow& o : sweep.orders)
    if (o.engine == row.engine && o.variant == row.variant && !o.not_falling.empty())
      text += (text.empty() ? "" : "; ") + o.not_falling_text();
  return text;
}

void analyse(SettingsSweep& sweep) {
  // Pareto fronts over the engine settings with status ok (the analytic methods are drawn for
  // scale: Newton is the reference itself).
  std::vector<size_t> engine_rows;
  for (size_t i = 0; i < sweep.rows.size(); ++i)
    if (sweep.rows[i].engine != "analytic") engine_rows.push_back(i);
  for (ErrorClass c : kErrorClasses) {
    std::vector<double> work, error;
    std::vector<bool> eligible;
    for (size_t i : engine_rows) {
      work.push_back(sweep.rows[i].work());
      error.push_back(sweep.rows[i].error(c));
      eligible.push_back(sweep.rows[i].status == RunStatus::ok);
    }
    const std::vector<bool> front = pareto_front(work, error, eligible, kErrorTie);
    for (size_t k = 0; k < engine_rows.size(); ++k)
      sweep.rows[engine_rows[k]].pareto[index_of(c)] = front[k];
  }
  // Orders per (engine, variant) series, over its rows with status ok.
  sweep.orders.clear();
  for (size_t i : engine_rows) {
    const SweepRow& r = sweep.rows[i];
    const bool seen = std::any_of(sweep.orders.begin(), sweep.orders.end(), [&](const OrderRow& o) {
      return o.engine == r.engine && o.variant == r.variant;
    });
    if (seen) continue;
    OrderRow o{r.engine, r.variant, {}, {}};
    for (ErrorClass c : kErrorClasses) {
      std::vector<double> dts, errors;
      for (size_t j : engine_rows) {
        const SweepRow& s = sweep.rows[j];
        if (s.engine != r.engine || s.variant != r.variant) continue;
        dts.push_back(s.dt);
        errors.push_back(s.status == RunStatus::ok ? s.error(c) : kNaN);
      }
      o.fit[index_of(c)] = convergence_order(dts, errors);
      if (!error_falls(dts, errors)) o.not_falling.push_back(c);
    }
    sweep.orders.push_back(std::move(o));
  }
  // The IFToMM limits, where the case has the benchmark's tip point.
  sweep.limits.clear();
  if (sweep.dynamics && std::any_of(sweep.rows.begin(), sweep.rows.end(), [](const SweepRow& r) {
        return !std::isnan(r.benchmark_error());
      }))
    sweep.limits = benchmark_limits(sweep.rows, sweep.sample_interval * (sweep.samples - 1));
}

std::vector<BenchmarkLimit> benchmark_limits(const std::vector<SweepRow>& rows, double duration) {
  // The series: an engine variant over its time steps; the exact simulation's second integrator
  // over its tolerances (its rows come loosest first). The reference itself (error 0) is none.
  const auto series_of =
      [](const SweepRow& r) -> std::optional<std::pair<std::string, std::string>> {
    if (r.engine != "analytic") return std::pair(r.engine, r.variant);
    if (r.variant.starts_with("exact, tolerance"))
      return std::pair(r.engine, fmt::format("exact, {}", kSimulationTolerancesIntegrator));
    return std::nullopt;
  };
  std::vector<std::pair<std::string, std::string>> series;
  for (const SweepRow& r : rows)
    if (const auto s = series_of(r);
        s && std::find(series.begin(), series.end(), *s) == series.end())
      series.push_back(*s);
  std::vector<BenchmarkLimit> out;
  for (double limit : kBenchmarkLimits)
    for (const auto& [engine, variant] : series) {
      BenchmarkLimit b;
      b.engine = engine;
      b.variant = variant;
      b.limit = limit;
      const SweepRow* coarsest = nullptr;
      const SweepRow* finest = nullptr;
      for (const SweepRow& r : rows) {
        if (series_of(r) != std::pair(engine, variant)) continue;
        // Engines: the largest dt; the exact integrator: the first (loosest) row.
        // (No lambda: clang 14 cannot capture a structured binding.)
        const bool coarser = coarsest == nullptr || (engine != "analytic" && r.dt > coarsest->dt);
        if (r.status == RunStatus::ok && r.benchmark_error() <= limit && coarser) coarsest = &r;
        if (finest == nullptr || (engine == "analytic" || r.dt < finest->dt)) finest = &r;
      }
      if (coarsest) {
        b.met = true;
        b.row = *coarsest;
        b.run_cpu_seconds = coarsest->cost() * duration;
      } else if (finest) {
        b.row = *finest;
        b.why = finest->status != RunStatus::ok
                    ? fmt::format(
                          "{} at the finest {} ({} samples flagged){}", to_string(finest->status),
                          engine == "analytic" ? "tolerance" : "step", finest->flagged_samples,
                          finest->message.empty() ? "" : ": " + finest->message)
                    : fmt::format("error {:.3g} at the finest {}", finest->benchmark_error(),
                                  engine == "analytic" ? "tolerance" : "step");
      }
      out.push_back(std::move(b));
    }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The cheapest setting

namespace {

// Of rows at one time step, the least work that meets the accuracy, or nullptr: of the rows with
// the lowest work, the first (the grid's order).
const SweepRow* least_work_meeting(const std::vector<const SweepRow*>& rows,
                                   const ClassLimits& limits) {
  double lowest = std::numeric_limits<double>::infinity();
  for (const SweepRow* r : rows)
    if (r->meets(limits)) lowest = std::min(lowest, r->work());
  for (const SweepRow* r : rows)
    if (r->meets(limits) && r->work() <= lowest) return r;
  return nullptr;
}

}  // namespace

Selection select_cheapest(std::string_view engine, double accuracy_pct,
                          const std::vector<SweepRow>& rows) {
  Selection s = select_cheapest(engine, ClassLimits::uniform(accuracy_pct), rows);
  s.accuracy_pct = accuracy_pct;
  return s;
}

Selection select_cheapest(std::string_view engine, const ClassLimits& limits,
                          const std::vector<SweepRow>& rows) {
  Selection s;
  s.engine = std::string(engine);
  s.accuracy_pct = kNaN;
  std::vector<double> dts;
  for (const SweepRow& r : rows)
    if (r.engine == engine) dts.push_back(r.dt);
  std::sort(dts.begin(), dts.end(), std::greater<>());
  dts.erase(std::unique(dts.begin(), dts.end()), dts.end());
  for (double dt : dts) {
    std::vector<const SweepRow*> level;
    for (const SweepRow& r : rows)
      if (r.engine == engine && r.dt == dt) {
        level.push_back(&r);
        s.tried.push_back(r);
      }
    if (const SweepRow* best = least_work_meeting(level, limits)) {
      s.found = true;
      s.chosen = *best;
      break;
    }
  }
  return s;
}

std::string Selection::summary() const {
  if (!found)
    return fmt::format(
        "{}: no setting tried ({}) meets {:g} % of peak on every quantity class "
        "with status ok; try finer time steps (--dt)",
        engine, tried.size(), accuracy_pct);
  std::string overrides;
  for (const auto& [k, v] : chosen.settings)
    if (k == "dt" || k == "integrator" || k == "solver" || k == "formulation" || k == "erp" ||
        k == "iterations" || k == "solref")
      overrides += fmt::format(" {}={}", k, v);
  return fmt::format(
      "{}: --accuracy {:g} %: chose {} ({}) after {} runs: {:.3g} ms per {}; max % of peak "
      "position {:.3g}, velocity {:.3g}, acceleration {:.3g}{}{}",
      engine, accuracy_pct, chosen.setting_label(), overrides.empty() ? "" : overrides.substr(1),
      tried.size(), 1e3 * chosen.cost(), std::isnan(chosen.energy_pct) ? "cycle" : "simulated s",
      chosen.error(ErrorClass::position), chosen.error(ErrorClass::velocity),
      chosen.error(ErrorClass::acceleration),
      std::isnan(chosen.error(ErrorClass::force))
          ? std::string()
          : fmt::format(", force {:.3g}", chosen.error(ErrorClass::force)),
      std::isnan(chosen.energy_pct) ? std::string()
                                    : fmt::format(", energy {:.3g}", chosen.energy_pct));
}

Selection cheapest_setting(const Mechanism& mechanism, ReferenceLadder& ladder,
                           std::string_view engine, double accuracy_pct,
                           const std::vector<double>& dts, const sim::Settings& base,
                           const Progress& progress, int repeat, int jobs) {
  if (!(accuracy_pct > 0.0)) throw std::invalid_argument("the accuracy must be a positive %");
  const std::vector<GridPoint> grid =
      engine_grid(engine, dts, mechanism.dynamics.has_value(), mechanism.has_friction());
  std::vector<SweepRow> rows;
  Selection s;
  // A time step's variants at once, then the next finer step: stop at the end of the first time
  // step where a variant meets the accuracy.
  for (size_t level_start = 0; level_start < grid.size();) {
    size_t level_end = level_start + 1;
    while (level_end < grid.size() && grid[level_end].dt == grid[level_start].dt) ++level_end;
    rows.resize(level_end);
    run_jobs(
        jobs, level_end - level_start,
        [&](size_t k) {
          rows[level_start + k] = evaluate_setting(mechanism, ladder, grid[level_start + k], base);
        },
        [&](size_t k) {
          if (progress)
            progress(static_cast<int>(level_start + k + 1), static_cast<int>(grid.size()),
                     grid[level_start + k]);
        });
    retime(mechanism, ladder, rows, level_start, repeat, {}, jobs);  // the level's variants
    level_start = level_end;
    s = select_cheapest(engine, accuracy_pct, rows);
    if (s.found) break;
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// The whole sweep

SettingsSweep run_settings_sweep(const Mechanism& mechanism, const SettingsSweepOptions& options) {
  SettingsSweep out;
  out.mechanism = &mechanism;
  ReferenceLadder ladder(mechanism, options.sweep);
  out.sample_interval = ladder.interval();
  out.samples = ladder.base().trajectory.samples();
  out.dynamics = mechanism.dynamics.has_value();

  // Snap the time steps first: two requests that land on the same step run once (and every
  // coarse reference is made here, before the threads).
  std::vector<double> snapped;
  for (double dt : options.dts) {
    double s = 0.0;
    ladder.for_dt(dt, &s);
    if (std::none_of(snapped.begin(), snapped.end(),
                     [&](double t) { return std::abs(t - s) <= 1e-9 * s; }))
      snapped.push_back(s);
  }
  std::vector<GridPoint> grid;
  std::vector<std::string> not_engines;
  for (const std::string& engine : options.engines) {
    if (!find_engine(engine)) {
      not_engines.push_back(
          fmt::format("{}: not an engine ({})", engine, fmt::join(engine_names(), ", ")));
      continue;
    }
    const std::vector<GridPoint> g =
        engine_grid(engine, snapped, out.dynamics, mechanism.has_friction());
    grid.insert(grid.end(), g.begin(), g.end());
  }

  // One pool: job 0 the analytic rows, job i the grid point i - 1, each into its own slot.
  const auto unable_to_realise = [](const SweepRow& row) {
    return row.status == RunStatus::diverged && row.wall_s_per_cycle == 0.0 &&
           row.message.find("cannot realise") != std::string::npos;
  };
  std::vector<std::string> analytic_skipped;
  std::vector<std::optional<SweepRow>> runs(grid.size());
  // An engine that cannot realise the mechanism runs nothing more of it: its jobs not yet started
  // are not run (those already running are dropped below, as a serial run never ran them).
  std::mutex unable_lock;
  std::vector<std::string> unable;
  const auto is_unable = [&](const std::string& engine) {
    const std::lock_guard<std::mutex> hold(unable_lock);
    return std::find(unable.begin(), unable.end(), engine) != unable.end();
  };
  run_jobs(
      options.jobs, grid.size() + 1,
      [&](size_t k) {
        if (k == 0) {
          out.rows = analytic_rows(mechanism, options.sweep, std::max(3, options.repeat),
                                   &analytic_skipped);
          return;
        }
        const GridPoint& point = grid[k - 1];
        if (is_unable(point.engine)) return;
        SweepRow row = evaluate_setting(mechanism, ladder, point, options.base);
        if (unable_to_realise(row)) {
          const std::lock_guard<std::mutex> hold(unable_lock);
          unable.push_back(point.engine);
        }
        runs[k - 1] = std::move(row);
      },
      [&](size_t k) {
        if (k > 0 && options.progress && !is_unable(grid[k - 1].engine))
          options.progress(static_cast<int>(k), static_cast<int>(grid.size()), grid[k - 1]);
      });
  out.skipped = analytic_skipped;
  out.skipped.insert(out.skipped.end(), not_engines.begin(), not_engines.end());
  const size_t first_engine_row = out.rows.size();
  for (size_t i = 0; i < grid.size(); ++i) {
    if (!runs[i]) continue;  // not run: its engine could not realise the mechanism
    // An engine that cannot realise the mechanism: say so once, nothing more of it.
    if (unable_to_realise(*runs[i])) {
      out.skipped.push_back(grid[i].engine + ": " + runs[i]->message);
      const std::string engine = grid[i].engine;
      while (i + 1 < grid.size() && grid[i + 1].engine == engine) ++i;
      continue;
    }
    out.rows.push_back(std::move(*runs[i]));
  }
  retime(mechanism, ladder, out.rows, first_engine_row, options.repeat, options.progress,
         options.jobs);
  analyse(out);
  out.accuracy_pct = options.accuracy_pct;
  if (options.accuracy_pct) select_settings(out, options.engines, *options.accuracy_pct);
  return out;
}

void select_settings(SettingsSweep& sweep, const std::vector<std::string>& engines,
                     double accuracy_pct) {
  sweep.accuracy_pct = accuracy_pct;
  sweep.selections.clear();
  for (const std::string& engine : engines)
    if (std::any_of(sweep.rows.begin(), sweep.rows.end(),
                    [&](const SweepRow& r) { return r.engine == engine; }))
      sweep.selections.push_back(select_cheapest(engine, accuracy_pct, sweep.rows));
}

// ---------------------------------------------------------------------------------------------
// CSV and console

namespace {

std::string settings_text(const sim::Settings& s) {
  std::string text;
  for (const auto& [k, v] : s) text += fmt::format("{}{}={}", text.empty() ? "" : "; ", k, v);
  return text;
}

}  // namespace

void write_sweep_csv(const SettingsSweep& sweep, std::ostream& out) {
  out << "engine,setting,dt,wall_s_per_cycle,max_pct_position,max_pct_velocity,"
         "max_pct_acceleration,max_loop_gap,status,variant,flagged_samples,samples,"
         "pareto_position,pareto_velocity,pareto_acceleration,raw_pct_position,"
         "raw_pct_velocity,raw_pct_acceleration,settings,message,end_pct_position,"
         "end_pct_velocity,end_pct_acceleration,max_pct_energy,repeats,cpu_s_per_cycle,"
         "tip_position_error,tip_velocity_error,max_pct_force,pareto_force,raw_pct_force,"
         "end_pct_force,work,rank\n";
  // The engine's place in the ranking (sweep_ranking.h) on the row it is ranked by.
  const EngineRanking ranking = rank_engines(sweep);
  const auto rank_of = [&](const SweepRow& r) {
    for (size_t i = 0; i < ranking.engines.size(); ++i) {
      const EngineRank& e = ranking.engines[i];
      if (e.has_row && e.engine == r.engine && e.row.variant == r.variant && e.row.dt == r.dt)
        return std::to_string(i + 1);
    }
    return std::string();
  };
  for (const SweepRow& r : sweep.rows) {
    out << csv_field(r.engine) << ',' << csv_field(r.setting_label()) << ',' << csv_number(r.dt)
        << ',' << csv_number(r.wall_s_per_cycle) << ',' << csv_number(r.max_pct[0]) << ','
        << csv_number(r.max_pct[1]) << ',' << csv_number(r.max_pct[2]) << ','
        << csv_number(r.max_loop_gap) << ',' << to_string(r.status) << ',' << csv_field(r.variant)
        << ',' << r.flagged_samples << ',' << r.samples << ',' << r.pareto[0] << ',' << r.pareto[1]
        << ',' << r.pareto[2] << ',' << csv_number(r.raw_pct[0]) << ',' << csv_number(r.raw_pct[1])
        << ',' << csv_number(r.raw_pct[2]) << ',' << csv_field(settings_text(r.settings)) << ','
        << csv_field(with_series_note(sweep, r, r.message)) << ',' << csv_number(r.end_pct[0])
        << ',' << csv_number(r.end_pct[1]) << ',' << csv_number(r.end_pct[2]) << ','
        << csv_number(r.energy_pct) << ',' << r.repeats << ',' << csv_number(r.cpu_s_per_cycle)
        << ',' << csv_number(r.tip_position_error) << ',' << csv_number(r.tip_velocity_error) << ','
        << csv_number(r.max_pct[3]) << ',' << r.pareto[3] << ',' << csv_number(r.raw_pct[3]) << ','
        << csv_number(r.end_pct[3]) << ',' << csv_number(r.work()) << ',' << rank_of(r) << '\n';
  }
}

void write_sweeps_csv(const std::vector<SweptDefinition>& sweeps, std::ostream& out) {
  for (size_t k = 0; k < sweeps.size(); ++k) {
    std::ostringstream one;
    write_sweep_csv(*sweeps[k].sweep, one);
    const std::string text = one.str();
    const std::string lead = csv_field(sweeps[k].path) + ',';
    // Each record of one definition's CSV behind its path (a quoted field may hold a newline);
    // the header once.
    bool quoted = false, header = true, start = true;
    for (char ch : text) {
      if (start && !(header && k > 0)) out << (header ? std::string("definition,") : lead);
      start = false;
      if (ch == '"') quoted = !quoted;
      if (!(header && k > 0)) out << ch;
      if (ch == '\n' && !quoted) {
        header = false;
        start = true;
      }
    }
  }
}

void print_sweep(const SettingsSweep& sweep, std::FILE* out) {
  const Mechanism& m = *sweep.mechanism;
  fmt::print(out, "{}: {} settings; reference {} samples every {:.4g} s\n", m.name,
             sweep.rows.size(), sweep.samples, sweep.sample_interval);
  if (sweep.dynamics)  // the errors at the end of the run and of the energy balance too
    fmt::print(out, "{:<8} {:<48} {:>10} {:>12} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {}\n",
               "engine", "setting", "dt [s]", "cpu s/sim s", "pos %", "end pos %", "vel %", "acc %",
               "force %", "energy %", "status");
  else
    fmt::print(out, "{:<8} {:<48} {:>10} {:>12} {:>10} {:>10} {:>10} {:>10} {:>10} {}\n", "engine",
               "setting", "dt [s]", "cpu s/cycle", "pos %", "vel %", "acc %", "force %", "gap [m]",
               "status");
  // A value that was not measured (no comparable sample, no forces read) is a dash.
  const auto value = [](double v) {
    return std::isnan(v) ? std::string("-") : fmt::format("{:.3g}", v);
  };
  for (const SweepRow& r : sweep.rows) {
    const bool on_front = std::any_of(r.pareto.begin(), r.pareto.end(), [](bool b) { return b; });
    const std::string front = on_front ? " *" : "";
    const std::string status = with_series_note(
        sweep, r,
        r.status == RunStatus::flagged ? fmt::format("flagged ({} samples)", r.flagged_samples)
        : r.status == RunStatus::ok && r.flagged_samples > 0
            ? fmt::format("ok ({} samples singular)", r.flagged_samples)
            : std::string(to_string(r.status)));
    const std::string dt = std::isnan(r.dt) ? std::string("-") : format_dt(r.dt);
    if (sweep.dynamics)
      fmt::print(out,
                 "{:<8} {:<48} {:>10} {:>12.4g} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {}{}\n",
                 r.engine, r.variant, dt, r.cost(), value(r.max_pct[0]), value(r.end_pct[0]),
                 value(r.max_pct[1]), value(r.max_pct[2]), value(r.max_pct[3]), value(r.energy_pct),
                 status, front);
    else
      fmt::print(out, "{:<8} {:<48} {:>10} {:>12.4g} {:>10} {:>10} {:>10} {:>10} {:>10.3g} {}{}\n",
                 r.engine, r.variant, dt, r.cost(), value(r.max_pct[0]), value(r.max_pct[1]),
                 value(r.max_pct[2]), value(r.max_pct[3]), r.max_loop_gap, status, front);
  }
  fmt::print(out, "(* on the Pareto front of error against cost for at least one class)\n");
  fmt::print(out,
             "\nObserved order of convergence in dt (least-squares slope, non-saturated "
             "points):\n");
  for (const OrderRow& o : sweep.orders) {
    fmt::print(out, "  {:<8} {:<48}", o.engine, o.variant);
    for (ErrorClass c : kErrorClasses) {
      const ConvergenceFit& f = o.fit[index_of(c)];
      fmt::print(out, " {} {}", to_string(c),
                 std::isnan(f.order) ? std::string("n/a")
                                     : fmt::format("{:.2f} ({} pts)", f.order, f.points));
    }
    fmt::print(out, "{}\n", o.not_falling.empty() ? "" : "; " + o.not_falling_text());
  }
  if (!sweep.limits.empty()) {
    fmt::print(out,
               "\nIFToMM accuracy limits: the largest |difference| of {}'s x, y [m] and vx, vy "
               "[m/s] over the run; per series, the largest step (the exact integrator: the "
               "loosest tolerance) that meets each, and the CPU time of the whole run:\n",
               benchmark_tip_point(m).value_or("?"));
    for (const BenchmarkLimit& b : sweep.limits)
      fmt::print(out, "  {:<8} {:<40} {:>6g}  {}\n", b.engine, b.variant, b.limit,
                 benchmark_limit_text(b));
  }
  for (const std::string& s : sweep.skipped) fmt::print(out, "not run: {}\n", s);
  for (const Selection& s : sweep.selections) fmt::print(out, "{}\n", s.summary());
  const EngineRanking ranking = rank_engines(sweep);
  fmt::print(out, "\nEngines ranked ({}):\n", ranking.rule);
  for (size_t i = 0; i < ranking.engines.size(); ++i)
    fmt::print(out, "  {}. {}\n", i + 1, ranking.engines[i].text());
}

std::string benchmark_limit_text(const BenchmarkLimit& b) {
  if (!b.met) return "not met: " + b.why;
  const std::string at = b.engine == "analytic" ? b.row.variant.substr(b.row.variant.find(',') + 2)
                                                : fmt::format("dt {} s", format_dt(b.row.dt));
  return fmt::format("met at {}: error {:.3g}, CPU {:.3g} s for the run", at,
                     b.row.benchmark_error(), b.run_cpu_seconds);
}

}  // namespace crosslink::methods
