// The engines of a settings sweep ranked at one accuracy (docs/sweep.md, "Ranking"): each
// engine's cheapest setting meeting it (select_cheapest: the coarsest time step where a variant
// meets it, the least work there), the engines that meet it by that setting's CPU time, cheapest
// first; then the engines that never meet it, by their best row with status ok (the least ratio
// of a class's error to its limit), and last those with no such row.
#pragma once

#include <string>
#include <vector>

#include "methods/settings_sweep.h"

namespace crosslink::methods {

struct EngineRank {
  std::string engine;
  bool met = false;
  bool has_row = false;  // not met: whether some row had status ok and every class measured
  // Met: the cheapest setting meeting the limits; not met: the row closest to them.
  SweepRow row;
  // The row's largest error over its class's limit (<= 1 when met), and that class ("energy"
  // for the energy balance). NaN / empty without a row.
  double worst_ratio = std::numeric_limits<double>::quiet_NaN();
  std::string worst_class;
  std::string text() const;  // one line: what it costs, or why it is last
};

struct EngineRanking {
  ClassLimits limits;
  std::string rule;                 // how the limits were set
  std::vector<EngineRank> engines;  // ranked, first the cheapest
};

// The common limits when no accuracy is asked: per class, the tightest default tolerance of
// `engines` (the engine table's, methods/engines.h; position: the tighter of position and angle,
// force: of force and torque), for a kinematic or a dynamics case.
ClassLimits common_tolerances(const std::vector<std::string>& engines, bool dynamics);

// Every engine with a row in `rows` (first appearance order) ranked at `limits`.
EngineRanking rank_engines(const std::vector<SweepRow>& rows, const ClassLimits& limits,
                           std::string rule);

// The sweep's ranking: at its --accuracy X when asked, else at common_tolerances() of its engines.
EngineRanking rank_engines(const SettingsSweep& sweep);

}  // namespace crosslink::methods
