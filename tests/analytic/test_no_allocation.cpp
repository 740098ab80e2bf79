// A pose (position, velocity, acceleration) on an already sized KinematicState allocates no
// heap memory. Allocations are counted at both doors: the global operator new (replaced here)
// and malloc itself (interposed here), because Eigen allocates with std::malloc, not new. The
// library is compiled without any Eigen malloc guard, so counting is the check that cannot be
// fooled by how inline Eigen code was instantiated.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <numbers>

#include <Eigen/LU>

#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"
#include "tests/common/sanitizers.h"

// AddressSanitizer brings its own malloc and operator new, which the counting doors below would
// replace: under it they are left out, and the tests that count skip, saying so (they run in
// the normal build). The condition estimate's test runs in both.
#define CROSSLINK_COUNTING (!CROSSLINK_ADDRESS_SANITIZER)

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_news{0};
std::atomic<long> g_mallocs{0};
}  // namespace

#if CROSSLINK_COUNTING
// glibc's own entry points, which the interposed malloc family forwards to.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* pointer, std::size_t size);

void* malloc(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_calloc(count, size);
}
void* realloc(void* pointer, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_realloc(pointer, size);
}
}

void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_news;
  if (void* p = __libc_malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return ::operator new(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  if (g_counting.load(std::memory_order_relaxed)) ++g_news;
  return __libc_malloc(size ? size : 1);
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept {
  return ::operator new(size, tag);
}
// The replaced operator new allocates with malloc, so free is its match; GCC 12 cannot see that
// once Eigen's allocations are inlined here (-Wmismatched-new-delete).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
#pragma GCC diagnostic pop
#endif

constexpr bool kCounting = CROSSLINK_COUNTING;
constexpr const char* kNotCounted =
    "AddressSanitizer owns the allocator: counted in the normal build";

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Counts {
  long news = 0, mallocs = 0;
};

// Counts the allocations of `poses` successive poses, 1 degree apart, each warm-started from the
// last as a sweep does. Assembly and a first pose are outside the count (they may size things).
Counts count_sweep(const Mechanism& m, int poses) {
  const NewtonSolver solver(m);
  KinematicState state(m);
  const SolveReport assembled = solver.assemble(state);
  EXPECT_EQ(assembled.status, PoseStatus::ok) << assembled.message;
  state.swept().value += kDeg;
  EXPECT_EQ(solver.solve(state).status, PoseStatus::ok);

  int not_ok = 0;
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  for (int k = 0; k < poses; ++k) {
    state.swept().value += kDeg;
    if (solver.solve(state).status != PoseStatus::ok) ++not_ok;
  }
  g_counting = false;
  EXPECT_EQ(not_ok, 0);
  EXPECT_TRUE(state.qddot.allFinite());
  return {g_news.load(), g_mallocs.load()};
}

TEST(NoAllocation, TheCountersSeeAllocations) {
  if (!kCounting) GTEST_SKIP() << kNotCounted;
  // The check can fail: an Eigen vector (malloc) and a std::vector (operator new) are counted.
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  {
    Eigen::VectorXd v(100);
    v.setZero();
    std::vector<double> w(100);
    EXPECT_EQ(v.sum() + w[0], 0.0);
  }
  g_counting = false;
  EXPECT_GE(g_news.load(), 1);     // the std::vector
  EXPECT_GE(g_mallocs.load(), 1);  // the Eigen vector (operator new above bypasses malloc)
}

TEST(NoAllocation, SewingMachinePoses) {
  if (!kCounting) GTEST_SKIP() << kNotCounted;
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  const Counts counts = count_sweep(m, 90);
  EXPECT_EQ(counts.news, 0);
  EXPECT_EQ(counts.mallocs, 0);
}

// A crank driving a slotted rocker through a pin in the slot (pin_in_slot): the crank pivot A
// is 0.05 m above the rocker pivot O, the crank 0.02 m long, so the rocker swings and the pin
// never reaches O.
TEST(NoAllocation, PinInSlotPoses) {
  if (!kCounting) GTEST_SKIP() << kNotCounted;
  const Mechanism m = parse_mechanism(R"(name = "slotted rocker"
[units]
length = "m"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { O = [0, 0], A = [0, 0.05] }
[[link]]
name = "crank"
points = { A = [0, 0], B = [0.02, 0] }
pose = [0, 0.05, 0]
[[link]]
name = "rocker"
points = { O = [0, 0], P = [0.1, 0] }
lines = { slot = { through = "O", toward = "P" } }
pose = [0, 0, 68.2]
[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"
[[joint]]
type = "revolute"
links = ["ground", "rocker"]
point = "O"
[[joint]]
type = "pin_in_slot"
guide = "rocker"
line = "slot"
slider = "crank"
point = "B"
[driver]
type = "link_angle"
link = "crank"
from = "A"
to = "B"
start = 0
speed = 1
)",
                                      "slotted_rocker.toml");
  const Counts counts = count_sweep(m, 360);
  EXPECT_EQ(counts.news, 0);
  EXPECT_EQ(counts.mallocs, 0);
}

// Several drivers: each pose sets every driver by its law (KinematicState::drive_at), and Newton
// passes them to the layout through the list sized with the state.
TEST(NoAllocation, TwoDriverPoses) {
  if (!kCounting) GTEST_SKIP() << kNotCounted;
  const Mechanism m = load_mechanism("mechanisms/drivers/fivebar_two_cranks.toml");
  const NewtonSolver solver(m);
  KinematicState state(m);
  ASSERT_EQ(solver.assemble(state).status, PoseStatus::ok);
  state.drive_at(m, 1.0 / 360.0);
  ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
  int not_ok = 0;
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  for (int k = 2; k < 180; ++k) {
    state.drive_at(m, k / 360.0);
    if (solver.solve(state).status != PoseStatus::ok) ++not_ok;
  }
  g_counting = false;
  EXPECT_EQ(not_ok, 0);
  EXPECT_TRUE(state.qddot.allFinite());
  EXPECT_EQ(g_news.load(), 0);
  EXPECT_EQ(g_mallocs.load(), 0);
}

TEST(NoAllocation, ConditionEstimateIsEigens) {
  // The allocation-free estimate must equal Eigen's PartialPivLU::rcond() of the same matrix
  // (15 x 15: Eigen factorises it by the unblocked loops, the same factors as SmallLU's).
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  const NewtonSolver solver(m);
  KinematicState state(m);
  ASSERT_EQ(solver.assemble(state).status, PoseStatus::ok);
  for (int k = 0; k < 36; ++k) {
    state.swept().value += 10 * kDeg;
    const SolveReport report = solver.solve(state);
    ASSERT_EQ(report.status, PoseStatus::ok);
    EXPECT_DOUBLE_EQ(report.rcond,
                     Eigen::PartialPivLU<Eigen::MatrixXd>(state.jacobian.dense()).rcond())
        << "at step " << k;
  }
}

}  // namespace
}  // namespace crosslink
