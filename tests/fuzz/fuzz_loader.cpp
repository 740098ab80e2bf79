// Fuzz target for the definition loader and validation (docs/robustness.md). Any text must load
// or be refused with located diagnostics, and a definition that loads must go through what
// `crosslink check` and `crosslink solve` do with it without a crash, a hang or a non-finite
// value. A violation aborts, so libFuzzer keeps the input; a hang is libFuzzer's -timeout.
//   - every diagnostic of a refusal is at file:line:column (line and column at least 1);
//   - no exception escapes but the refusals the commands turn into exit code 2;
//   - check's report holds no "nan" or "inf" (unless the definition's own names do);
//   - every value of every sample solve writes (the sweep, one --at pose, its instantaneous
//     centres) is finite, whatever the sample's status: a flagged sample has finite
//     placeholders (docs/json.md);
//   - every [[derived]] quantity, exact and from the samples, is finite or has no value and
//     says why (a channel its object does not have crashed solve: issue 35).
// Built with libFuzzer by -DCROSSLINK_FUZZ=ON (clang); replay.cpp runs kept inputs with any
// compiler.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "analytic/derived/derived.h"
#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/reference/budget.h"
#include "analytic/reference/dyad_sweep.h"
#include "app/commands.h"
#include "methods/check.h"

