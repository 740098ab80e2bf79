// Exact kinematics by closed-form Assur groups of class II (dyads), solved in sequence from the
// driver outward.
//
// Decomposition. Links are placed one group at a time; a group's outer joints attach it to links
// already placed (the ground first). What a joint to a placed link K asks of an unplaced link U
// is a "tie":
//   pin    a point of U at a known world point (a revolute joint with K)          2 equations
//   angle  U's angle known (a prismatic joint's fixed relative angle, a driver,     1 equation
//          a gear pair whose other gear and carrier are placed, or a rack and pinion
//          whose rack and guide are placed: the pinion turns by the rack's travel)
//   slot   a point on a line, one of the two on U (the line part of a prismatic or 1 equation
//          pin-in-slot joint)
// A prismatic joint with a known travel along its line (a slider driver's, or the travel a rack
// and pinion gives the rack once the pinion and the guide are placed) is a pin at a moving point
// of the guide's line, not a slot.
// Groups, in the order they are searched:
//   input       pin + angle (the driver's input link, a link welded to a placed one, a gear or
//               pinion turned by a placed mate, a rack moved by a placed pinion)
//   pivot_slot  pin + slot: one link and a slotted pin or a slotted link (the block of an R-P
//               pair taken as a pin-in-slot)                                   circle-line, tangent
//   slide_slot  angle + slot + slot                                                       line-line
//   dyad        two links joined by an inner revolute or prismatic joint, each held by a pin (R)
//               or by angle + slot (P): RRR, RRP, PRR, PRP (inner R: circle-circle, circle-line,
//               line-line) and RPR, RPP, PPR (inner P: tangent, line-line). PPP does not place.
// A chain where no such group remains (a class-III group such as the Wanzer needle bar's
// triangle with three slotted pins, or a driver on a floating link such as the polycentric
// hinge's theta4) does not decompose: Decomposition::reason says why and Newton solves it.
//
// Assembly modes. A group with two solutions (circle-circle, circle-line, tangent) has an
// assembly_mode of +1 or -1, read off the assembled position (NewtonSolver::assemble at the
// driver's start value, i.e. the drawing) and then followed continuously: at each pose both
// solutions are computed and the one nearest the pose predicted from the previous two samples is
// taken; when that is the other mode, the change is reported (it happens only where the two
// solutions meet, a toggle or change point).
//
// Velocity and acceleration. Each link of a group moves with one unknown rate of its own tie
// (omega about a pin, or the slide rate along a slot), so a dyad's rates solve a 2x2 linear system
// (the inner joint's two velocity equations), a single link's a 1x1. The accelerations solve the
// same matrix; the velocity-squared and Coriolis terms (2 omega sdot of a slide on a turning line)
// come from planar.h's BodyMotion and project.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/planar.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

// What a joint to a placed link asks of an unplaced link (see the header comment).
struct Tie {
  enum class Kind { pin, angle, slot };
  Kind kind = Kind::pin;
  int joint = -1;  // the joint it comes from (-1: the link_angle driver)
  // pin: point `on_link` of the unplaced link sits at point `on_known` of link `known`; when
  // `driver_slide`, at a travel s along line `line` of `known` instead: the driver's
  // displacement, or with `rack` (a rack's slide) s = ratio (theta_pinion - theta_guide) + phase
  // of that rack and pinion joint, its pinion and guide placed.
  // angle: theta = known_scale * theta_known + offset + driver_sign * driver value (known = -1:
  // no link), plus second_scale * theta_second for a gear pair's (its other gear the known
  // link, its carrier the second: the rolling of the pitch circles, linear in both), plus
  // travel_scale * s for a pinion's (`rack` its rack and pinion joint, s the rack's travel read
  // off the placed guide and rack, the known link the guide).
  // slot: the line part of `joint`; the unplaced link is its slider when `slider_is_unplaced`.
  int known = -1;
  int on_known = -1, on_link = -1, line = -1;
  bool driver_slide = false;
  double offset = 0.0, driver_sign = 0.0;
  bool slider_is_unplaced = false;
  double known_scale = 1.0;
  int second = -1;
  double second_scale = 0.0;
  int rack = -1;  // the rack and pinion joint whose travel places it (a pin) or turns it (an angle)
  double travel_scale = 0.0;
};

// One group of the decomposition, placed once the links its ties name are placed.
struct AssurGroup {
  enum class Kind { input, pivot_slot, slide_slot, dyad };
  Kind kind = Kind::input;
  int link[2] = {-1, -1};    // the unplaced links (dyad: two; others: link[0])
  std::vector<Tie> ties[2];  // the ties of each link to placed links
  int inner = -1;            // dyad: the joint between link[0] and link[1]
  // Per link, the index in ties[i] of its pin, angle and slot tie (-1: none); `equation` is the
  // second slot of a pivot_slot or slide_slot group (the one its rate is solved from).
  int pin[2] = {-1, -1}, angle[2] = {-1, -1}, slot[2] = {-1, -1}, equation = -1;
  bool two_solutions = false;  // it has an assembly mode
  std::string name;            // "RRR dyad coupler + rocker (B, C, D)"
};

struct Decomposition {
  bool complete = false;           // every link is placed by a group
  std::vector<AssurGroup> groups;  // in solving order, from the driver outward
  std::string reason;              // why it does not decompose (empty when complete)
};
// From the ground and the driver outward; topology only (geometry decides modes, not groups).
Decomposition decompose(const Mechanism& mechanism);

