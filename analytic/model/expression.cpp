#include "analytic/model/expression.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <numbers>
#include <vector>

#include "analytic/model/limits.h"

namespace crosslink {
namespace {

// Why an expression has no value; thrown from anywhere in the descent, caught by evaluate().
struct Fault {
  size_t offset;
  std::string message;
};

struct Function {
  std::string_view name;
  std::string_view arguments;  // as the messages name them
  size_t count;
  double (*apply)(const double* x, double angle_unit);
};

constexpr Function kFunctions[] = {
    {"sqrt", "x", 1, [](const double* x, double) { return std::sqrt(x[0]); }},
    {"abs", "x", 1, [](const double* x, double) { return std::abs(x[0]); }},
    {"sin", "angle", 1, [](const double* x, double u) { return std::sin(x[0] * u); }},
    {"cos", "angle", 1, [](const double* x, double u) { return std::cos(x[0] * u); }},
    {"tan", "angle", 1, [](const double* x, double u) { return std::tan(x[0] * u); }},
    {"asin", "x", 1, [](const double* x, double u) { return std::asin(x[0]) / u; }},
    {"acos", "x", 1, [](const double* x, double u) { return std::acos(x[0]) / u; }},
    {"atan", "x", 1, [](const double* x, double u) { return std::atan(x[0]) / u; }},
    {"atan2", "y, x", 2, [](const double* x, double u) { return std::atan2(x[0], x[1]) / u; }},
};

std::string function_names() {
  std::string names;
  for (const Function& f : kFunctions) names += (names.empty() ? "" : ", ") + std::string(f.name);
  return names;
}

bool is_digit(char c) {
  return c >= '0' && c <= '9';
}
bool is_letter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
}

// A recursive descent over the grammar in expression.h, one method per rule, evaluating as it
// goes. Every nesting (a sign, a power's exponent, parentheses) passes through signed_value(),
// which bounds the depth, so no text can exhaust the stack.
class Parser {
 public:
  Parser(std::string_view text, double angle_unit) : text_(text), angle_unit_(angle_unit) {}

  double whole() {
    const double value = sum();
    skip_spaces();
    if (pos_ < text_.size()) {
      if (text_[pos_] == ')') throw Fault{pos_, "')' without a matching '('"};
      throw Fault{pos_,
                  fmt::format("expected an operator (+ - * / ^) or the end, found {}", found())};
    }
    return value;
  }

 private:
  double sum() {
    double value = product();
    for (;;) {
      skip_spaces();
      const size_t at = pos_;
      if (take('+'))
        value = operation('+', value, product(), at);
      else if (take('-'))
        value = operation('-', value, product(), at);
      else
        return value;
    }
  }

  double product() {
    double value = signed_value();
    for (;;) {
      skip_spaces();
      const size_t at = pos_;
      if (take('*'))
        value = operation('*', value, signed_value(), at);
      else if (take('/'))
        value = operation('/', value, signed_value(), at);
      else
        return value;
    }
  }

  double signed_value() {
    skip_spaces();
    if (++depth_ > limits::kExpressionNesting)
      throw Fault{pos_, fmt::format("signs, powers and parentheses nested deeper than {} levels, "
                                    "the limit of an expression",
                                    limits::kExpressionNesting)};
    double value;
    if (take('-'))
      value = -signed_value();
    else if (take('+'))
      value = signed_value();
    else
      value = power();
    --depth_;
    return value;
  }

  double power() {
    const double base = primary();
    skip_spaces();
    const size_t at = pos_;
    if (!take('^')) return base;
    return operation('^', base, signed_value(), at);  // the exponent's own ^ binds first
  }

  double primary() {
    skip_spaces();
    const size_t start = pos_;
    const char c = pos_ < text_.size() ? text_[pos_] : '\0';
    if (is_digit(c) || c == '.') return number();
    if (is_letter(c)) return name();
    if (!take('('))
      throw Fault{pos_, fmt::format("expected a number, a name or '(', found {}", found())};
    const double value = sum();
    close(start);
    return value;
  }

  // The ')' of the '(' at `open`.
  void close(size_t open) {
    skip_spaces();
    if (take(')')) return;
    if (pos_ == text_.size()) throw Fault{open, "'(' is never closed"};
    throw Fault{pos_, fmt::format("expected ')' or an operator, found {}", found())};
  }

