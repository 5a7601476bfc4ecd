#pragma once
// The simulator's Bullet side, private to sim_bullet: the world and its colliders (Simulator::Impl)
// and the conversions both simulator.cpp (building, stepping) and readings.cpp (truth, sensors) use.
#include "hpr/sim/simulator.hpp"

#include <BulletCollision/CollisionShapes/btBoxShape.h>
#include <BulletCollision/CollisionShapes/btCompoundShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btCylinderShape.h>
#include <BulletCollision/CollisionShapes/btSphereShape.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyJointLimitConstraint.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <btBulletDynamicsCommon.h>
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>

#include "hpr/common/log.hpp"
#include "hpr/mesh/mesh.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/sim/multibody.hpp"

namespace hpr::sim {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;
using model::Vector6d;

inline constexpr int kGroundGroup = 1, kRobotGroup = 2;

inline btTransform to_bt(const SE3& X) {
  btTransform t;
  t.setOrigin(sim::to_bt(X.p));
  t.setRotation(to_bt_quaternion(X.R));
  return t;
}

inline Eigen::Vector4d quat_wxyz(const Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.w(), q.x(), q.y(), q.z()};
}

/// A joint limit that Bullet solves whichever links collide. Bullet solves a multibody constraint
/// in the simulation island of its link's own collider and drops it when that link has none (with
/// feet-only collisions, every joint but the two whose child link is a foot): the limit is then
/// simply not there. Every collider of one multibody lies in one island, so any of them names it.
/// The collider is looked up once (Bullet asks for the island in every comparison of its
/// constraint sort, each sub-step); construct it after the multibody's colliders are attached.
class JointLimit final : public btMultiBodyJointLimitConstraint {
 public:
  JointLimit(btMultiBody* mb, int link, double lower, double upper)
      : btMultiBodyJointLimitConstraint(mb, link, lower, upper), collider_(any_collider(mb)) {}
  int getIslandIdA() const override { return collider_ != nullptr ? collider_->getIslandTag() : -1; }
  int getIslandIdB() const override { return getIslandIdA(); }  // both bodies are the one multibody

 private:
  static const btMultiBodyLinkCollider* any_collider(const btMultiBody* mb) {
    if (const btMultiBodyLinkCollider* c = mb->getBaseCollider()) return c;
    for (int i = 0; i < mb->getNumLinks(); ++i) {
      if (const btMultiBodyLinkCollider* c = mb->getLink(i).m_collider) return c;
    }
    return nullptr;
  }
  const btMultiBodyLinkCollider* collider_;
};

struct Simulator::Impl {
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher{&collision_config};
  btDbvtBroadphase broadphase;
  btMultiBodyConstraintSolver solver;
  std::unique_ptr<btMultiBodyDynamicsWorld> world;
  std::unique_ptr<MultiBodyRobot> bullet;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btMultiBodyLinkCollider>> colliders;
  std::vector<btMultiBodyLinkCollider*> body_collider;  // per model body (may be null)
  std::vector<std::unique_ptr<JointLimit>> limits;
  std::unique_ptr<btCollisionShape> ground_shape;
  std::unique_ptr<btCollisionObject> ground;
  std::array<int, 2> foot_body{};
  std::array<Vector6d, 2> contact_impulse_O{};  // Σ (F, p × F) h over the control period, world origin
  std::vector<btVector3> omega, vel;            // Bullet link velocities (local frames)
  // compute_truth's per-body workspace, sized with omega and vel (no allocation in a step).
  std::vector<Vector3d> c_W, v_W, omega_W;
  std::vector<Matrix3d> R_W;
  btAlignedObjectArray<btQuaternion> world_to_local;
  btAlignedObjectArray<btVector3> local_origin;

  Impl() { world = std::make_unique<btMultiBodyDynamicsWorld>(&dispatcher, &broadphase, &solver, &collision_config); }
  ~Impl() {
    for (auto& l : limits) world->removeMultiBodyConstraint(l.get());
    for (auto& c : colliders) world->removeCollisionObject(c.get());
    if (ground) world->removeCollisionObject(ground.get());
    if (bullet) world->removeMultiBody(bullet->multibody());
    world.reset();
  }
  /// Every finite position limit of `m` as a constraint (after the colliders are attached).
  void add_joint_limits(const model::Model& m) {
    for (int j = 0; j < m.nj; ++j) {
      const double lo = m.q_lower[static_cast<size_t>(j)], hi = m.q_upper[static_cast<size_t>(j)];
      if (!std::isfinite(lo) || !std::isfinite(hi)) continue;
      auto c = std::make_unique<JointLimit>(bullet->multibody(), j, lo, hi);
      world->addMultiBodyConstraint(c.get());
      limits.push_back(std::move(c));
    }
  }
  /// The ground: the plane z = 0.
  void add_ground(double friction, double restitution) {
    ground_shape = std::make_unique<btStaticPlaneShape>(btVector3(0, 0, 1), 0.0);
    ground = std::make_unique<btCollisionObject>();
    ground->setCollisionShape(ground_shape.get());
    btTransform gt;
    gt.setIdentity();
    ground->setWorldTransform(gt);
    ground->setFriction(friction);
    ground->setRestitution(restitution);
    world->addCollisionObject(ground.get(), kGroundGroup, kRobotGroup);
  }
  void refresh_kinematics() {
    btMultiBody* mb = bullet->multibody();
    mb->forwardKinematics(world_to_local, local_origin);
    mb->updateCollisionObjectWorldTransforms(world_to_local, local_origin);
  }
  // World placement and twist (angular, CoM linear) of Bullet link `body` - 1 (base for 0).
  SE3 link_frame(int body) const {
    const btMultiBody* mb = bullet->multibody();
    SE3 X;
    if (body == 0) {
      X.R = from_bt(mb->getWorldToBaseRot().inverse());
      X.p = from_bt(mb->getBasePos());
    } else {
      const btTransform& t = mb->getLink(body - 1).m_cachedWorldTransform;
      X.R = from_bt(t.getRotation());
      X.p = from_bt(t.getOrigin());
    }
    return X;
  }
};

}  // namespace hpr::sim
