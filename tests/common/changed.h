// A bundled definition with some of its text changed, written to the test's scratch folder and
// loaded from there: a variant to hold against the definition or against another linkage.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/loader.h"
#include "tests/common/cli.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink::test {

// `file` (relative to the source root) with each `from` replaced by its `to` (which must occur).
inline Mechanism changed(const std::string& file,
                         const std::vector<std::pair<std::string, std::string>>& changes) {
  std::string text = source_text(file);
  for (const auto& [from, to] : changes) text = replaced(text, from, to);
  const std::filesystem::path path = scratch_dir() / std::filesystem::path(file).filename();
  std::ofstream(path) << text;
  return load_mechanism(path.string());
}

}  // namespace crosslink::test
