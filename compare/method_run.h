// What the comparator compares: one method's run over a Mechanism, whoever made it (the exact
// solvers, an engine, a file of printed values), as the same Trajectory type with the settings it
// ran with and what it cost. The methods themselves are assembled in methods/registry.h.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/run_record.h"
#include "analytic/model/trajectory.h"

namespace crosslink::compare {

// How a method is drawn in every report's charts: a colour ("#1f77b4") and a dash pattern (px
// on, off, ...; {} solid). Each method's is named once: the engine table's row for an engine
// (methods/engines.h), methods::method_style for the exact methods.
struct LineStyle {
  std::string colour;
  std::vector<double> dash;
};

struct MethodRun {
  std::string name;         // one of method_names()
  std::string description;  // one line for reports
  bool available = false;   // built in and able to realise this mechanism
  bool ok = false;          // ran to the end (an engine may diverge: ok = false)
  std::string message;      // why not available / not ok, or the method's notes
  Trajectory trajectory;    // same samples as the reference sweep
  RunSettings settings;     // every setting in force
  RunCost cost;
  // The channel kinds the method computes ("omega", "vx", ...; empty: every channel); its other
  // channels are not compared.
  std::vector<std::string> kinds;
  bool computes(std::string_view channel) const;
};

}  // namespace crosslink::compare
