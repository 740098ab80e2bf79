// Limits on what one definition may hold, so that no file can crash the TOML parser, overflow a
// computation to a non-finite value or make validation run for ever. They are fixed, and far
// beyond what any planar linkage needs. (The work of a command has limits of its own, which
// options raise: analytic/reference/budget.h.)
#pragma once

namespace crosslink::limits {

// What reaches the TOML parser. toml++ recurses once per level of a dotted key and overflows
// the stack near 50,000 levels, so the text is screened before it is parsed.
constexpr long kDefinitionBytes = 1 << 20;  // a bundled definition is under 10 kB
constexpr int kKeyParts = 16;               // parts of one dotted key or table header: a.b.c is 3
constexpr int kNesting = 16;                // arrays and inline tables inside one another
// An expression in a number (analytic/model/expression.h) is parsed by recursion too: signs,
// powers' exponents and parentheses inside one another.
constexpr int kExpressionNesting = 64;

// Counts. The solver's Jacobian and its LU are sparse (their work grows with the links), the
// tracer's two SVDs at a sweep's start are dense in 3 coordinates per moving link, validation
// compares names pairwise: 400 links hold IFToMM A02 with N = 160 (321 bars, 481 joints), the
// size its cost is measured at (bench/a02.h).
constexpr int kLinks = 400;
constexpr int kJoints = 800;
constexpr int kPoints = 1000;             // over all links
constexpr int kLines = 1000;              // over all links
constexpr int kTableRows = 10000;         // a table law's rows (each evaluation visits them all)
constexpr int kPolynomialTerms = 20;      // coefficients of a polynomial law
constexpr int kReferences = 10000;        // [[reference]] entries
constexpr int kExpectedPositions = 1000;  // [expect] toggles, change points

// Magnitudes, in SI. Products of them (a = omega^2 r, time = travel / speed) stay finite. The
// solver closes the chain to 1e-12 of its size, which round-off in the link angles allows up to
// about 1e5 rad: a drawing's angles stay well below (1e7 degrees took 47 s to fail). A value the
// driver is swept or solved to is reached by continuation, whose steps analytic/reference/budget.h
// counts.
constexpr double kLength = 1e6;         // m: coordinates, a slider's driver values
constexpr double kSmallestSize = 1e-6;  // m: the mechanism's size (largest drawn distance)
constexpr double kAngle = 1e4;          // rad: angles as drawn, an angular driver's start
constexpr double kDriverValue = 1e8;    // rad: a range, [expect] and [[reference]] values
constexpr double kRate = 1e9;  // rad/s or m/s: the driver's speed, a law's rate, [dynamics] rate
constexpr double kSlowestSpeed = 1e-9;      // rad/s or m/s: a slower speed (or [dynamics] rate) has
                                            // no cycle; a nonzero value that underflows is refused
                                            // too, or it would silently be at rest
constexpr double kAcceleration = 1e18;      // rad/s^2 or m/s^2: a law's acceleration
constexpr double kDuration = 1e9;           // s: a law's duration, a table's times
constexpr double kShortestDuration = 1e-9;  // s: a law's duration, a table's time steps
constexpr double kReferenceValue = 1e30;    // any [[reference]] value, SI
constexpr double kTolerance = 1e6;          // % of peak
// Physics: masses and loads of any machine, far from overflow in m a, k x, F r.
constexpr double kMass = 1e9;      // kg
constexpr double kInertia = 1e12;  // kg m^2
constexpr double kForce = 1e12;    // N: loads, [dynamics] efforts along a slider
constexpr double kTorque = 1e12;   // N m: loads, [dynamics] efforts on a turning link
// Springs and dampers ([[spring]]). A steel bar 1 m^2 in section and 1 m long is 2e11 N/m, so
// no spring of a linkage comes near 1e15 N/m; k x at the largest length (1e6 m) stays 1e21 N.
// A damper of 1e12 N s/m holds 1e3 N at 1 nm/s: far stiffer than any real one, and c v at the
// largest rate stays 1e21 N. Without a limit, 1e308 N s/cm became infinite in SI.
constexpr double kStiffness = 1e15;  // N/m
constexpr double kDamping = 1e12;    // N s/m
constexpr double kGravity = 1e6;     // m/s^2
// Joint friction: Coulomb coefficients of dry and lubricated pairs are below 1.5 (rubber on dry
// asphalt is near 1); 10 is no material's.
constexpr double kFrictionCoefficient = 10.0;

}  // namespace crosslink::limits
