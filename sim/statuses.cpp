#include "sim/statuses.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "analytic/model/units_text.h"
#include "analytic/reference/trust.h"

namespace crosslink::sim {

StatusJudge::StatusJudge(const Trajectory& reference, Span span, Thresholds thresholds, bool events)
    : reference_(reference), span_(span), thresholds_(thresholds), events_(events) {
  // The conditioning limit is a fraction of the chain's own (analytic/reference/trust.h): a long
  // chain is ill-conditioned everywhere without being near a singular position.
  thresholds_.singular_rcond *= typical_rcond(reference);
}

bool StatusJudge::outside(int i, Trajectory& out) {
  if (i >= span_.first && i <= span_.last) return false;
  const auto row = static_cast<size_t>(i);
  out.status[row] = reference_.status[row];
  // Not run: no value of the engine here, whatever the flag kept says (docs/compare.md).
  if (out.not_run.empty()) out.not_run.assign(out.status.size(), 0);
  out.not_run[row] = 1;
  out.rcond(i) = reference_.rcond(i);
  out.loop_gap(i) = 0.0;
  if (events_)
    out.events.push_back({event_position(reference_, i), reference_.status[row],
                          "outside the reference's usable samples: not run, the reference's "
                          "flag kept"});
  return true;
}

PoseStatus StatusJudge::lost(int i) {
  if (first_lost_ < 0) first_lost_ = i;
  return PoseStatus::diverged;
}

PoseStatus StatusJudge::judge(int i, double gap, double rcond,
                              const std::function<double()>& branch_distance, Trajectory& out) {
  const PoseStatus flag = reference_.status[static_cast<size_t>(i)];
  if (!usable(flag)) {
    if (events_)
      out.events.push_back({event_position(reference_, i), flag,
                            "the reference flags this sample: run through, the flag kept"});
    ++kept_;
    return flag;
  }
  if (gap > thresholds_.loop_gap) {
    ++loop_gaps_;
    return PoseStatus::loop_gap;
  }
  if (rcond < thresholds_.singular_rcond) {
    if (first_singular_ < 0) first_singular_ = i;
    ++singular_;
    return PoseStatus::singular;
  }
  // Another solution of the same equations is another assembly mode: the engine took the other
  // branch at a change point. A model error (perturb_link) closes back onto the reference's
  // branch and stays a reported difference.
  if (branch_distance && branch_distance() > thresholds_.branch_distance) {
    if (first_jump_ < 0) first_jump_ = i;
    ++jumped_;
    return PoseStatus::branch_jump;
  }
  return PoseStatus::ok;
}

std::string kept_note(int kept, bool kinematic) {
  if (kept == 0) return "";
  return kinematic ? fmt::format(
                         "{} samples inside the run keep the reference's flag (run through)", kept)
                   : fmt::format("{} samples keep the reference's flag (run through)", kept);
}

std::string branch_jump_note(int jumped) {
  if (jumped == 0) return "";
  return fmt::format("{} samples flagged branch_jump (the engine is on another assembly mode)",
                     jumped);
}

std::string dynamics_singular_note(int singular, double singular_rcond) {
  if (singular == 0) return "";
  return fmt::format(
      "{} samples flagged singular (constraint Jacobian rcond below {:.2g}, singular_rcond of "
      "the chain's own conditioning, at the engine's configuration: next to a singular position)",
      singular, singular_rcond);
}

std::string dynamics_span_note(const Trajectory& reference, Span span) {
  if (span.first == 0 && span.last == reference.samples() - 1) return "";
  return fmt::format("run over the reference's usable samples {} .. {} (t = {:.6g} .. {:.6g} s)",
                     span.first, span.last, reference.time(span.first), reference.time(span.last));
}

std::string creep_note(const Mechanism& m, const Trajectory& reference, const Trajectory& run) {
  double creep = 0.0, held = 0.0;
  std::vector<std::string> windows;
  for (const auto& [from, to] : reference.held) {
    int first = -1, last = -1;
    for (int k = 0; k < run.samples(); ++k) {
      if (reference.time(k) <= from || reference.time(k) > to ||
          !usable(run.status[static_cast<size_t>(k)]))
        continue;
      if (first < 0) first = k;
      last = k;
      creep = std::max(creep, std::abs(run.driver_values(k, 0) - run.driver_values(first, 0)));
    }
    if (first < 0) continue;
    held += reference.time(last) - reference.time(first);
    windows.push_back(fmt::format("{:.6g} .. {:.6g}", reference.time(first), reference.time(last)));
  }
  if (windows.empty()) return "";
  return fmt::format(
      "creep: {:.3g} {} in the {:.6g} s the exact motion is held at rest by friction (t = {} s)",
      creep, m.drivers.front().angular() ? "rad" : "m", held, fmt::join(windows, ", "));
}

std::string energy_drift_note(double threshold, double energy_scale, const Trajectory& reference,
                              int drift_at, double worst) {
  return fmt::format(
      "energy drift: the balance is off by more than {:g} of the energy scale ({:.3g} J) from "
      "t = {:.6g} s (sample {}); worst {:.3g} J",
      threshold, energy_scale, reference.time(drift_at), drift_at, worst);
}

EngineRun failed_run(EngineRun run, std::string message) {
  run.ok = false;
  run.message = std::move(message);
  std::fill(run.trajectory.status.begin(), run.trajectory.status.end(), PoseStatus::diverged);
  return run;
}

void add_note(std::string& message, const std::string& note) {
  if (note.empty()) return;
  message = message.empty() ? note : message + "; " + note;
}

// The loop-gap note and an event where each run of loop_gap samples starts.
void note_loop_gaps(int flagged, const Eigen::VectorXd& gaps, double threshold,
                    const Trajectory& reference, EngineRun& run, const Mechanism& definition) {
  if (flagged == 0) return;
  add_note(run.message, fmt::format("{} samples flagged loop_gap (largest gap {} > threshold {})",
                                    flagged, length_text(definition, gaps.maxCoeff()),
                                    length_text(definition, threshold)));
  Trajectory& out = run.trajectory;
  for (int i = 0; i < out.samples(); ++i)
    if (out.status[static_cast<size_t>(i)] == PoseStatus::loop_gap &&
        (i == 0 || out.status[static_cast<size_t>(i - 1)] != PoseStatus::loop_gap))
      out.events.push_back({event_position(reference, i), PoseStatus::loop_gap,
                            "loop gap " + length_text(definition, gaps(i))});
}

}  // namespace crosslink::sim
