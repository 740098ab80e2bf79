// Bullet 3.24's btMultiBodyJointFeedback checked against an exact reaction, the check behind
// crosslink's choice to read no forces in the multibody formulation (docs/engines.md, "Forces").
// Upstream reports it at twice the applied torque (bullet3 issues 2966, 4604); btMultiBody.cpp
// (3.24, computeAccelerationsArticulatedBodyAlgorithmMultiDof) writes the feedback in the step's
// first pass and adds to it in the constraint pass, whose bias force holds the velocity terms
// again. On a pendulum that is the centripetal force, read twice.
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>
#include <BulletCollision/CollisionShapes/btEmptyShape.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyJointFeedback.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

namespace {

constexpr double kMass = 2.0, kCom = 0.5, kInertia = 0.25, kGravity = 9.81;  // SI

// A bar pinned to the ground at the origin, turning about z, its centre of mass kCom along its
// x axis; one step of dt from angle q (from the x axis) and rate w, reading the feedback of
// that step: the force the ground exerts on the bar, world axes, and the rate the step ends at.
struct Reading {
  Eigen::Vector2d force;
  double rate;
};
Reading feedback_force(double q, double w, double dt) {
  btDefaultCollisionConfiguration collision;
  btCollisionDispatcher dispatcher(&collision);
  btDbvtBroadphase broadphase;
  btMultiBodyConstraintSolver solver;
  btMultiBodyDynamicsWorld world(&dispatcher, &broadphase, &solver, &collision);
  world.setGravity(btVector3(0, -kGravity, 0));
  world.getSolverInfo().m_jointFeedbackInWorldSpace = true;
  btMultiBody bar(1, 0.0, btVector3(0, 0, 0), true, false);
  bar.setupRevolute(0, kMass, btVector3(kInertia, kInertia, kInertia), -1,
                    btQuaternion::getIdentity(), btVector3(0, 0, 1), btVector3(0, 0, 0),
                    btVector3(kCom, 0, 0), true);
  btMultiBodyJointFeedback feedback;
  bar.getLink(0).m_jointFeedback = &feedback;
  bar.setLinearDamping(0.0);
  bar.setAngularDamping(0.0);
  bar.setMaxCoordinateVelocity(1e300);
  bar.setUseGyroTerm(false);
  bar.finalizeMultiDof();
  bar.setJointPos(0, q);
  bar.setJointVel(0, w);
  world.addMultiBody(&bar);
  btAlignedObjectArray<btQuaternion> rot;
  btAlignedObjectArray<btVector3> org;
  bar.forwardKinematics(rot, org);
  btEmptyShape empty;
  btMultiBodyLinkCollider collider(&bar, 0);  // as crosslink's scene: every link has one
  collider.setCollisionShape(&empty);
  collider.setWorldTransform(bar.getLink(0).m_cachedWorldTransform);
  world.addCollisionObject(&collider, 0, 0);
  bar.getLink(0).m_collider = &collider;
  world.stepSimulation(dt, 0, dt);
  world.removeCollisionObject(&collider);
  world.removeMultiBody(&bar);
  const btVector3& f = feedback.m_reactionForces.m_topVec;
  return {{f.x(), f.y()}, bar.getJointVel(0)};
}

// The exact reaction: m a_c = F + m g, a_c = alpha k x r - w^2 r, alpha from the moment of
// gravity about the pivot.
Eigen::Vector2d exact_force(double q, double w) {
  const Eigen::Vector2d r = kCom * Eigen::Vector2d(std::cos(q), std::sin(q));
  const double alpha = -kMass * kGravity * r.x() / (kInertia + kMass * kCom * kCom);
  const Eigen::Vector2d a = alpha * Eigen::Vector2d(-r.y(), r.x()) - w * w * r;
  return kMass * a - kMass * Eigen::Vector2d(0.0, -kGravity);
}

// A step of 1e-6 s: the rate the constraint pass sees differs from w by alpha dt (2e-5 rad/s),
// so what that pass adds at rest is below 1e-9 N.
constexpr double kDt = 1e-6;

TEST(BulletMultiBodyFeedback, AtRestItIsTheExactReaction) {
  for (const double q : {0.0, 0.7, -std::numbers::pi / 2, 2.5}) {
    const Eigen::Vector2d read = feedback_force(q, 0.0, kDt).force, exact = exact_force(q, 0.0);
    EXPECT_LT((read - exact).norm(), 1e-8 * exact.norm()) << "q = " << q;
  }
}

// The first pass reads the reaction at the step's start; the constraint pass then adds the
// centripetal force again, at the rate the step ends at. If this fails, Bullet counts the
// velocity terms once (bullet3 issue 2966 fixed): the multibody formulation's forces could then
// be read (sim/bullet, plan_scene).
TEST(BulletMultiBodyFeedback, InMotionItReadsTheCentripetalForceTwice) {
  for (const double q : {0.0, 0.7, -std::numbers::pi / 2, 2.5}) {
    for (const double w : {1.0, 4.0, -6.0}) {
      const Reading read = feedback_force(q, w, kDt);
      const Eigen::Vector2d exact = exact_force(q, w);
      const Eigen::Vector2d again =
          -kMass * read.rate * read.rate * kCom * Eigen::Vector2d(std::cos(q), std::sin(q));
      EXPECT_GT((read.force - exact).norm(), 0.5 * again.norm()) << "q = " << q << ", w = " << w;
      EXPECT_LT((read.force - exact - again).norm(), 1e-9 * exact.norm())
          << "q = " << q << ", w = " << w << ": read " << read.force.transpose() << ", exact "
          << exact.transpose();
    }
  }
}

}  // namespace
