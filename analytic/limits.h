// Limits on what one definition may hold, so that no file can crash the TOML parser. They are
// fixed, and far beyond what any planar linkage needs.
#pragma once

namespace crosslink::limits {

// What reaches the TOML parser. toml++ recurses once per level of a dotted key and overflows
// the stack near 50,000 levels, so the text is screened before it is parsed.
constexpr long kDefinitionBytes = 1 << 20;  // a bundled definition is under 10 kB
constexpr int kKeyParts = 16;               // parts of one dotted key or table header: a.b.c is 3
constexpr int kNesting = 16;                // arrays and inline tables inside one another

}  // namespace crosslink::limits
