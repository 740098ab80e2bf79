// The comparison of every method against the reference (analytic Newton), channel by channel,
// and of every method against the definition's [[reference]] values. Metrics: metrics.h;
// tolerances: tolerance.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"
#include "compare/derived.h"
#include "compare/method_run.h"
#include "compare/metrics.h"
#include "compare/tolerance.h"

namespace crosslink::compare {

enum class Verdict { pass, fail, not_applicable };
std::string_view to_string(Verdict verdict);

// One channel of one method against the reference.
struct ChannelResult {
  std::string method;
  ChannelMetrics metrics;
  double tolerance = 0.0;  // [% of peak]
  Verdict verdict = Verdict::not_applicable;
  bool prescribed = false;  // the definition fixes its values (prescribed()): counted apart
};

// Whether the definition itself fixes a channel's values, so that a method agrees on it by
// construction: every channel of a point on the ground; the angle, omega and alpha of a link a
// prismatic joint holds to the ground; and, following a motion law (not a dynamics case), the
// driven coordinate's own: the angle, omega and alpha of the link whose angle against the ground
// is driven, the s, sdot and sddot of a driven slider.
bool prescribed(const Mechanism& mechanism, std::string_view channel);

// A [[reference]] row of the definition with every method's value at its driver value.
struct ReferenceRow {
  Reference reference;  // the printed value (SI)
  double exact = 0.0;   // analytic Newton at exactly reference.driver_value (SI)
  bool exact_ok = false;
  struct Value {
    std::string method;
    double value = 0.0;         // SI
    bool interpolated = false;  // between two sweep samples (linear)
  };
  std::vector<Value> values;  // every available method that computes the channel
  // Values below this (SI) are zero to round-off, 1e-9 of the quantity's characteristic scale
  // (metrics.h): a % difference against them means nothing and is not given.
  double zero = 0.0;
  // The course's "% difference" of `value` against `against` (SI; angles in [0, 2 pi)), or NaN
  // where `against` is a round-off zero.
  double percent(double value, double against) const;
  // The row's verdict when it is judged (Reference::judged()): the printed value within its
  // tolerance of the exact one (no % against a round-off zero), or within its printed rounding;
  // without an exact value it does not hold. nullopt: shown, not judged.
  std::optional<bool> holds() const;
};

// A failing engine rerun at half its time step (crosslink compare): how a failing channel's
// difference changes (of the least differentiated class failing, its largest) tells an error of
// the engine's discretisation, which falls with the step, from one that does not (a modelling
// difference, the reference, a singular position).
struct StepProbe {
  std::string method;
  double dt = 0.0, half_dt = 0.0;    // [s]
  bool ok = false;                   // the half-step run completed
  std::string message;               // why it did not
  std::string channel;               // the failing channel with the largest max % of peak
  double pct = 0.0, half_pct = 0.0;  // its max % of peak at dt and at half_dt
  // log2(pct / half_pct): about 1 at first order, 2 at second, 0 when the step is not the cause.
  // NaN where it is not a number (a difference of 0 at either step: log of 0 or of 0/0).
  double order() const {
    const double o = std::log2(pct / half_pct);
    return std::isfinite(o) ? o : NAN;
  }
};

struct Comparison {
  const Mechanism* mechanism = nullptr;
  std::vector<MethodRun> methods;  // methods[0]: the reference ("analytic")
  std::vector<ChannelResult> channels;
  std::vector<ReferenceRow> references;
  DerivedResults derived;  // the [[derived]] quantities, exact and every method's
  // Methods asked for that ran but failed (diverged, wrong sample count): they fail the whole.
  std::vector<std::string> failed_methods;
  std::vector<StepProbe> step_probes;  // filled by the caller that reruns (crosslink compare)

  const MethodRun& reference() const { return methods.front(); }
  const MethodRun* method(std::string_view name) const;
  bool pass() const;
  // No method but the reference ran (asked for alone, or every other one not run) and no
  // [[reference]] value is judged: nothing was compared, so there is no verdict to pass (values
  // shown beside the exact ones are no verdict).
  bool nothing_compared() const {
    return channels.empty() && failed_methods.empty() && derived.checks.empty() &&
           std::none_of(references.begin(), references.end(),
                        [](const ReferenceRow& r) { return r.reference.judged(); });
  }
  int reference_failures() const;  // judged [[reference]] rows that do not hold
  int failures() const;            // channels with verdict fail
  // How many channels have each verdict, the computed ones and the prescribed ones apart.
  struct Counts {
    int pass = 0, fail = 0, not_applicable = 0;
    int total() const { return pass + fail + not_applicable; }
  };
  Counts counts(bool prescribed) const;
  // "N channel comparisons: p pass, f fail, n n/a; M more of values the definition prescribes
  // (...): ..." as the console, HTML report and JSON say it.
  std::string counts_text() const;
  // "; N [[derived]] comparisons: p pass, f fail, n n/a", or "" without [[derived]] checks.
  std::string derived_counts_text() const;
  // "; N [[reference]] value(s) judged: p hold, f fail" for the judged rows and "; N [[reference]]
  // value(s) beside the exact ones, k within their printed rounding (shown, not judged)" for the
  // others, or "" without [[reference]] rows: a verdict on no channel names what it showed.
  std::string references_counts_text() const;
};

// What the comparator judges against besides the reference's samples, solved before it is called
// (the exact methods solve, the comparator judges: methods::exact_values makes them): the
// [[derived]] quantities located on the exact solution, and each [[reference]] row's exact value
// at its driver value (none for a row of a derived quantity, or where no pose is solved).
struct ExactValues {
  std::vector<DerivedValue> derived;              // Mechanism::derived order
  std::vector<std::optional<double>> references;  // Mechanism::references order
};

// Compares every available method in `methods` (the first is the reference) channel by
// channel, their [[derived]] quantities against `exact`'s, and fills the [[reference]] rows.
Comparison compare_methods(const Mechanism& mechanism, std::vector<MethodRun> methods,
                           const Tolerances& tolerances, const ExactValues& exact);

// The value of one channel of `trajectory` at a driver value: the sample on it, or a linear
// interpolation between the two samples around it (angular drivers modulo 2 pi). nullopt when
// the value lies outside the sweep or the channel is unknown.
std::optional<double> value_at(const Trajectory& trajectory, std::string_view channel,
                               double driver_value, bool angular, bool* interpolated = nullptr);

// The reference at a channel's worst sample k, against its whole sweep: what a failure there is
// read against (an engine's error grows as the constraint Jacobian's conditioning falls, next to
// a singular position).
struct WorstContext {
  double rcond = NAN;         // the reference's at sample k (NaN: it keeps none)
  double median_rcond = NAN;  // over its usable samples
  // Its singular position (an event of kind singular: dead point, toggle, change point, a
  // parallel mechanism's inverse or direct singularity) nearest to sample k, or nullptr.
  const Trajectory::Event* nearest_singular = nullptr;
  // From sample k to it [driver unit, or s with `in_time`]: > 0 when it comes later.
  double distance = 0.0;
};
WorstContext worst_context(const Trajectory& reference, int k, bool in_time);

}  // namespace crosslink::compare
