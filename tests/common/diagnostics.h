// A definition's text that the loader refuses, turned into what the commands would print: for
// tests that expect a fault at a place.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "analytic/model/loader.h"

namespace crosslink::test {

// The diagnostics that refuse `text` read as the file `file`, each placed in it; the test fails
// (and there are none) when the definition is accepted.
inline std::vector<Diagnostic> diagnostics_of(const std::string& text,
                                              const std::string& file = "bad.toml") {
  try {
    (void)parse_mechanism(text, file);
  } catch (const DefinitionError& e) {
    for (const Diagnostic& d : e.diagnostics()) EXPECT_EQ(d.where.file, file) << d.str();
    return e.diagnostics();
  }
  ADD_FAILURE() << "the definition was accepted:\n" << text;
  return {};
}

// Those diagnostics as `crosslink check` prints them, one a line ("" when it is accepted).
inline std::string error_of(const std::string& text, const std::string& file = "bad.toml") {
  std::string all;
  for (const Diagnostic& d : diagnostics_of(text, file)) {
    if (!all.empty()) all += '\n';
    all += d.str();
  }
  return all;
}

}  // namespace crosslink::test
