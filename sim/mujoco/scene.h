// The MuJoCo scene of a Mechanism, before it becomes MJCF text: scene links (the mechanism's
// links plus one block per pin-in-slot), scene joints, the spanning tree that MuJoCo's joints
// realise, the cut joints closed by <connect>, and the driven joint. Internal to crosslink_mujoco.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analytic/mechanism.h"
#include "analytic/trajectory.h"

namespace crosslink::sim::mujoco_scene {

// A rigid body of the scene. Its body frame is the link frame of the Mechanism (a block's frame
// sits at its pin with the guide's orientation), so a point's local coordinates carry over.
struct SceneLink {
  std::string name;
  int source = -1;  // Mechanism link index; -1 for a pin-in-slot block
  bool ground = false;
  std::vector<Eigen::Vector2d> points;             // by Mechanism point index, local [m]
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();  // (x, y, theta) assembled [m, rad]
  // The link's mass properties (Link::mass, shared with the exact solver); a block has
  // auxiliary_mass() at its pin and a negligible inertia.
  double mass = 0.0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // local [m]
  double inertia = 0.0;                              // about z through the centre [kg m^2]
  // A block: it turns with link `guide` and carries point `pin_point` of link `pin` (scene
  // indices), which is where its frame sits.
  int guide = -1, pin = -1;
  Eigen::Vector2d pin_point = Eigen::Vector2d::Zero();
};

// A one-freedom joint between scene links a and b.
//   hinge: point ua of a coincides with point ub of b; value = theta_b - theta_a [rad]
//   slide: point ub of b stays on the line (origin, direction) of a, with theta_b - theta_a
//          fixed; value = s = direction . (P_b - origin) [m]
struct SceneJoint {
  enum class Kind { hinge, slide };
  Kind kind = Kind::hinge;
  std::string name;
  int source = -1;  // the Mechanism joint it realises (a pin-in-slot: both its slide and pin)
  int a = -1, b = -1;
  Eigen::Vector2d ua = Eigen::Vector2d::Zero();  // hinge: local point on a
  Eigen::Vector2d ub = Eigen::Vector2d::Zero();  // local point on b
  Eigen::Vector2d origin = Eigen::Vector2d::Zero(), direction = Eigen::Vector2d::UnitX();
  double relative_angle = 0.0;  // theta_b - theta_a (slide) [rad]
  double value = 0.0;           // assembled value (hinge angle or s)
  bool in_tree = false;
  int parent = -1, child = -1;  // tree joints: scene link indices (parent nearer the ground)
};

// How the driver coordinate MuJoCo holds follows the definition's driver:
// coordinate = sign * (driver - offset). The coordinate is the driven tree joint's value, or,
// with `tendon` (the angle of a link without a ground pivot), the fixed tendon over the hinges on
// the tree's path from the ground to the link (driver_tendon()): their sum is the link's
// absolute angle, so the definition's own driver is driven and its torque read.
struct DrivenJoint {
  int joint = -1;  // scene joint index: the driven joint, or (tendon) a hinge of the link
  double sign = 1.0, offset = 0.0;
  bool tendon = false;
};

struct Scene {
  std::vector<SceneLink> links;  // index 0 is the ground
  std::vector<SceneJoint> joints;
  std::vector<int> tree_order;  // tree joints, parents before children
  std::vector<int> cuts;        // joints closed by <connect>
  DrivenJoint driven;
  double size = 1.0;  // Mechanism::size() [m]
  // The scene's unit of mass in kg is 1 / mass_scale: every mass and inertia of the scene is the
  // mechanism's times mass_scale, and so is every force MuJoCo applies or reports. MuJoCo refuses
  // a body whose mass or inertia is under mjMINVAL (1e-15): a crank-rocker drawn at 1e-5 of its
  // size (a watch, a MEMS part) has link inertias of 2e-16 kg m^2. The motion does not depend on
  // the unit of mass, and a power of 2 scales every product exactly; 1 when nothing is that
  // light.
  double mass_scale = 1.0;
};

// Builds the scene from the mechanism and the absolute coordinates q (x, y, theta per moving
// link, Mechanism order) of an assembled configuration. Throws std::runtime_error when MuJoCo
// cannot realise the mechanism (the message says why).
Scene build_scene(const Mechanism& mechanism, const Eigen::VectorXd& q);

// Just the realisability check of build_scene (no configuration needed).
bool realisable(const Mechanism& mechanism, std::string* why);

// The driver coordinate as a fixed tendon: (scene joint, coefficient) pairs whose weighted sum
// is the coordinate. A tree-joint driver is its joint; a floating link's angle (tendon) is the
// sum of the hinges on the tree path from the ground to the link.
std::vector<std::pair<int, double>> driver_tendon(const Mechanism& mechanism, const Scene& scene);

// The tree joints from scene link `link` up to the ground, nearest first.
std::vector<int> tree_path(const Scene& scene, int link);

// What turns the MJCF into a scene for MuJoCo alone (the export; docs/engines.md, "The exported
// scene"): a clock hinge that moves the driver coordinate through the driver equality (crosslink's
// runs set the equality's target every step instead), drawn bars, and a keyframe at speed.
struct Clock {
  double inertia = 1.0;    // [kg m^2]
  double damping = 0.0;    // constant speed: a servo, torque - damping x rate [N m s]
  double torque = 0.0;     //   with torque = damping x speed [N m]
  double stiffness = 0.0;  // an oscillation between the sweep's ends: a spring [N m]
  double springref = 0.0;  //   centred on this clock angle [rad]
  double rate = 0.0;       // the keyframe's clock rate [rad/s]
};
struct Standalone {
  std::optional<Clock> clock;  // none: a dynamics case, whose coordinate moves freely
  std::vector<double> rates;   // per scene joint: its rate at the start (the keyframe) [rad/s, m/s]
  double radius = 0.0;         // of the drawn bars [m]
  std::vector<std::array<Eigen::Vector2d, 2>> guides;  // ground lines' drawn segments, world [m]
};

struct MjcfOptions {
  double dt = 1e-3;
  std::string integrator = "Euler", solver = "Newton";
  int iterations = 20;
  double tolerance = 1e-10;
  Eigen::Vector2d solref = Eigen::Vector2d(-1e6, -1e3);         // loop constraints
  Eigen::Matrix<double, 5, 1> solimp;                           // loop constraints
  Eigen::Vector2d driver_solref = Eigen::Vector2d(-1e6, -1e3);  // driver equality
  Eigen::Matrix<double, 5, 1> driver_solimp;
  double driver_armature = 0.0;  // rotor inertia on the driven tree joint [kg m^2, or kg]
  Eigen::Vector2d gravity = Eigen::Vector2d::Zero();  // the Mechanism's [m/s^2]; zero: off
  // Whether the driver equality is written: a forward-dynamics scene has none (the coordinate
  // moves freely under the applied effort).
  bool driven = true;
  std::optional<Standalone> standalone;  // the export's additions; none for crosslink's own runs
};

// The MJCF text. Joint names are the scene joints' names; the driver equality is "driver".
// With `standalone`, the clock is a hinge "clock" and the driver a fixed tendon "driver".
std::string to_mjcf(const Mechanism& mechanism, const Scene& scene, const MjcfOptions& options);

}  // namespace crosslink::sim::mujoco_scene