namespace {

using namespace crosslink;

[[noreturn]] void violation(const std::string& what) {
  std::fprintf(stderr, "fuzz_loader: %s\n", what.c_str());
  std::abort();
}

void require_places(const DefinitionError& e) {
  for (const Diagnostic& d : e.diagnostics())
    if (d.where.line < 1 || d.where.column < 1)
      violation("a diagnostic without a place: " + d.str());
}

// Whether `text` holds the word nan or inf (any case), as fmt writes a non-finite number.
bool has_non_finite_word(const std::string& text) {
  auto letter = [&](size_t i) {
    return i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_');
  };
  for (size_t i = 0; i + 3 <= text.size(); ++i) {
    if (i > 0 && letter(i - 1)) continue;
    std::string word = text.substr(i, 3);
    for (char& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if ((word == "nan" || word == "inf") && !letter(i + 3)) return true;
  }
  return false;
}

void require_finite(const Trajectory& t, const std::string& what) {
  bool finite = t.time.allFinite() && t.driver_values.allFinite();
  for (const Eigen::MatrixXd* m : {&t.angle, &t.omega, &t.alpha, &t.x, &t.y, &t.vx, &t.vy, &t.ax,
                                   &t.ay, &t.s, &t.sdot, &t.sddot})
    finite = finite && m->allFinite();
  for (const Trajectory::Event& e : t.events) finite = finite && std::isfinite(e.driver);
  if (!finite) violation("a non-finite value in " + what);
}

// Each input's work is bounded so that a minute tries thousands of inputs: an angular driver is
// swept on a 10 degree grid (36 samples; a slider's default grid is 360 samples), and the tracer
// has 20,000 steps a leg (the bundled definitions take under 5,000, the 40-bar A02 chain
// included), so an input that spends them takes the flagged path of a spent leg.
SweepOptions bounded_sweep(const Mechanism& m) {
  SweepOptions options;
  if (m.drivers[0].angular()) options.step = std::numbers::pi / 18.0;
  options.tracer_steps = 20000;
  return options;
}

void require_finite(const std::vector<DerivedValue>& values, const std::string& what) {
  for (const DerivedValue& v : values) {
    if (v.fields.empty()) violation("a [[derived]] quantity without fields in " + what);
    bool none = true;
    for (const DerivedField& f : v.fields) {
      if (f.value && !std::isfinite(*f.value))
        violation("a non-finite [[derived]] field " + f.name + " in " + what);
      none = none && !f.value;
    }
    if (none && v.reason.empty()) violation("a [[derived]] quantity with no value and no reason");
  }
}

// What `solve` writes: the sweep by its default method (check's, `swept`, when it made one: the
// same call with the same options), its [[derived]] quantities, one pose, and its centres.
void solve(const Mechanism& m, const std::optional<Trajectory>& swept) {
  // The sweep within the work limits a command would check (check_report's own sweep is
  // bounded by them already; a driver at rest has one pose, which the check refuses to sweep).
  if (!swept && !m.drivers[0].at_rest()) check_sweep_work(m, bounded_sweep(m), {});
  Trajectory t = swept ? *swept : sweep(m, bounded_sweep(m));
  require_finite(t, "the Newton sweep");
  if (!m.derived.empty() && t.samples() > 0) {
    require_finite(derived_exact(m, t), "the exact [[derived]] quantities");
    require_finite(derived_sampled(m, t), "the sampled [[derived]] quantities");
  }
  if (decompose(m).complete) {
    t = dyad_sweep(m, t);
    require_finite(t, "the dyad sweep");
  }
  const double at = m.drivers[0].start + (m.drivers[0].angular() ? 0.5 : 0.1 * m.size());
  check_solve_at_work(m, at, {}, {});
  const Trajectory pose = solve_at(m, at);
  require_finite(pose, "solve --at");
  if (!usable(pose.status[0])) return;
  const CentreVelocities v = centre_velocities(m, instant_centres(m, pose, 0), pose, 0);
  if (!v.complete) return;
  for (double omega : v.omega)
    if (!std::isfinite(omega)) violation("a non-finite velocity from the instantaneous centres");
  for (const Eigen::Vector2d& p : v.point)
    if (!p.allFinite()) violation("a non-finite velocity from the instantaneous centres");
}

}  // namespace

#ifdef CROSSLINK_LIBFUZZER
// libFuzzer's byte mutations seldom turn a number into another valid number, so half of the
// mutations replace one number of the definition by a value at the edges of the limits (or past
// them); the other half are libFuzzer's own.
extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned int seed) {
  static const char* const kValues[] = {"0",
                                        "-0.0",
                                        "1",
                                        "-1",
                                        "0.5",
                                        "90",
                                        "180",
                                        "360",
                                        "1e-9",
                                        "1e-12",
                                        "1e-300",
                                        "1e-320",
                                        "5e-324",
                                        "1e5",
                                        "1e6",
                                        "1e8",
                                        "1e9",
                                        "1e10",
                                        "1e300",
                                        "1e308",
                                        "-1e308",
                                        "nan",
                                        "inf",
                                        "-inf",
                                        "9223372036854775807",
                                        "1.0000000001",
                                        "6.283185307179586",
                                        "57.29577951308232"};
  std::minstd_rand random(seed);
  std::string text(reinterpret_cast<const char*>(data), size);
  // The numbers: runs of digits with their sign, point and exponent.
  std::vector<std::pair<std::size_t, std::size_t>> numbers;
  for (std::size_t i = 0; i < text.size();) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) {
      ++i;
      continue;
    }
    std::size_t begin = i > 0 && (text[i - 1] == '-' || text[i - 1] == '+') ? i - 1 : i;
    while (i < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.' || text[i] == 'e' ||
            text[i] == 'E' ||
            ((text[i] == '-' || text[i] == '+') && (text[i - 1] == 'e' || text[i - 1] == 'E'))))
      ++i;
    numbers.emplace_back(begin, i - begin);
  }
  if (numbers.empty() || random() % 2 == 0) return LLVMFuzzerMutate(data, size, max_size);
  const auto [at, length] = numbers[random() % numbers.size()];
  text.replace(at, length, kValues[random() % std::size(kValues)]);
  if (text.size() > max_size) return LLVMFuzzerMutate(data, size, max_size);
  std::copy(text.begin(), text.end(), data);
  return text.size();
}
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const Mechanism m = parse_mechanism(text, "fuzz.toml");
    const methods::CheckReport report = methods::check_report(m, {}, bounded_sweep(m));
    if (has_non_finite_word(report.out + report.err) && !has_non_finite_word(text))
      violation("check printed a non-finite value:\n" + report.out + report.err);
    if (report.exit_code == app::kExitOk) solve(m, report.sweep);
  } catch (const DefinitionError& e) {
    require_places(e);
  } catch (const std::invalid_argument&) {
    // The work asked for is over the limits: refused before it starts, exit code 2.
  }
  return 0;
}
