// Speed against accuracy: every engine over a grid of its settings (time step, integrator,
// solver, constraint softness or ERP), each setting compared with the exact Newton sweep (a
// dynamics case: the exact simulation) through compare_methods() (the metrics of metrics.h,
// nothing re-implemented), with its wall time per simulated cycle (per simulated second for a
// dynamics case), the median of repeated runs; the observed order of convergence in dt; the
// Pareto front of error against work; and the least-work setting that meets an accuracy asked
// for. The front and the pick weigh the work (the model evaluations the engine reports, fixed by
// the time step and the integrator), never a timing: CPU times moved by 17 to 66 % between
// identical sweeps on this shared machine, so any rule on them moved the front; with the work two
// identical sweeps draw the same front and pick the same setting. See docs/sweep.md.
//
// Quantity classes of a row (max over the channels of the class, usable samples only):
//   position      "position" and "angle" channels (both are position-level quantities; an angle's
//                 peak is pi, metrics.h)
//   velocity      omega, vx, vy, v, sdot
//   acceleration  alpha, ax, ay, a, sddot
//   force         the driver's torque or force, the joints' reactions, the shaking force and
//                 moment (kinetostatics; a dynamics case's joint forces), where the engine reads
//                 them: NaN where it does not (MuJoCo, a slide on a floating driven link's path),
//                 which no pick holds against
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/reference/sweep.h"
#include "compare/comparison.h"
#include "compare/report.h"
#include "compare/tolerance.h"
#include "methods/engines.h"
#include "methods/registry.h"

namespace crosslink::methods {

// The comparator's vocabulary, which the sweep scores every run in.
using compare::ChannelResult;
using compare::compare_methods;
using compare::Comparison;
using compare::csv_field;
using compare::csv_number;
using compare::HtmlOptions;
using compare::Tolerances;
using compare::Verdict;

// The classes a sweep row reports, in CSV column order.
enum class ErrorClass { position, velocity, acceleration, force };
constexpr std::array<ErrorClass, 4> kErrorClasses = {ErrorClass::position, ErrorClass::velocity,
                                                     ErrorClass::acceleration, ErrorClass::force};
std::string_view to_string(ErrorClass c);
// The class a channel's quantity belongs to (angle -> position, torque -> force); none for
// energy (its own column).
std::optional<ErrorClass> error_class_of(Quantity q);

// One value per class (ErrorClass order), NaN where none was measured.
using ClassValues = std::array<double, kErrorClasses.size()>;
constexpr ClassValues kNoValues = {
    std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
    std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};

// What a row must meet: a limit per class [% of peak] (ErrorClass order; the force class only
// where the engine reads forces) and on the energy balance [% of the energy scale] (a dynamics
// case). `--accuracy X` is X on every class and on the energy.
struct ClassLimits {
  ClassValues pct = kNoValues;
  double energy_pct = std::numeric_limits<double>::quiet_NaN();
  static ClassLimits uniform(double pct) { return {{pct, pct, pct, pct}, pct}; }
};

// One setting of one engine: every override passed to the engine, dt included.
struct GridPoint {
  std::string engine;      // an engine_names() entry
  std::string variant;     // everything but dt, e.g. "Euler/Newton": the family a dt series forms
  double dt = 0.0;         // requested time step [s] (snapped to the samples, see ReferenceLadder)
  sim::Settings settings;  // engine overrides except dt (the sweep adds the snapped dt)
};

// The variants a sweep tries for an engine (names and overrides), the engine's default first;
// for a dynamics case (`dynamics`) the engine's forward-dynamics variants (docs/sweep.md): the
// engine table's (methods/engines.h). MuJoCo: integrators Euler / implicit / RK4 (Newton solver),
// solvers CG / PGS (Euler), loop softness: MuJoCo's own default solref "0.02 1" / solimp "0.9
// 0.95 0.001", and the engine-notes (2 dt, 0.5). Bullet: formulation rigid / multibody, solver
// MLCP Dantzig / sequential impulse (10 and 100 iterations), ERP 1 / 0.2.
// A mechanism with joint friction (`friction`) adds the engine's friction variants.
std::vector<Variant> engine_variants(std::string_view engine, bool dynamics = false,
                                     bool friction = false);

// The default time steps: 1e-2, 3e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5 s (over two decades).
std::vector<double> default_time_steps();
// The time steps the cheapest-setting search of `crosslink compare --accuracy` tries, coarse to
// fine: the sample interval h [s] divided by 1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128
// (every one puts samples on step boundaries of the comparison's own reference).
std::vector<double> accuracy_time_steps(double interval);

// Every (time step, variant) of an engine, coarse to fine, the variants in engine_variants()
// order within one time step.
std::vector<GridPoint> engine_grid(std::string_view engine, const std::vector<double>& dts,
                                   bool dynamics = false, bool friction = false);

// Reference sweeps whose samples fall on step boundaries. The base sweep (the mechanism's
// default grid, or SweepOptions::step) has sample interval h. A time step dt <= h is snapped to
// h / round(h / dt) and uses the base sweep; a dt > h is snapped to m h, m = round(dt / h), and
// uses a sweep with every m-th driver value (step m times the base step), built once and kept.
// A dynamics case's reference is its simulation at the case's interval h; a dt > h is h (an
// engine never steps past a sample).
class ReferenceLadder {
 public:
  ReferenceLadder(const Mechanism& mechanism, const SweepOptions& options);
  // With the base reference already run (run_reference(mechanism, options)).
  ReferenceLadder(const Mechanism& mechanism, const SweepOptions& options, MethodRun base);
  const MethodRun& base() const { return *base_; }
  double interval() const { return interval_; }  // h [s]
  // The reference for a requested dt and the snapped dt [s]. Safe to call from the sweep's
  // threads (a coarse reference is made once, under a lock; what it returns stays in place).
  const MethodRun& for_dt(double dt, double* snapped);
  // The exact values a comparison against `reference`, one for_dt returned, judges with
  // (exact_values), solved once with it.
  const compare::ExactValues& exact_of(const MethodRun& reference);

