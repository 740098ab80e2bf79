// Loading and validating mechanism definition files (TOML). The schema is documented in
// docs/mechanism-format.md. Every problem is reported with file:line:column.
#pragma once

#include <string>
#include <string_view>

#include "analytic/model/mechanism.h"

namespace crosslink {

// A definition as its file writes it, parsed and validated: syntax, names, points and lines on
// their links, units, the drivers, the Grübler–Kutzbach mobility against their number, the
// derived quantities and the claims; throws DefinitionError listing every problem found. Its
// [[branch]] tables are read, not applied: the loader solves nothing, and assembling is a step of
// its own (apply_branches, analytic/kinematics/branch.h). "-" reads standard input.
Mechanism read_definition(const std::string& path);
// The same from text in memory; `file` names it in messages.
Mechanism parse_definition(std::string_view text, const std::string& file);

// A definition ready to run: read (parsed), then assembled: the assembly its [[branch]] tables
// name, written into its poses (apply_branches). Defined with the assembly step, in
// analytic/kinematics/branch.cpp.
Mechanism load_mechanism(const std::string& path);
Mechanism parse_mechanism(std::string_view text, const std::string& file);

}  // namespace crosslink