// Working storage for one mechanism, sized once; a solve allocates nothing.
struct DyadState {
  explicit DyadState(const Mechanism& mechanism);

  KinematicState kinematics;       // q, qdot, qddot and the driver, as Newton's
  std::vector<BodyMotion> motion;  // per link (ground included), the solved motion
  std::vector<int> assembly_mode;  // per group: +1, -1, or 0 (one solution)
  // Per group, the solution that tells its modes apart (the solved point, or the direction of a
  // tangent line times the mechanism's size) at the last two accepted samples, for the
  // continuity prediction; `history` counts how many are valid (0, 1, 2).
  std::vector<Eigen::Vector2d> previous, before_previous;
  double previous_driver = 0.0, before_previous_driver = 0.0;  // where they were solved
  int history = 0;
  // Of the last solve_position: over the two-solution groups, the largest ratio of the chosen
  // root's distance from the prediction to the other root's (0: clear; near 1: continuity cannot
  // tell the two assemblies apart at this step).
  double ambiguity = 0.0;
  double smallest_sine = 1.0;  // of the last solve_position: min over groups (0 = singular)
  int folding_group = -1;      // the two-solution group it belongs to (-1: none)
  // Mode changes of the last solve_position: group index, old mode, new mode.
  struct ModeChange {
    int group, from, to;
    double driver;  // where it happened [rad or m]
  };
  std::vector<ModeChange> mode_changes;
  // Per group, the matrix of its rate equations at the last solve_velocity (valid until the next
  // solve_position): solve_acceleration reuses it.
  std::vector<Eigen::Matrix2d> rate_matrix;
  bool rate_matrix_valid = false;
};

class DyadSolver {
 public:
  // The decomposition must be complete (throws std::invalid_argument otherwise). A pose whose
  // smallest group sine (of the angle at which its two loci meet; 0 at a toggle or change
  // point) is below `singular_sine` is singular: positions are given, rates are not.
  DyadSolver(const Mechanism& mechanism, Decomposition decomposition, double singular_sine = 1e-7);

  const Mechanism& mechanism() const { return mechanism_; }
  const Decomposition& decomposition() const { return decomposition_; }

  // Reads every group's assembly mode off a solved (assembled) Newton state and takes its link
  // angles as the reference for unwrapping.
  void set_modes(const KinematicState& assembled, DyadState& state) const;

  // Position of every group at state.kinematics.driver, in order, following the modes.
  SolveReport solve_position(DyadState& state) const;
  void solve_velocity(DyadState& state) const;
  void solve_acceleration(DyadState& state) const;
  SolveReport solve(DyadState& state) const;  // all three

  // Describes group g's mode: "+1 (C left of B -> D)".
  std::string describe_mode(int group, int mode) const;

 private:
  struct Roots;
  // Per group, what does not change from pose to pose (its ties and the link-local geometry its
  // roots and placement use), built once by the constructor.
  struct Plan {
    struct Side {
      Tie pin, angle;  // copies of the link's pin and angle ties (when it has them)
      bool has_pin = false, has_angle = false;
      Eigen::Vector2d pin_local = Eigen::Vector2d::Zero();  // the pin's point on this link
      Eigen::Vector2d pin_known = Eigen::Vector2d::Zero();  // and on its known link
      // The point that place() turns about the pin (dyad: the inner joint's; pivot_slot: the
      // slotted pin's): its distance from the pin and its angle in the link's frame from it.
      double radius = 0.0, turn_angle = 0.0;
    };
    Side side[2];
    int unknowns = 0;  // of the rate equations: 0 (input), 1 (single link), 2 (dyad)
    // An RRR dyad (two pinned links, no angle ties): rates in closed form (rrr_rates), with its
    // inner joint's point on each link.
    bool rrr = false;
    Eigen::Vector2d inner[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    // An input group (one link, a pin and an angle tie): rates straight from them (input_rates).
    bool input = false;
  };
  // A link's motion at a given unknown rate (or its derivative): the part that does not depend
  // on it, worked out once per group and pose (see prepare_rate).
  struct Rate;
  // Both solutions of group g from the links placed before it (count 0: it cannot assemble).
  void roots(const AssurGroup& g, const Plan& plan, DyadState& state, Roots& out) const;
  // Places g's links on root `index`.
  void place(const AssurGroup& g, const Plan& plan, const Roots& roots, int index,
             DyadState& state) const;
  // Rates (velocity) and their derivatives (acceleration) of g's links from its unknowns.
  Rate prepare_rate(const AssurGroup& g, const Plan& plan, int i, bool accel,
                    DyadState& state) const;
  void rrr_rates(const AssurGroup& g, const Plan& plan, bool accel, DyadState& state) const;
  void input_rates(const AssurGroup& g, const Plan& plan, bool accel, DyadState& state) const;
  Eigen::Vector2d rate_residual(const AssurGroup& g, const DyadState& state, bool accel) const;
  // Motions -> kinematics.q, qdot or qddot (each copied once per pose).
  void publish_position(DyadState& state) const;
  void publish_velocity(DyadState& state) const;
  void publish_acceleration(DyadState& state) const;

  const Mechanism& mechanism_;
  Decomposition decomposition_;
  std::vector<Plan> plans_;                  // per group
  std::vector<std::pair<int, int>> moving_;  // (link, moving index) of every moving link
  double size_;                              // Mechanism::size() [m]
  double singular_sine_;
};

}  // namespace crosslink
