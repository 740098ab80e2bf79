// Arithmetic in numbers (analytic/model/expression.h): values against the same arithmetic written
// in C++ or worked by hand, and every error at the byte that causes it.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "analytic/model/expression.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;  // radians per degree: a file in degrees
constexpr double kRad = 1.0;

double value_of(const std::string& text, double angle_unit = kRad) {
  const Evaluation e = evaluate(text, angle_unit);
  EXPECT_TRUE(e.ok()) << text << ": " << e.error;
  return e.value;
}

TEST(Expression, NumbersAsTomlWritesThem) {
  EXPECT_EQ(value_of("2"), 2.0);
  EXPECT_EQ(value_of("2.5"), 2.5);
  EXPECT_EQ(value_of(".5"), 0.5);
  EXPECT_EQ(value_of("2."), 2.0);
  EXPECT_EQ(value_of("1e-3"), 0.001);
  EXPECT_EQ(value_of("1.5E+3"), 1500.0);
  EXPECT_EQ(value_of("  7\t"), 7.0);
}

TEST(Expression, PrecedenceAndAssociativity) {
  EXPECT_EQ(value_of("1 + 2*3"), 7.0);
  EXPECT_EQ(value_of("(1 + 2)*3"), 9.0);
  EXPECT_EQ(value_of("7 - 2 - 1"), 4.0);  // (7 - 2) - 1
  EXPECT_EQ(value_of("8/4/2"), 1.0);      // (8 / 4) / 2
  EXPECT_EQ(value_of("2^3^2"), 512.0);    // 2^(3^2), not (2^3)^2 = 64
  EXPECT_EQ(value_of("-2^2"), -4.0);      // -(2^2)
  EXPECT_EQ(value_of("(-2)^2"), 4.0);
  EXPECT_EQ(value_of("2^-2"), 0.25);
  EXPECT_EQ(value_of("-2^-2"), -0.25);
  EXPECT_EQ(value_of("2*-3"), -6.0);
  EXPECT_EQ(value_of("--3"), 3.0);
  EXPECT_EQ(value_of("+2 - +1"), 1.0);
  EXPECT_EQ(value_of("2 * 3^2 + 1"), 19.0);
  // As exact as the same operations in C++: the point of writing 1/3 instead of 0.333333.
  EXPECT_EQ(value_of("2.5 + 1/3"), 2.5 + 1.0 / 3.0);
}

TEST(Expression, ConstantAndFunctionsOfNumbers) {
  EXPECT_EQ(value_of("pi"), kPi);
  EXPECT_EQ(value_of("pi", kDeg), kPi);  // a number, whatever the angle unit
  EXPECT_EQ(value_of("sqrt(2)"), std::sqrt(2.0));
  EXPECT_EQ(value_of("sqrt(16)"), 4.0);
  EXPECT_EQ(value_of("abs(-3.5)"), 3.5);
  EXPECT_EQ(value_of("sqrt(3)/2 * 4"), std::sqrt(3.0) / 2 * 4);
  EXPECT_EQ(value_of("sqrt( 9 + 16 )"), 5.0);
}

