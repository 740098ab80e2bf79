// The statuses stage both engine runs end with: after the run, each sample's status is judged in
// one order (outside the usable span, not reached, flagged by the reference, loop gap, singular,
// another assembly mode), and the counts become the run's notes. The engines measure the gap, the
// conditioning and the closed configuration each in their own way and word some notes and events
// differently; the judge decides, counts and writes what they share.
#pragma once

#include <functional>
#include <string>

#include "analytic/model/trajectory.h"
#include "sim/engine.h"
#include "sim/sampling.h"

namespace crosslink::sim {

// Where an event at the reference's sample i lies along the sweep (Trajectory::Event::driver):
// the driver's value, or with several drivers, whose sweep runs in time, the time, as the exact
// sweep's own events.
inline double event_position(const Trajectory& reference, int i) {
  return reference.along(i);
}

class StatusJudge {
 public:
  struct Thresholds {
    double loop_gap = 0.0;  // a larger gap in a sample's steps: loop_gap [m]
    // A sample conditioned worse than this fraction of the chain's own conditioning (the
    // reference's typical_rcond, analytic/reference/trust.h): singular.
    double singular_rcond = 0.0;
    double branch_distance =
        0.0;  // a closed configuration further from the reference's: branch_jump
  };
  // `events`: a kinematic run puts an event on every sample it keeps at the reference's flag
  // (outside the span, or flagged inside it); a dynamics run does not.
  StatusJudge(const Trajectory& reference, Span span, Thresholds thresholds, bool events);

  // Whether sample i lies outside the usable span; then `out` keeps the reference's status and
  // rcond there and no engine value (loop gap 0).
  bool outside(int i, Trajectory& out);
  // Sample i was not reached (the run stopped before its stencil): diverged.
  PoseStatus lost(int i);
  // A reached sample inside the span, from its gap and rcond; `branch_distance` (when given, and
  // asked only when nothing else flags the sample) is how far its closed configuration is from
  // the reference's, negative when it does not close. PoseStatus::ok when nothing flags it.
  PoseStatus judge(int i, double gap, double rcond, const std::function<double()>& branch_distance,
                   Trajectory& out);

  // The absolute rcond limit in force: singular_rcond times the chain's own conditioning.
  double singular_limit() const { return thresholds_.singular_rcond; }
  int kept() const { return kept_; }  // reference-flagged samples inside the span (run through)
  int loop_gaps() const { return loop_gaps_; }
  int singular() const { return singular_; }
  int first_singular() const { return first_singular_; }
  int jumped() const { return jumped_; }
  int first_jump() const { return first_jump_; }
  int first_lost() const { return first_lost_; }

 private:
  const Trajectory& reference_;
  Span span_;
  Thresholds thresholds_;
  bool events_;
  int kept_ = 0, loop_gaps_ = 0, singular_ = 0, jumped_ = 0;
  int first_singular_ = -1, first_jump_ = -1, first_lost_ = -1;
};

// The notes both engines word alike ("" when there is nothing to say).
std::string kept_note(int kept, bool kinematic);  // reference-flagged samples run through
std::string branch_jump_note(int jumped);
std::string dynamics_singular_note(int singular, double singular_rcond);
std::string dynamics_span_note(const Trajectory& reference, Span span);  // "" over all samples
std::string energy_drift_note(double threshold, double energy_scale, const Trajectory& reference,
                              int drift_at, double worst);

// The loop-gap note (`flagged` samples, the largest of `gaps`, per sample) and an event where
// each run of loop_gap samples starts; lengths in the definition's units.
void note_loop_gaps(int flagged, const Eigen::VectorXd& gaps, double threshold,
                    const Trajectory& reference, EngineRun& run, const Mechanism& definition);

// Appends `note` to a run's message, "; " between notes (nothing for an empty note).
void add_note(std::string& message, const std::string& note);

// Joint friction: how far a dynamics run's coordinate moves while the exact motion is held at
// rest (Trajectory::held), its largest departure from the first usable sample of each time it is
// held; "" when the exact motion is never held.
std::string creep_note(const Mechanism& m, const Trajectory& reference, const Trajectory& run);

// A run that could not be made: its reason, and every sample diverged (no engine value).
EngineRun failed_run(EngineRun run, std::string message);

}  // namespace crosslink::sim