 private:
  const Mechanism& mechanism_;
  SweepOptions options_;
  std::unique_ptr<MethodRun> base_;
  double interval_ = 0.0, base_step_ = 0.0;
  std::map<long, std::unique_ptr<MethodRun>> coarse_;  // by m
  std::map<const MethodRun*, compare::ExactValues> exact_;
  std::mutex coarse_lock_;
};

enum class RunStatus {
  ok,        // every sample the reference can use, the engine could use too
  flagged,   // the engine flagged samples the reference did not (loop_gap, singular, diverged)
  diverged,  // the run did not finish (NaN, runaway, lost driver, or could not be built)
};
std::string_view to_string(RunStatus s);

// One engine setting (or one analytic method) against the reference.
struct SweepRow {
  std::string engine;   // an engine_names() entry, or "analytic" for the exact methods
  std::string variant;  // grid variant, or "newton" / "dyads"
  double dt = std::numeric_limits<double>::quiet_NaN();  // in force [s]; NaN for analytic
  sim::Settings settings;         // every setting in force (as the engine reported it)
  sim::Settings overrides;        // what was passed to the engine (base, variant, dt): reruns it
  double wall_s_per_cycle = 0.0;  // stepping (or solving) time per driver cycle [s] (a dynamics
                                  // case: per simulated second), the median of `repeats` runs
  // The same in CPU time of the stepping thread (RunCost::cpu_seconds_per_cycle), the median of
  // `repeats` runs: the cost fronts, picks and charts use (cost()).
  double cpu_s_per_cycle = 0.0;
  int repeats = 1;
  // Max % of peak per class; NaN when no sample could be compared (force: or the run reads no
  // forces).
  ClassValues max_pct = kNoValues;
  // The same over every sample the engine recorded, flagged ones included (only a run that
  // flagged samples or diverged part-way has one): how far off the run is where it collapses.
  ClassValues raw_pct = kNoValues;
  // Dynamics cases: the % of peak per class at the end of the run (the last sample both call
  // usable; the benchmarks' "error at the end"), and the max % of the energy scale over the
  // energy channels (an --accuracy pick must meet it too). NaN otherwise.
  ClassValues end_pct = kNoValues;
  double energy_pct = std::numeric_limits<double>::quiet_NaN();
  // Dynamics cases: the IFToMM benchmarks' error (A01, A02; benchmark_tip_errors()): the largest
  // difference from the reference of the driven link's tip, per coordinate of its position
  // [length unit] and of its velocity [length unit/s]. NaN where the case has no tip point.
  double tip_position_error = std::numeric_limits<double>::quiet_NaN();
  double tip_velocity_error = std::numeric_limits<double>::quiet_NaN();
  double max_loop_gap = 0.0;  // largest cut-joint gap over all samples [m]
  RunStatus status = RunStatus::ok;
  int flagged_samples = 0;  // samples usable in the reference but not in the run
  int samples = 0;
  std::string message;                                 // the engine's notes or why it diverged
  std::array<bool, kErrorClasses.size()> pareto = {};  // on the engines' front, per class

