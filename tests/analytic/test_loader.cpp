// Definition loading and validation: every error class names the right line.
#include <gtest/gtest.h>

#include "analytic/loader.h"

namespace crosslink {
namespace {

TEST(Loader, LoadsSewingMachine) {
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  EXPECT_EQ(m.links.size(), 6u);
  EXPECT_EQ(mobility(m).mobility, 1);
  EXPECT_DOUBLE_EQ(m.units.length, 0.01);
}

}  // namespace
}  // namespace crosslink
