// [[derived]] quantities across methods: each method's value from its own samples against the
// exact one, judged like a channel (docs/compare.md, "Derived quantities").
#pragma once

#include <cstdio>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "analytic/derived/derived.h"
#include "compare/method_run.h"
#include "compare/tolerance.h"

namespace crosslink::compare {

enum class Verdict;

// One field of one [[derived]] quantity for one method other than the reference.
struct DerivedCheck {
  const DerivedSpec* spec = nullptr;
  std::string field;  // "ratio", "at_max", ...
  DerivedUnit unit = DerivedUnit::channel;
  Quantity quantity_class = Quantity::position;  // the class it is judged in
  std::string method;
  std::optional<double> value;     // the method's, from its samples (SI)
  std::optional<double> exact;     // located on the exact solution
  std::optional<double> estimate;  // the same estimate from the reference's own samples
  // A location's ties (DerivedField::ties): the other places each puts the same extreme.
  std::vector<double> value_ties, exact_ties, estimate_ties;
  double scale = 0.0;      // what % of scale divides by (SI)
  double tolerance = 0.0;  // % of scale: the comparator's for the field's class
  Verdict verdict{};
  std::string reason;  // why there is no verdict (a value that does not exist)
  std::string quantity() const { return spec->name + "." + field; }
  // The course's % difference from the exact value; NaN where either does not exist.
  double pct_vs_exact() const;
  // The verdict metric: 100 |value - estimate| / scale, the method's own error with the
  // estimate's error (the same on both) taken out; NaN where either does not exist.
  double pct_of_scale() const;
};

struct DerivedResults {
  std::vector<DerivedValue> exact;     // the reference's, located on the exact solution
  std::vector<DerivedValue> estimate;  // from the reference's samples, as a method's would be
  struct Method {
    std::string name;
    std::vector<DerivedValue> values;
  };
  std::vector<Method> methods;  // every other method that ran, from its samples
  std::vector<DerivedCheck> checks;
  bool empty() const { return exact.empty(); }
  int failures() const;
};

// The mechanism's [[derived]] quantities for every method (methods[0] the exact reference), against
// `exact`, the same located on the exact solution (derived_exact on methods[0]'s trajectory).
DerivedResults compare_derived(const Mechanism& mechanism, const std::vector<MethodRun>& methods,
                               const Tolerances& tolerances, std::vector<DerivedValue> exact);

// Console: the exact values (file units) and every method's, with % and verdicts.
void print_derived(std::FILE* out, const Mechanism& mechanism, const DerivedResults& results);
// `solve`: the exact values alone, with the [expect.derived] values beside them; the text of
// each quantity and its fields, `indent` spaces in (`check`'s design summary).
std::string derived_exact_text(const Mechanism& mechanism, const std::vector<DerivedValue>& exact,
                               int indent);
void print_derived_exact(std::FILE* out, const Mechanism& mechanism,
                         const std::vector<DerivedValue>& exact);
// JSON (docs/json.md, "derived"): SI.
nlohmann::json derived_json(const std::vector<DerivedValue>& exact,
                            const DerivedResults* results = nullptr);
// CSV rows in write_csv's columns: channel "derived:<name>.<field>", no sample.
void write_derived_csv(const DerivedResults& results, std::ostream& out);
// An HTML table (file units) for the report page.
std::string derived_table_html(const Mechanism& mechanism, const DerivedResults& results);

}  // namespace crosslink::compare