  // Digits with an optional decimal point and exponent: 2, 2.5, .5, 2., 1e-3.
  double number() {
    const size_t start = pos_;
    auto digits = [&] {
      const size_t from = pos_;
      while (pos_ < text_.size() && is_digit(text_[pos_])) ++pos_;
      return pos_ > from;
    };
    bool any = digits();
    if (take('.')) any = digits() || any;
    if (!any) throw Fault{start, "'.' without digits"};
    if (pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
      const size_t mark = pos_++;
      if (pos_ < text_.size() && (text_[pos_] == '+' || text_[pos_] == '-')) ++pos_;
      if (!digits()) throw Fault{mark, "an exponent needs digits (1e-3)"};
    }
    double value = 0.0;
    const std::from_chars_result read =
        std::from_chars(text_.data() + start, text_.data() + pos_, value);
    if (read.ec != std::errc() || read.ptr != text_.data() + pos_)
      throw Fault{start, fmt::format("{} is outside the range of a number",
                                     text_.substr(start, pos_ - start))};
    return value;
  }

  // The constant pi, or a function and its arguments.
  double name() {
    const size_t start = pos_;
    while (pos_ < text_.size() && (is_letter(text_[pos_]) || is_digit(text_[pos_]))) ++pos_;
    const std::string_view word = text_.substr(start, pos_ - start);
    if (word == "pi") return std::numbers::pi;
    skip_spaces();
    const bool call = pos_ < text_.size() && text_[pos_] == '(';
    const Function* f = nullptr;
    for (const Function& candidate : kFunctions)
      if (candidate.name == word) f = &candidate;
    if (!f)
      throw Fault{
          start, call ? fmt::format("unknown function '{}' (functions: {})", word, function_names())
                      : fmt::format("unknown name '{}' (the constant pi, and the "
                                    "functions {})",
                                    word, function_names())};
    if (!call) throw Fault{start, fmt::format("'{}' is a function: write {}(...)", word, word)};
    const size_t open = pos_++;
    std::vector<double> x;
    do x.push_back(sum());
    while (take(','));
    close(open);
    if (x.size() != f->count)
      throw Fault{start, fmt::format("{} takes {} argument{} ({}), not {}", word, f->count,
                                     f->count == 1 ? "" : "s", f->arguments, x.size())};
    return finite(f->apply(x.data(), angle_unit_), start, [&] {
      std::string args;
      for (double v : x) args += fmt::format("{}{:g}", args.empty() ? "" : ", ", v);
      return fmt::format("{}({})", word, args);
    });
  }

  double operation(char op, double a, double b, size_t at) {
    if (op == '/' && b == 0.0) throw Fault{at, "division by zero"};
    const double value = op == '+'   ? a + b
                         : op == '-' ? a - b
                         : op == '*' ? a * b
                         : op == '/' ? a / b
                                     : std::pow(a, b);
    return finite(value, at, [&] { return fmt::format("{:g} {} {:g}", a, op, b); });
  }

  // `value` when it is finite; else a fault at `at` naming the operation that made it.
  template <class Describe>
  double finite(double value, size_t at, Describe describe) const {
    if (std::isfinite(value)) return value;
    throw Fault{at, fmt::format("{} is not {}", describe(),
                                std::isnan(value) ? "a real number" : "a finite number")};
  }

  void skip_spaces() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' ||
                                   text_[pos_] == '\n' || text_[pos_] == '\r'))
      ++pos_;
  }

  bool take(char c) {
    if (pos_ >= text_.size() || text_[pos_] != c) return false;
    ++pos_;
    return true;
  }

  // The character at the position, whole (a UTF-8 sequence), for messages.
  std::string found() const {
    if (pos_ >= text_.size()) return "the end";
    size_t n = 1;
    while (pos_ + n < text_.size() && (static_cast<unsigned char>(text_[pos_ + n]) & 0xC0) == 0x80)
      ++n;
    return fmt::format("'{}'", text_.substr(pos_, n));
  }

  std::string_view text_;
  double angle_unit_;
  size_t pos_ = 0;
  int depth_ = 0;
};

}  // namespace

Evaluation evaluate(std::string_view text, double angle_unit) {
  Evaluation result;
  try {
    result.value = Parser(text, angle_unit).whole();
  } catch (const Fault& fault) {
    result.error = fault.message;
    result.offset = fault.offset;
  }
  return result;
}

}  // namespace crosslink
