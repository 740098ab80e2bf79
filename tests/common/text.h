// Where a marker stands in a definition's text, for tests that expect a diagnostic's place; a
// definition's text with one change; and a command's output with its wrapped lines joined.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace crosslink::test {

// The 1-based line of `text` on which the n-th (1-based) `marker` begins (0: not there).
inline int line_of(const std::string& text, const std::string& marker, int n = 1) {
  size_t at = text.find(marker);
  while (at != std::string::npos && --n > 0) at = text.find(marker, at + marker.size());
  if (at == std::string::npos) return 0;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
}

// `text` with the first occurrence of `from` replaced by `to` (which must occur).
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test fault: '" << from << "' not in the definition";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// `text` with every run of whitespace (a line wrapped at 100 columns) one space.
inline std::string flattened(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool space = c == ' ' || c == '\n' || c == '\t';
    if (space && !out.empty() && out.back() == ' ') continue;
    out += space ? ' ' : c;
  }
  return out;
}

}  // namespace crosslink::test
