// The MuJoCo scene of a Mechanism, before it becomes MJCF text: the scene graph (sim/scene_graph.h:
// bodies, joints, spanning tree, cuts closed by <connect>, driven coordinate) translated at an
// assembled configuration, with MuJoCo's unit of mass. Internal to crosslink_mujoco.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "sim/scene_graph.h"
#include "sim/settings.h"

namespace crosslink::sim::mujoco_scene {

// A body of the graph as MuJoCo writes it: its points and its assembled pose; mass and inertia in
// the scene's unit of mass (Scene::mass_scale).
struct SceneLink : SceneBody {
  std::vector<Eigen::Vector2d> points;             // by Mechanism point index, local [m]
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();  // (x, y, theta) assembled [m, rad]
};

// A joint of the graph with its assembled value (hinge angle or s), which MuJoCo's qpos holds.
struct SceneJoint : sim::SceneJoint {
  double value = 0.0;
  // Joint friction (a tree joint's): MuJoCo's frictionloss on its degree of freedom, at build its
  // load-independent part in the scene's unit of mass [N m or N] (a run sets it before each step).
  bool friction = false;
  double frictionloss = 0.0;
  bool friction_grows = false;  // with the joint's reaction (set by a run, not in the MJCF)
  // A loop's cut pin with friction: the fixed tendon that carries it, named friction_tendon(),
  // over its relative rotation (relative_angle_terms): a <connect> takes no frictionloss.
  std::vector<std::pair<int, double>> friction_terms;
  std::string friction_tendon() const { return "friction:" + name; }
};

struct Scene {
  std::vector<SceneLink> links;  // index 0 is the ground
  std::vector<SceneJoint> joints;
  std::vector<int> tree_order;  // tree joints, parents before children
  std::vector<int> cuts;        // joints closed by <connect>
  // The driver coordinates MuJoCo holds, one per driver (Mechanism::drivers order), each
  // coordinate = sign * (driver - offset): the driven tree joint's value, or, for a floating
  // link's angle, the fixed tendon over the hinges on the tree's path from the ground to the link
  // (DrivenCoordinate::terms): their sum is the link's absolute angle, so the definition's own
  // driver is driven and its torque read.
  std::vector<DrivenCoordinate> driven;
  // Each driver's equality (and a floating link's tendon) name: "driver" for one driver,
  // "driver:<name>" for each of several.
  std::vector<std::string> driver_names;
  // Gear pairs and racks: each a fixed tendon over its terms, named after its joint, held at its
  // length at qpos0 (the assembled start) by a tendon equality of the same name with the loop
  // constraints' solref and solimp.
  std::vector<SceneCoupling> couplings;
  // Cam joints: their shapes (SceneContact), geom contact_geom(c, true) on the cam (a profile
  // that is not a disc: the mesh of that name) and contact_geom(c, false) on the follower, and one
  // <pair> with condim 1 (frictionless: the joint slides and rolls free) and the contact solref
  // and solimp.
  std::vector<SceneContact> contacts;
  // Pins in curved slots: each a spatial tendon from site arc_site(a, true) at the arc's centre
  // to site arc_site(a, false) at the pin, named after its joint, held at its length at qpos0
  // (the radius, assembled) by a tendon equality of the same name with the loop constraints'
  // solref and solimp: one row, and no body between.
  std::vector<SceneArc> arcs;
  double size = 1.0;  // Mechanism::size() [m]
  // The scene's unit of mass in kg is 1 / mass_scale: every mass and inertia of the scene is the
  // mechanism's times mass_scale, and so is every force MuJoCo applies or reports. MuJoCo refuses
  // a body whose mass or inertia is under mjMINVAL (1e-15): a crank-rocker drawn at 1e-5 of its
  // size (a watch, a MEMS part) has link inertias of 2e-16 kg m^2. The motion does not depend on
  // the unit of mass, and a power of 2 scales every product exactly; 1 when nothing is that
  // light.
  double mass_scale = 1.0;
};

// The geom of contact c on its cam (`cam`) or its follower: "cam:<joint>", "follower:<joint>".
std::string contact_geom(const Mechanism& mechanism, const SceneContact& c, bool cam);

// The site of arc a at its centre (`centre`) or at its pin: "<joint>:centre", "<joint>:pin".
std::string arc_site(const Mechanism& mechanism, const SceneArc& a, bool centre);

// Builds the scene from the mechanism and the absolute coordinates q (x, y, theta per moving
// link, Mechanism order) of an assembled configuration; a cam whose profile is not a disc is a
// mesh of `cam_facets` facets a turn. Throws std::runtime_error when MuJoCo cannot realise the
// mechanism (the message says why).
Scene build_scene(const Mechanism& mechanism, const Eigen::VectorXd& q,
                  int cam_facets = kDefaultCamFacets);

// Just the realisability check of build_scene (no configuration needed).
bool realisable(const Mechanism& mechanism, std::string* why);

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
  Eigen::Vector2d friction_solref = Eigen::Vector2d(0.02, 1.0);  // frictionloss rows
  Eigen::Vector2d contact_solref = Eigen::Vector2d(0.02, 1.0);   // cams' contact pairs
  Eigen::Matrix<double, 5, 1> contact_solimp;
  // Per driver: the rotor inertia on its driven tree joint [kg m^2, or kg] (none: 0).
  std::vector<double> driver_armature;
  Eigen::Vector2d gravity = Eigen::Vector2d::Zero();  // the Mechanism's [m/s^2]; zero: off
  // Whether the driver equality is written: a forward-dynamics scene has none (the coordinate
  // moves freely under the applied effort).
  bool driven = true;
  std::optional<Standalone> standalone;  // the export's additions; none for crosslink's own runs
};

// The MJCF text. Joint names are the scene joints' names; the driver equalities are
// Scene::driver_names.
// With `standalone`, the clock is a hinge "clock" and the driver a fixed tendon "driver".
std::string to_mjcf(const Mechanism& mechanism, const Scene& scene, const MjcfOptions& options);

}  // namespace crosslink::sim::mujoco_scene
