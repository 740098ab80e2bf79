// The mechanism drawn to take away (docs/report.md, "A drawing to take away"): the report's
// drawing as a standalone SVG file, optionally animated over the sweep.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink::compare {

// A link's drawn segment between two of its named points: the edges of the convex hull of its
// points, a binary link its one line, a ternary link its triangle; a point on an edge or inside
// is drawn as a point only. Only points the trajectory has.
struct LinkSegment {
  std::string link, p, q;
};
std::vector<LinkSegment> link_segments(const Mechanism& mechanism, const Trajectory& trajectory);
// The named points that move, those not named on the ground first (Mechanism::named_points
// order): the points whose paths the drawings and the report's path chart draw.
std::vector<std::string> moving_points(const Mechanism& mechanism);

// A guide as drawn at sample `k` of `trajectory` (m, y up): a line guide `reach` either side of
// its origin; a curved slot's centreline in 48 chords, a spline slot's from end to end, an arc's
// whole circle, closed (it has no ends: the pin may go round it). Line guides first, in link
// order, then the curved slots in joint order; none on a moving link without a position at `k`.
struct GuideOutline {
  std::string name;  // the line's, or the slot's joint's
  std::string link;  // that carries it
  bool moving = false;
  std::vector<Eigen::Vector2d> points;
};
std::vector<GuideOutline> guide_outlines(const Mechanism& mechanism, const Trajectory& trajectory,
                                         int k, double reach);

// The links at sample `row` of `sweep` (file length units, y up), the ground's pivots and guides,
// every moving point's path over the sweep in grey (the coupler curves; broken where a sample
// has no position), the slots on moving links and the cams' profiles with their rollers in the
// links' colours; the points named. With `animate_seconds` > 0, the links and moving points go
// through every sample with a position in turn, one sweep per that many seconds, repeating
// (SMIL <animate>, which browsers play from the file alone), and the names are left out.
std::string drawing_svg(const Mechanism& mechanism, const Trajectory& sweep, int row,
                        double animate_seconds = 0.0);

}  // namespace crosslink::compare
