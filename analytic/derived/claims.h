// A definition's own claims judged against its exact solution: what its [expect] table says the
// sweep finds (the assembling range, toggles, change points, a four-bar's Grashof class) and the
// [[derived]] values [expect.derived] gives (docs/mechanism-format.md, "Claims"). `crosslink
// check` prints each and fails (exit 1) on one that does not hold, at its file:line.
#pragma once

#include <string>
#include <vector>

#include "analytic/derived/derived.h"
#include "analytic/model/mechanism.h"
#include "analytic/reference/sweep.h"

namespace crosslink {

// A claim holds when |computed - claimed| <= tolerance / 100 * max(|claimed|, scale), the
// tolerance in percent as every tolerance of a definition, the scale 1 rad for an angle or an
// angular driver's value, the mechanism's size for a length or a slider's value, 1 otherwise (SI).
// Without [expect] 'tolerance' it is this: the claims are closed forms, written to the digits they
// hold to (1e-9 of the value).
constexpr double kClaimTolerancePct = 1e-7;

struct Claim {
  std::string what;               // "[expect] 'toggles'", "[expect.derived] 'Q'"
  SourceLocation where;           // the claim's value in the file
  std::string claimed, computed;  // as the file writes them (its units), or in words
  bool holds = false;
};

// The tolerance `expectations` are judged to [%]: theirs, else kClaimTolerancePct.
double claim_tolerance_pct(const Expectations& expectations);

// Every claim of `mechanism` (none without [expect]), in the file's order: `derived` are its
// [[derived]] values on its exact sweep at the default options (derived_exact) and `singular` the
// singular positions that sweep met (sweep()); the assembling range is traced when limits are
// claimed. A claim whose computed value does not exist (a derived value with its reason, limits of
// a full rotation) does not hold.
std::vector<Claim> judge_claims(const Mechanism& mechanism,
                                const std::vector<DerivedValue>& derived,
                                const std::vector<SingularPosition>& singular);

}  // namespace crosslink
