// The engine-neutral scene of a Mechanism: the rigid bodies an engine builds (the links, plus one
// block per pin-in-slot), the joints between them, the spanning tree an engine with joint
// coordinates realises, the loop joints it leaves out of the tree (cuts, closed by a constraint)
// and the driven coordinates. Every topology decision is made here, once; an engine translates
// the graph into its own model and decides nothing about topology (docs/decisions.md, "Scene
// graph").
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/planar.h"

namespace crosslink::sim {

// A rigid body. Its frame is the link frame of the Mechanism, so a point's local coordinates
// carry over; a block's frame sits at its pin: a straight slot's turns with its guide, a curved
// slot's points its x axis from the arc's centre to the pin.
struct SceneBody {
  std::string name;
  int source = -1;  // Mechanism link index; -1 for a block
  bool ground = false;
  // The mass model every engine gets: the link's scene_mass() (sim/forces.h); a block has
  // auxiliary_mass() at its pin and a negligible inertia.
  double mass = 0.0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // local [m]
  double inertia = 0.0;                              // about z through the centre [kg m^2]
  // A block: it realises joint `joint` (Mechanism index; a pin-in-slot, or a point on a circle:
  // arc_geometry) on body `guide` and carries point `pin_point` of body `pin`, which is where its
  // frame sits. A straight slot's block slides on the guide's line; a circle's is an arm hinged
  // at its centre, its radius long (a point on a circle is a binary link to the centre).
  int joint = -1, guide = -1, pin = -1;
  Eigen::Vector2d pin_point = Eigen::Vector2d::Zero();
};

// A joint between bodies a and b.
//   hinge:  point ua of a coincides with point ub of b; value = theta_b - theta_a [rad]
//   slide:  point ub of b stays on the line (origin, direction) of a, with theta_b - theta_a
//           fixed at relative_angle; value = s = direction . (P_b - origin) [m]
//   planar: b moves freely in the plane of a (the ground); its value is theta_b [rad]. Only
//           TreePolicy::planar_joints adds one.
// A coupling between joints' values (a gear pair, a rack and pinion) is no joint of the graph: it
// is a SceneCoupling, never in the tree, which every engine closes as a constraint.
struct SceneJoint {
  enum class Kind { hinge, slide, planar };
  Kind kind = Kind::hinge;
  std::string name;
  int source = -1;  // the Mechanism joint it realises (a pin-in-slot: both its slide and pin)
  int a = -1, b = -1;
  Eigen::Vector2d ua = Eigen::Vector2d::Zero();  // hinge: local point on a
  Eigen::Vector2d ub = Eigen::Vector2d::Zero();  // local point on b
  Eigen::Vector2d origin = Eigen::Vector2d::Zero(), direction = Eigen::Vector2d::UnitX();
  double relative_angle = 0.0;  // slide: theta_b - theta_a [rad]
  // The spanning tree: a tree joint's parent body (nearer the ground) and child.
  bool in_tree = false;
  int parent = -1, child = -1;
  // The joint between a block and its guide (a slot's slide, an arc's centre hinge). The block
  // is massless but for 1e-6 of a link, so this joint carries its pin's force, which an engine
  // reads at the pin's joint.
  bool block_guide = false;
};

// A driver realised in the scene: the joint values whose weighted sum is the driver's value
// less `offset` (sum of coefficient x value = driver - offset). A joint angle, a slider or a link
// angle at a ground pivot is one joint (coefficient +-1); the angle of a floating link (no ground
// pivot) is the sum of the hinges on the tree's path from the ground to it, or, with
// TreePolicy::planar_joints, the angle of its planar ground joint.
struct DrivenCoordinate {
  int joint = -1;       // the joint that goes first into the tree: the driven one, or (floating) a
                        // hinge of the link, or its planar ground joint
  double sign = 1.0;    // the coefficient of `joint`
  double offset = 0.0;  // the measured direction's angle in its link's frame [rad]; 0 for a slider
  bool floating = false;  // the angle of a link without a ground pivot
  int body = -1;          // floating: the link's body
  std::vector<int> path;  // floating: the tree joints from the body up to the ground, nearest first
  std::vector<std::pair<int, double>> terms;  // (joint, coefficient)
};

// A gear pair or a rack and pinion (JointType::gear, rack_pinion) over the tree's coordinates:
// the coupling phi = (theta_a - theta_c) + ratio (theta_b - theta_c) of a gear pair, or
// s - ratio (theta_a - theta_c) of a rack (theta_c the carrier's angle, s the rack's slide), is
// the sum of coefficient x value over `terms`, tree joints only (a body's angle is the sum of the
// hinges on its tree path, or its planar joint's), plus a constant the engine takes from its
// assembled start. An engine holds it there, as it holds a cut closed.
struct SceneCoupling {
  int source = -1;                            // the Mechanism joint
  std::vector<std::pair<int, double>> terms;  // (scene joint, coefficient), each joint once
  // d phi / d theta of the gearing's first moving gear (the first gear unless it is the ground):
  // the coupling's generalised force times it is the couple on that gear (pass_tooth_force).
  double on_first = 1.0;
  int slide = -1;  // a rack: its slide's scene joint (coefficient 1), whose force carries the
                   // coupling's push along the line besides its own reaction
};

// A cam joint (JointType::cam) realised as contact between two shapes, never in the tree: the
// follower is held on the cam by its spring or gravity through the contact, which only pushes, as
// the joint does. So far the pairs whose contact is exact, each shape centred in the plane z = 0:
// an eccentric cam's disc, a sphere, and a roller, another sphere, whose distance is
// |C_follower - C_cam| - (R + r) along the line of centres (a knife edge, radius 0, is a sphere of
// a quarter of the disc's radius on a disc smaller by as much: the same distance and normal, an
// engine's spheres being of positive size); or a flat face, a box whose face lies on the face's
// line, a plate a quarter of the disc's radius thick behind it and long enough for any contact
// along it, whose distance is n . (C_cam - O) - R along the face's normal (docs/cams.md, "The
// engines' contact"). Every engine builds these shapes as they are.
struct SceneContact {
  int source = -1;                                       // the Mechanism joint
  int cam = -1, follower = -1;                           // bodies
  Eigen::Vector2d cam_centre = Eigen::Vector2d::Zero();  // the disc's sphere, local on cam
  double cam_radius = 0.0;                               // [m]
  // The follower's sphere, or (face) its box: its centre, local on the follower [m].
  Eigen::Vector2d follower_centre = Eigen::Vector2d::Zero();
  double follower_radius = 0.0;  // the sphere's [m]
  bool face = false;
  double box_angle = 0.0;  // the box's x axis (along the face) in the follower's frame [rad]
  Eigen::Vector3d box_half = Eigen::Vector3d::Zero();  // its half sizes along x, y, z [m]
  // How far ahead an engine whose contact is made only where its shapes overlap seeks it, to make
  // it speculative (ODE, Bullet: the disc collided larger by it, the gap given back) [m].
  double margin = 0.0;
  // A profile that is not a disc (TreePolicy::cam_facets): the cam is a prism over this convex
  // polygon, local on the cam, counterclockwise, its vertices on the profile (a knife edge's
  // moved in by the sphere's radius), `cam_half_thickness` either side of z = 0, instead of the
  // disc's sphere. Its facets bend the profile's normal by up to half a facet's turn.
  std::vector<Eigen::Vector2d> cam_polygon;
  double cam_half_thickness = 0.0;  // [m]
  // A flat face held on its disc both ways (closure = "form": a yoke) is two contacts of one
  // joint: the face's, and this far one's, its face's line moved the disc's diameter across the
  // disc and its box beyond it (box_angle turned half a turn: its normal away from the cam).
  bool far = false;
};

// A point of one link held on a circle of another: a pin in a curved slot, or the centre of a
// roller (or a knife edge) in a groove cut round a disc, a form-closed eccentric cam, which is the
// same pair (docs/cams.md, "Circular slots and eccentric cams"): point `point` of the joint's
// link_b stays `radius` from `centre` of its link_a (local [m]). A force-closed cam, a flat face
// and any other profile are none: contact holds them.
struct ArcGeometry {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero(), point = Eigen::Vector2d::Zero();
  double radius = 0.0;
};
std::optional<ArcGeometry> arc_geometry(const Mechanism& mechanism, const Joint& joint);

// A point on a circle (arc_geometry) held by a distance row of the engine's own
// (TreePolicy::arc_rows): `point` of body `pin` stays `radius` from `centre` of body `guide`.
struct SceneArc : ArcGeometry {
  int source = -1;           // the Mechanism joint
  int guide = -1, pin = -1;  // bodies
};

// Linear couplings of coordinates, each a row of (coordinate, coefficient) terms held at zero
// rate, recombined for an engine whose coupling joins at most two coordinates: a planetary
// train's gear pair on a moving carrier spans three (sun, planet, carrier), but once the train's
// other pair has tied the planet to the carrier, the first less a multiple of the second ties the
// sun to the carrier alone (Willis' formula). Each output row is a combination of the input rows
// (rows = mix x input), and the recombination is invertible, so the engine holds the same
// motion; its multipliers lambda give the input rows' as mix^T lambda.
struct CouplingRows {
  std::vector<std::vector<std::pair<int, double>>> rows;
  Eigen::MatrixXd mix;  // output row i = sum_k mix(i, k) input row k
};
// `rows` recombined so that each holds at most `most` terms, or the index of an input row no
// recombination brings down to that (-1 on success, with `out` filled).
int reduce_couplings(const std::vector<std::vector<std::pair<int, double>>>& rows, int most,
                     CouplingRows& out);

// How an engine's tree is to be grown: each choice below is where the two engines' models differ,
// kept because changing either would change that engine's numbers (docs/decisions.md, "Scene
// graph").
struct TreePolicy {
  // After the driven joint and the slides, the hinges to the ground before the others (Bullet's
  // multibody: each ground pivot roots its own multibody).
  bool ground_pivots_first = false;
  // A floating link's driven angle is the angle of a planar joint from the ground to it (Bullet),
  // instead of the sum of the hinges on its tree path (MuJoCo's fixed tendon).
  bool planar_joints = false;
  // No loop closes inside one multibody (a subtree hanging from the ground): such a loop is split
  // by putting its deeper end on a planar ground joint (Bullet's multibody MLCP solve gets those
  // loops wrong). Tree joints are then ordered by depth.
  bool split_loops = false;
  // Cam joints become SceneContacts (the engine realises contact); else a cam is refused.
  bool contacts = false;
  // A point on a circle (arc_geometry: a pin-in-arc, a grooved disc's roller) is a SceneArc, a
  // distance row the engine holds itself (MuJoCo's spatial tendon), instead of an arm between two
  // hinges: MuJoCo's equality rows keep a softness in proportion to their inverse inertia, and an
  // arm's (auxiliary_mass()) lets the row give way.
  bool arc_rows = false;
  // A cam whose profile is not a disc becomes a convex prism of this many facets a turn
  // (SceneContact::cam_polygon: the engine's mesh); 0: refused, for the reason `no_mesh` gives
  // (what was measured of the engine's own convex contact).
  int cam_facets = 0;
  std::string_view no_mesh = "which it does not build yet";
};

struct SceneGraph {
  // Bodies: the ground (0), the moving links in Mechanism order, then one block per pin-in-slot
  // or (without TreePolicy::arc_rows) point on a circle, in joint order.
  std::vector<SceneBody> bodies;
  // Joints in Mechanism order, a pin-in-slot as its slide (guide to block) then its pin (block
  // to pin link), a point on a circle as its centre hinge (guide to block) then its pin; planar
  // joints last.
  std::vector<SceneJoint> joints;
  // The spanning tree, the minimum spanning tree under the preference: the driven joints first
  // (so the driver acts on a joint of the tree), then slides and planar joints (so every cut is
  // a hinge, which a point constraint closes exactly), then (ground_pivots_first) the hinges to
  // the ground, then the other hinges; each group in joint order.
  std::vector<int> tree_order;           // tree joints, parents before children
  std::vector<int> cuts;                 // joints left out of the tree, in joint order
  std::vector<DrivenCoordinate> driven;  // per driver of the Mechanism
  std::vector<SceneCoupling> couplings;  // per gear pair or rack, in joint order
  std::vector<SceneContact> contacts;    // per cam joint (TreePolicy::contacts), in joint order
  std::vector<SceneArc> arcs;            // per point on a circle (TreePolicy::arc_rows)
  // A slide among the cuts (a loop of slides only), which no point constraint closes; -1: none.
  int cut_slide = -1;
  // split_loops: "" or why the loops could not be split (the graph is then the unsplit one).
  std::string split_error;
};

// A body's motion from the Mechanism's coordinates q (and rates qdot, when given): a link's, or a
// block's, which sits at its pin and turns with its guide (a straight slot) or with the line
// from the arc's centre to the pin (a curved slot).
BodyMotion body_motion(const Mechanism& mechanism, const SceneBody& body, const Eigen::VectorXd& q,
                       const Eigen::VectorXd* qdot = nullptr);

// Hinge `joint`'s value, theta_b - theta_a, over the tree's coordinates: (scene joint,
// coefficient) terms, the hinges (or planar joints) on the paths from its bodies to the ground.
// An engine holds a cut pin's relative rotation so (MuJoCo's fixed tendon for its friction).
std::vector<std::pair<int, double>> relative_angle_terms(const SceneGraph& g, int joint);

// The scene graph of `mechanism` under `policy`. Throws std::runtime_error when no engine can
// realise it: a driver that no joint of the scene moves, or bodies not joined to the ground.
SceneGraph scene_graph(const Mechanism& mechanism, const TreePolicy& policy = {});

}  // namespace crosslink::sim