// Angles are in the file's unit: in degrees, cos(60) is cos(60 deg) and asin(0.5) is 30.
TEST(Expression, TrigonometryInDegrees) {
  EXPECT_NEAR(value_of("cos(60)", kDeg), 0.5, 1e-15);
  EXPECT_NEAR(value_of("sin(30)", kDeg), 0.5, 1e-15);
  EXPECT_NEAR(value_of("tan(45)", kDeg), 1.0, 1e-15);
  EXPECT_NEAR(value_of("10*cos(30)", kDeg), 5.0 * std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(value_of("asin(0.5)", kDeg), 30.0, 1e-13);
  EXPECT_NEAR(value_of("acos(-1)", kDeg), 180.0, 1e-13);
  EXPECT_NEAR(value_of("atan(1)", kDeg), 45.0, 1e-13);
  EXPECT_NEAR(value_of("atan2(1, -1)", kDeg), 135.0, 1e-13);
  EXPECT_NEAR(value_of("atan2(-1, 0)", kDeg), -90.0, 1e-13);
}

TEST(Expression, TrigonometryInRadians) {
  EXPECT_NEAR(value_of("cos(pi/3)"), 0.5, 1e-15);
  EXPECT_NEAR(value_of("sin(pi/6)"), 0.5, 1e-15);
  EXPECT_NEAR(value_of("cos(60)"), -0.9524129804151563, 1e-15);  // 60 rad, not 60 deg
  EXPECT_NEAR(value_of("asin(0.5)"), kPi / 6, 1e-15);
  EXPECT_NEAR(value_of("atan2(1, -1)"), 3 * kPi / 4, 1e-15);
}

// The byte at fault and a message naming what was expected or found.
void expect_error(const std::string& text, size_t offset, const std::string& phrase) {
  const Evaluation e = evaluate(text, kDeg);
  ASSERT_FALSE(e.ok()) << text << " = " << e.value;
  EXPECT_EQ(e.offset, offset) << text << ": " << e.error;
  EXPECT_NE(e.error.find(phrase), std::string::npos) << text << ": " << e.error;
}

TEST(Expression, SyntaxErrorsAtTheirByte) {
  expect_error("1 + * 2", 4, "expected a number, a name or '(', found '*'");
  expect_error("1 +", 3, "found the end");
  expect_error("", 0, "found the end");
  expect_error("2 3", 2, "expected an operator (+ - * / ^) or the end, found '3'");
  expect_error("2pi", 1, "found 'p'");
  expect_error("2.5.1", 3, "found '.'");
  expect_error("1e", 1, "an exponent needs digits");
  expect_error(".", 0, "'.' without digits");
  expect_error("1e999", 0, "1e999 is outside the range of a number");
  expect_error("60 − 1", 3, "found '−'");  // U+2212 from a copied text: the whole character
}

TEST(Expression, UnbalancedParentheses) {
  expect_error("(1 + 2", 0, "'(' is never closed");
  expect_error("2*(1 + (2)", 2, "'(' is never closed");
  expect_error("1 + 2)", 5, "')' without a matching '('");
  expect_error("(1 2)", 3, "expected ')' or an operator, found '2'");
  expect_error("()", 1, "found ')'");
  expect_error("sqrt(2", 4, "'(' is never closed");
}

TEST(Expression, NamesAndFunctions) {
  expect_error("sqr(2)", 0, "unknown function 'sqr' (functions: sqrt, abs, sin, cos, tan, asin");
  expect_error("1 + e", 4, "unknown name 'e' (the constant pi");
  expect_error("2*sqrt", 2, "'sqrt' is a function: write sqrt(...)");
  expect_error("atan2(1)", 0, "atan2 takes 2 arguments (y, x), not 1");
  expect_error("cos(1, 2)", 0, "cos takes 1 argument (angle), not 2");
  expect_error("PI", 0, "unknown name 'PI'");  // names are lower case
}

// A value that is not finite is an error at the operation that made it.
TEST(Expression, NonFiniteResults) {
  expect_error("1/0", 1, "division by zero");
  expect_error("2 + 1/(3 - 3)", 5, "division by zero");
  expect_error("1 + sqrt(-1)", 4, "sqrt(-1) is not a real number");
  expect_error("asin(2)", 0, "asin(2) is not a real number");
  expect_error("(-8)^(1/3)", 4, "-8 ^ 0.333333 is not a real number");
  expect_error("0^-1", 1, "0 ^ -1 is not a finite number");
  expect_error("1e300 * 1e300", 6, "1e+300 * 1e+300 is not a finite number");
}

// The parser recurses once per sign, power and parenthesis: a deep nesting is refused, never a
// stack overflow.
TEST(Expression, NestingIsBounded) {
  EXPECT_EQ(value_of(std::string(60, '(') + "1" + std::string(60, ')')), 1.0);
  expect_error(std::string(100000, '(') + "1", 64, "nested deeper than 64 levels");
  expect_error(std::string(100000, '-') + "1", 64, "nested deeper than 64 levels");
  std::string powers = "2";
  for (int k = 0; k < 100000; ++k) powers += "^2";
  expect_error(powers, 2 * 64, "nested deeper than 64 levels");
}

}  // namespace
}  // namespace crosslink
