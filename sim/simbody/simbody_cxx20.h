// Simbody 3.7's headers as Debian builds the library. First, without NDEBUG: the package is built
// without it, and its classes have members only then (CacheEntryInfo's prerequisite versions), so
// a Release build's inline copies of Simbody's functions would read a different layout (measured:
// a segmentation fault in ListOfDependents::notePrerequisiteChange at realizeTopology). Then,
// under C++20: its index types (SimTK_DEFINE_UNIQUE_INDEX_TYPE) compare
// with an int through member operator==(int) and a conversion to int, so under C++20's reversed
// candidates `index == index` is ambiguous (GCC 12: an error inside Simbody's own headers). An
// equality of two indices of one type, declared before those headers, is the exact match that
// resolves it; it compares what the members compare.
#pragma once

#pragma push_macro("NDEBUG")
#undef NDEBUG
#include <SimTKcommon/internal/common.h>

namespace SimTK {

template <class Index>
requires requires(const Index& i) {
  i.isValidExtended();
  static_cast<int>(i);
}
bool operator==(const Index& a, const Index& b) {
  return static_cast<int>(a) == static_cast<int>(b);
}

}  // namespace SimTK

// MultibodyGraphMaker (which crosslink does not use: the scene graph is its own) holds vectors of
// its own incomplete types, which clang's C++20 library rejects where GCC 12's accepts them: its
// include guard is defined so that Simbody.h skips it (no other Simbody header names it).
#define SimTK_SIMMATH_MULTIBODY_GRAPH_MAKER_H_
#include <Simbody.h>
#undef SimTK_SIMMATH_MULTIBODY_GRAPH_MAKER_H_
#pragma pop_macro("NDEBUG")