  double error(ErrorClass c) const { return max_pct[static_cast<size_t>(c)]; }
  // The IFToMM error: the larger of the tip's position and velocity errors (NaN: none).
  double benchmark_error() const;
  // The cost: the CPU time per cycle, or the wall time where none was measured.
  double cost() const { return cpu_s_per_cycle > 0.0 ? cpu_s_per_cycle : wall_s_per_cycle; }
  // The model evaluations the engine reported per step it took (RunCost; MuJoCo's RK4 4, its
  // Euler and implicit 1, Bullet 1). NaN: the run took no step, or an analytic row.
  double evaluations_per_step = std::numeric_limits<double>::quiet_NaN();
  // The work: the engine's model evaluations per simulated second at the row's time step, its
  // evaluations per step over dt. The same in every run, it is what the front and the pick
  // weigh. NaN for the analytic rows and a run that took no step.
  double work() const;
  // "dt=0.001 integrator=Euler solver=Newton" (engine rows), "newton" (analytic).
  std::string setting_label() const;
  // Whether the row meets `accuracy_pct` on every class with status ok (forces where read).
  bool meets(double accuracy_pct) const;
  // The same against a limit per class (and on the energy where the row has one).
  bool meets(const ClassLimits& limits) const;
};

// The IFToMM benchmarks' error measure (A01 and A02: "the time-history of the position and
// velocity of point B0 (x and y coordinates)", 1e-1 low and 1e-3 high precision, at the
// benchmark's output steps; docs/dynamics.md): the tip of the driven link, the driver's `to` point
// (A01's P1, A02's B0). Over every sample where both runs have values (the engine's `singular`
// samples included: the benchmark counts every output step), the largest |difference| of x, y
// [length unit] and of vx, vy [length unit/s]. {NaN, NaN} when the driver names no tip point (or
// there are several drivers) or no sample has values.
std::optional<std::string> benchmark_tip_point(const Mechanism& mechanism);
std::array<double, 2> benchmark_tip_errors(const Mechanism& mechanism, const Trajectory& reference,
                                           const Trajectory& run);

// Runs one grid point against the ladder's reference for its dt, once. `base` overrides come
// first (e.g. a --set perturb_link), the grid point's after.
SweepRow evaluate_setting(const Mechanism& mechanism, ReferenceLadder& ladder,
                          const GridPoint& point, const sim::Settings& base = {});

// Progress of a long run: (index from 1, total, the grid point about to run).
using Progress = std::function<void(int, int, const GridPoint&)>;

// The cost of rows[first..] as the median of `repeat` runs (the errors are the same every run):
// the rows already run once are run `repeat` - 1 times more, in turn (every row once per
// round), so that a burst of load on the machine falls on one run of many settings, which the
// median drops, rather than on every run of one setting. A diverged row is not rerun.
void retime(const Mechanism& mechanism, ReferenceLadder& ladder, std::vector<SweepRow>& rows,
            size_t first, int repeat, const Progress& progress = {}, int jobs = 1);

// The analytic methods as rows: Newton (error 0 by definition: it is the reference) and dyads
// (errors against Newton), their cost from timing their sweeps (median of `repeat`). A method
// that cannot solve the mechanism is left out and, with `skipped`, says why there. A dynamics
// case: the exact simulation (error 0) and its second integrator (dopri5) at looser tolerances
// (kSimulationTolerances), against it.
constexpr std::array<double, 4> kSimulationTolerances = {1e-4, 1e-6, 1e-8, 1e-10};
constexpr const char* kSimulationTolerancesIntegrator = "dopri5";
std::vector<SweepRow> analytic_rows(const Mechanism& mechanism, const SweepOptions& options,
                                    int repeat = 3, std::vector<std::string>* skipped = nullptr);

// Two errors within this fraction of each other are the same error: settings of one family
// (MuJoCo's Euler with the Newton, CG or PGS solver) differ in error by 2 %, and the front does
// not separate them on that.
constexpr double kErrorTie = 0.1;

// Pareto front of (cost, error), both minimised: point i is on the front when it is eligible
// and no other eligible point j dominates it: cost_j <= cost_i, error_j <= (1 + error_tie)
// error_i, and cost_j < cost_i or (1 + error_tie) error_j < error_i. Ineligible points (or
// non-finite values) are never on it. The sweep's cost here is the work (SweepRow::work()),
// exact, so only errors have a tie.
std::vector<bool> pareto_front(const std::vector<double>& cost, const std::vector<double>& error,
                               const std::vector<bool>& eligible, double error_tie = 0.0);

// Observed order of convergence p in error ~ C dt^p: least-squares slope of log error against
// log dt over the non-saturated points. From coarse to fine, a point is left out when
//   - it is not finite, or not above zero, or its error is >= `saturation_pct` (the run has not
//     reached its asymptotic range or has collapsed); or
//   - it lies on the floor: from the first pair whose local order log(e1/e2)/log(dt1/dt2) is
//     below `floor_order` on, the finer points stop improving (round-off, a solver tolerance).
struct ConvergenceFit {
  double order = std::numeric_limits<double>::quiet_NaN();  // NaN with fewer than 2 points
  int points = 0;                                           // points in the fit
  double dt_max = 0.0, dt_min = 0.0;                        // range fitted [s]
  std::vector<bool> used;                                   // per input point
};
ConvergenceFit convergence_order(const std::vector<double>& dt, const std::vector<double>& error,
                                 double saturation_pct = 10.0, double floor_order = 0.5);

// Whether an error series still falls as its step shrinks: of its finite points, the error at the
// smallest dt is below the error at the next smallest by more than kErrorTie. A series whose
// error stays or grows there (MuJoCo RK4's velocity and acceleration against a per-step driver
// target, docs/sweep.md) does not: the finer step bought nothing. True with fewer than two finite
// points (nothing to say).
bool error_falls(const std::vector<double>& dt, const std::vector<double>& error);

// The order of one (engine, variant) series per class.
struct OrderRow {
  std::string engine, variant;
  std::array<ConvergenceFit, kErrorClasses.size()> fit;  // ErrorClass order
  // The classes whose error over the series' rows with status ok does not fall (error_falls).
  std::vector<ErrorClass> not_falling;
  // "velocity, acceleration error does not fall as dt shrinks", or empty.
  std::string not_falling_text() const;
};

// The cheapest setting of one engine meeting an accuracy, searched from coarse to fine: every
// variant at the coarsest time step, then the next finer step, stopping at the first time step
// where some variant meets the accuracy on every class with status ok; of those, the cheapest.
struct Selection {
  std::string engine;
  double accuracy_pct = 0.0;
  bool found = false;
  SweepRow chosen;              // when found
  std::vector<SweepRow> tried;  // every row run, in order
  std::string summary() const;  // one line: what was chosen and what it costs, or why none
};

// The selection rule over rows already run: time steps from coarse to fine, the first where a
// row of `engine` meets the accuracy; of that time step's rows meeting it, the least work, and
// among equals the earlier row (the grid's variant order, the engine's default first).
Selection select_cheapest(std::string_view engine, double accuracy_pct,
                          const std::vector<SweepRow>& rows);
// The same rule against a limit per class (Selection::accuracy_pct: NaN).
Selection select_cheapest(std::string_view engine, const ClassLimits& limits,
                          const std::vector<SweepRow>& rows);

Selection cheapest_setting(const Mechanism& mechanism, ReferenceLadder& ladder,
                           std::string_view engine, double accuracy_pct,
                           const std::vector<double>& dts, const sim::Settings& base = {},
                           const Progress& progress = {}, int repeat = 1, int jobs = 1);

// The IFToMM accuracy limits in the benchmark's error measure (benchmark_error()).
constexpr std::array<double, 2> kBenchmarkLimits = {1e-1, 1e-3};

// Where one series meets one IFToMM limit: an engine variant over its time steps, or the exact
// simulation's second integrator over its tolerances (engine "analytic", variant "exact").
struct BenchmarkLimit {
  std::string engine, variant;
  double limit = 0.0;
  bool met = false;
  // Met: the coarsest row meeting it (status ok, benchmark error at most the limit): the largest
  // time step, or the loosest tolerance. Not met: the series' finest row, for the reason.
  SweepRow row;
  double run_cpu_seconds = std::numeric_limits<double>::quiet_NaN();  // met: over the whole run
  std::string why;  // not met: the finest row's status and error
};

// Every series' place against every limit, in row order (analyse() fills it for a dynamics case
// whose driver names a tip point). `duration`: the simulated time of one run [s].
std::vector<BenchmarkLimit> benchmark_limits(const std::vector<SweepRow>& rows, double duration);
// "met at dt 0.001 s: error 3.1e-4, CPU 0.021 s for the run", or "not met: ..." (console, HTML).
std::string benchmark_limit_text(const BenchmarkLimit& b);

struct SettingsSweepOptions {
  std::vector<std::string> engines = engine_names();  // every engine
  std::vector<double> dts = default_time_steps();
  SweepOptions sweep;                  // the reference's grid
  sim::Settings base;                  // overrides applied to every engine run
  int repeat = 1;                      // median of N runs per setting (the command: 3)
  std::optional<double> accuracy_pct;  // also select the cheapest setting per engine
  Progress progress;
  int jobs = 1;  // threads the settings and repeats run over (methods/jobs.h)
};

struct SettingsSweep {
  const Mechanism* mechanism = nullptr;
  std::vector<SweepRow> rows;  // analytic rows first, then every engine's grid
  std::vector<OrderRow> orders;
  std::vector<Selection> selections;   // with accuracy_pct
  std::optional<double> accuracy_pct;  // --accuracy: the selections' and the ranking's
  std::vector<std::string> skipped;    // engines not built or unable to realise the mechanism
  double sample_interval = 0.0;        // base reference [s]
  int samples = 0;                     // base reference
  bool dynamics = false;               // a dynamics case: costs per simulated second, end errors
  std::vector<BenchmarkLimit> limits;  // a dynamics case with a tip point: the IFToMM limits
};

// The whole sweep: analytic rows, every engine's grid, orders, Pareto fronts, selections.
SettingsSweep run_settings_sweep(const Mechanism& mechanism, const SettingsSweepOptions& options);

// `text` (a row's status or message) with what the series of `row` says of it
// (OrderRow::not_falling_text()) after a "; ", where it says something.
std::string with_series_note(const SettingsSweep& sweep, const SweepRow& row, std::string text);

// Fills orders and pareto flags from rows (run_settings_sweep calls it).
void analyse(SettingsSweep& sweep);
// The cheapest setting of each engine of `engines` that has rows (select_cheapest), in that
// order, into sweep.selections (run_settings_sweep calls it; so does `crosslink merge`).
void select_settings(SettingsSweep& sweep, const std::vector<std::string>& engines,
                     double accuracy_pct);

// One row per setting: engine, setting, dt, wall_s_per_cycle, max_pct_position,
// max_pct_velocity, max_pct_acceleration, max_loop_gap, status, then variant, flagged_samples,
// samples, pareto_position, pareto_velocity, pareto_acceleration, raw_pct_position,
// raw_pct_velocity, raw_pct_acceleration, settings, message, end_pct_position,
// end_pct_velocity, end_pct_acceleration, max_pct_energy, repeats, cpu_s_per_cycle,
// tip_position_error, tip_velocity_error, max_pct_force, pareto_force, raw_pct_force,
// end_pct_force, work, rank (sweep_ranking.h: the engine's place on the row it is ranked by).
// SI units.
void write_sweep_csv(const SettingsSweep& sweep, std::ostream& out);

// The self-contained HTML page (the comparator's page frame and chart scripts, report.h).
void write_sweep_html(const SettingsSweep& sweep, const HtmlOptions& options, std::ostream& out);

// One page of several definitions' sweeps (`crosslink sweep` over several files, `crosslink
// merge`): a list of them, then each one's sections as write_sweep_html writes them.
struct SweptDefinition {
  std::string path;  // as the command was given it
  const SettingsSweep* sweep = nullptr;
};
void write_sweeps_html(const std::vector<SweptDefinition>& sweeps, const HtmlOptions& options,
                       std::ostream& out);

// The CSV of several definitions' sweeps: write_sweep_csv's columns after a first, `definition`
// (the path as given), the definitions in order.
void write_sweeps_csv(const std::vector<SweptDefinition>& sweeps, std::ostream& out);

// Console summary: the table, orders and selections.
void print_sweep(const SettingsSweep& sweep, std::FILE* out);

}  // namespace crosslink::methods
