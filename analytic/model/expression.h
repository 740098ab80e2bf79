// Arithmetic in a definition's numbers: where the loader reads a number it also takes a string
// holding an expression, "2.5 + 1/3" or "10*cos(30)" (docs/mechanism-format.md), so that a
// textbook's dimensions are written as printed instead of converted by hand to a few decimals.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace crosslink {

// The value of an expression, or why it has none and where.
struct Evaluation {
  double value = 0.0;
  std::string error;  // empty when `value` holds the result
  size_t offset = 0;  // the byte of the text at fault (0-based)
  bool ok() const { return error.empty(); }
};

// Evaluates `text` by the grammar (lowest precedence first; spaces anywhere between tokens)
//   sum     = product { ("+" | "-") product }
//   product = signed { ("*" | "/") signed }
//   signed  = ("+" | "-") signed | power
//   power   = primary [ "^" signed ]             right-associative: 2^3^2 = 2^9; -2^2 = -4
//   primary = number | "pi" | function "(" sum { "," sum } ")" | "(" sum ")"
// with decimal numbers (1, 2.5, .5, 1e-3) and the functions sqrt, abs, sin, cos, tan, asin,
// acos, atan and atan2(y, x). Angles, the trigonometric functions' arguments and the inverse
// ones' results, are in units of `angle_unit` radians (pi / 180 in a file in degrees). A result
// that is not a finite number (sqrt(-1), 1/0) is an error at the operation that made it.
Evaluation evaluate(std::string_view text, double angle_unit);

}  // namespace crosslink
