// Loading and validating mechanism definition files (TOML). The schema is documented in
// docs/mechanism-format.md. Every problem is reported with file:line:column.
#pragma once

#include <string>
#include <string_view>

#include "analytic/mechanism.h"

namespace crosslink {

// Parses and validates a definition; throws DefinitionError listing every problem found.
// Validation covers syntax, names, points and lines on their links, units, the driver, and the
// Grübler–Kutzbach mobility against the number of drivers (one).
Mechanism load_mechanism(const std::string& path);
// The same from text in memory; `file` names it in messages.
Mechanism parse_mechanism(std::string_view text, const std::string& file);

}  // namespace crosslink
