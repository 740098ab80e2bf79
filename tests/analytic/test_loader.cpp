// Definition loading and validation: every error class names the right line.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "analytic/loader.h"

namespace crosslink {
namespace {

TEST(Loader, LoadsSewingMachine) {
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  EXPECT_EQ(m.links.size(), 6u);
  EXPECT_EQ(mobility(m).mobility, 1);
  EXPECT_DOUBLE_EQ(m.units.length, 0.01);
}

// Issue 13: every bundled definition cites what a user can look up (a book, a course, a paper,
// or that the dimensions were chosen here), never a path of the folders crosslink was written in.
TEST(Loader, BundledCitationsNameDocumentsNotPaths) {
  int files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(
           std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms")) {
    if (entry.path().extension() != ".toml") continue;
    const Mechanism m = load_mechanism(entry.path().string());
    ++files;
    EXPECT_FALSE(m.citation.empty()) << entry.path();
    for (const char* path : {"shared/", "seeds/", "reference/", ".txt", ".md"})
      EXPECT_EQ(m.citation.find(path), std::string::npos) << entry.path() << ": " << m.citation;
  }
  EXPECT_GT(files, 20);
}

}  // namespace
}  // namespace crosslink
