#include "methods/solve.h"

#include <fmt/format.h>

#include <stdexcept>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/units_text.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/trust.h"

namespace crosslink::methods {

Solution solve(const Mechanism& m, const SolveOptions& options) {
  if (options.method != "auto" && options.method != "newton" && options.method != "dyads")
    throw std::invalid_argument(
        fmt::format("method '{}': one of auto, newton or dyads", options.method));
  const bool single = options.at.has_value();
  const bool reverse = options.sweep.at_limit == SweepOptions::AtLimit::reverse;
  const double at = single ? *options.at : 0.0;
  if (single)
    check_solve_at_work(m, at, options.sweep, options.limits);
  else
    check_sweep_work(m, options.sweep, options.limits);
  Solution out;
  Trajectory& t = out.trajectory;
  t = single ? solve_at(m, at, options.sweep) : sweep(m, options.sweep);
  if (single && t.status[0] == PoseStatus::cannot_assemble) {
    // No pose exists: the range `check` finds where it is known.
    std::string where;
    if (!m.axis().timed() && m.swept().law.kind == MotionLaw::Kind::constant_speed &&
        !m.at_rest()) {
      const AssemblingRange range = assembling_range(m, options.sweep);
      if (range.unknown.empty() && !range.full_cycle && range.lower < range.upper)
        where = fmt::format(
            ": outside the driver's assembling range, {}, as `crosslink check` reports it",
            range.explain(m));
    }
    throw DefinitionError(
        {Diagnostic{start_where(m),
                    fmt::format("cannot_assemble at {}{}", sweep_position_text(m, at, 6), where)}});
  }
  // [[derived]] quantities, located on the Newton sweep (its events hold the toggles).
  if (!single) out.derived = derived_exact(m, t);
  // Closed-form dyads at the same driver values, when asked for (or, for auto, when possible).
  // Reversing at a toggle revisits driver values on the other assembly mode: the traced Newton
  // sweep follows that; auto keeps it.
  const Decomposition decomposition =
      reverse && options.method != "dyads" ? Decomposition{} : decompose(m);
  if (options.method == "dyads" && !decomposition.complete)
    throw std::invalid_argument("method dyads: the chain does not decompose into dyads: " +
                                decomposition.reason);
  out.method = "newton (asked for)";
  if (decomposition.complete) {
    // The dyads march from the drawn position too: to the pose solve_at solved, whole turns of a
    // driver that turns fully nearer the start.
    const SkippedTurns skip = single ? skipped_turns(m, at, options.sweep) : SkippedTurns{};
    // (Newton's own sample is shifted for the dyads' grid and back, not copied.)
    const auto swept = static_cast<Eigen::Index>(m.axis().driver);  // when skip.turns != 0
    if (skip.turns != 0) t.driver_values(0, swept) -= skip.driver_shift();
    Trajectory closed = dyad_sweep(m, t, options.method != "newton");
    if (skip.turns != 0) t.driver_values(0, swept) += skip.driver_shift();
    skip.move_on(m, at, closed);
    // The two exact methods check each other (analytic/reference/trust.h): a sample they disagree
    // on is flagged with the reason, whichever of them is returned.
    cross_check(m, t, closed);
    if (options.method != "newton") {
      for (int k = 0; k < t.samples(); ++k)
        if (t.status[static_cast<size_t>(k)] == PoseStatus::exact_methods_disagree &&
            usable(closed.status[static_cast<size_t>(k)]))
          closed.status[static_cast<size_t>(k)] = PoseStatus::exact_methods_disagree;
      for (const Trajectory::Event& e : t.events)
        if (e.kind == PoseStatus::exact_methods_disagree) closed.events.push_back(e);
      t = std::move(closed);
      out.method =
          "dyads (closed form, " + std::to_string(decomposition.groups.size()) + " groups)";
    }
  } else if (options.method == "auto" && reverse) {
    out.method =
        "newton (--at-limit reverse: the traced sweep follows the loop through its toggles)";
  } else if (options.method == "auto") {
    out.method = "newton (the chain does not decompose into dyads: " + decomposition.reason + ")";
  }
  t.flag_non_finite();  // the dyads' samples (Newton's are flagged as they are written)
  return out;
}

}  // namespace crosslink::methods
