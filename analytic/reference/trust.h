// What of the reference is trusted: every rule that keeps a reference sample out of a peak, a
// scale or a verdict is here (and stated in docs/compare.md), so the comparator, the engines'
// force checks and the tests apply the same ones.
//
// The reference checks itself: where two exact methods solve the same sample (Newton and the
// closed-form dyads), a sample on which they disagree beyond round-off is not trusted. Such a
// sample is what a singular solve can leave behind unflagged (a change point on the grid gave a
// rocker rate of the wrong sign, marked ok, and its forces became every force channel's peak),
// so it is flagged `exact_methods_disagree`, listed as an event, and kept out like any other
// flagged sample.
#pragma once

#include <string>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

// The largest difference two exact methods may show on a sample, relative to the quantity's
// characteristic scale (positions L, velocities W L, accelerations W^2 L, angles 1 rad, angular
// rates W, W^2; W the driver's peak rate, L the mechanism's size), and times the sample's
// condition beyond the chain's own (typical_rcond / rcond, when above 1; squared for
// accelerations, whose right side holds the rates squared): round-off grows with it next to a
// singular position. Measured on every bundled definition with both
// methods, the worst agreement is far below it (docs/compare.md).
constexpr double kExactAgreement = 1e-6;

// The driver's peak rate W over a trajectory, in rad/s (a slider's m/s over the mechanism's
// size), the rate a link turning with the driver has: the largest |rate| and sqrt|acceleration|
// of the motion law at the samples' times; a dynamics case (no law) by differences of its
// samples.
double driver_peak_rate(const Mechanism& mechanism, const Trajectory& trajectory);

struct CrossCheck {
  std::string method;  // the second exact method
  int compared = 0;    // samples both methods solved (ok in both)
  int disagree = 0;    // reference samples flagged exact_methods_disagree
  int singular = 0;    // reference samples the second method finds singular: flagged singular
  double worst = 0.0;  // largest difference over the samples that agree, relative to its scale
                       // and the sample's condition (kExactAgreement)
  std::string worst_channel;
};

// Compares every kinematic channel of `reference` with `second` (same samples) and flags the
// reference's ok samples where `second` differs by more than kExactAgreement of the scale, or
// where `second` could not solve the sample (it cannot close it there), with an event naming the
// channel and both values. A sample `second` finds singular is flagged singular, as the
// reference flags its own singular samples (their neighbours are then kept out too). Forces are not
// compared: the second method's are the same multipliers at its own poses.
CrossCheck cross_check(const Mechanism& mechanism, Trajectory& reference, const Trajectory& second);

// Forces near a singular position grow as 1/rcond, and so does any approximate method's error
// there: force verdicts keep out the samples whose conditioning is below kForceConditioning of
// the chain's own, the median rcond of the reference's solved samples. Relative, because a
// chain's conditioning depends on its size and topology (IFToMM A02's chain of 40 four-bars sits
// at 1.7e-4 at its median), not on how near it is to a singular position. 0.15 is the absolute
// limit it replaces (1e-2) on the linkage that limit was set on, the change-point four-bar
// (median 0.07: within about 4 degrees of each change point, where the exact reactions and the
// engines' errors grow as 1/rcond). Over the bundled linkages the lowest conditioning against
// the median is 0.29 on the Jansen leg and 0.5 to 0.9 on the others that never near a singular
// position: none loses a sample.
constexpr double kForceConditioning = 0.15;
// The chain's own conditioning: the median rcond over the reference's solved samples (1 when it
// has none).
double typical_rcond(const Trajectory& reference);
// The same, as a property of the mechanism: the reference's median when it has at least
// kConditioningSamples solved samples, else the median over a sweep of the mechanism at 10
// degrees (a single pose, or a sweep at 90 degrees, is not the chain's conditioning: one sample
// next to a toggle was its own median, and the self-check flagged two methods agreeing to 9
// digits).
constexpr int kConditioningSamples = 36;
double chain_rcond(const Mechanism& mechanism, const Trajectory& reference);

// Why reference sample k is kept out of a verdict, "" when it is trusted: its status
// ("reference:<status>"), a neighbour flagged singular ("beside_singular": one grid step from a
// dead point or change point the Jacobian's condition is 10 to 40 times worse, so agreement is
// round-off amplified by it), and for forces an rcond below `force_rcond`
// ("ill_conditioned", see kForceConditioning; pass 0 for kinematic channels).
std::string untrusted(const Trajectory& reference, int k, double force_rcond);

}  // namespace crosslink
