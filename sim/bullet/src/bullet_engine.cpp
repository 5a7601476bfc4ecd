// The Bullet engine: a btMultiBody of the simulated model and its colliders on a static plane,
// stepped by Bullet's multibody constraint solver (the simulator above it in simulator.cpp).
#include "hpr/sim/bullet_engine.hpp"
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

#include "hpr/common/log.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/sim/multibody.hpp"

namespace hpr::sim {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::SE3;
using model::Vector6d;

constexpr int kGroundGroup = 1, kRobotGroup = 2;

btTransform to_bt(const SE3& X) {
  btTransform t;
  t.setOrigin(sim::to_bt(X.p));
  t.setRotation(to_bt_quaternion(X.R));
  return t;
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

class BulletEngine final : public Engine {
 public:
  BulletEngine(const model::Model& m, const SimConfig& config, const Shapes& shapes, const std::array<int, 2>& foot_body)
      : model_(&m), foot_body_(foot_body) {
    world_ = std::make_unique<btMultiBodyDynamicsWorld>(&dispatcher_, &broadphase_, &solver_, &collision_config_);
    world_->setGravity(sim::to_bt(config.gravity));
    btContactSolverInfo& info = world_->getSolverInfo();
    info.m_numIterations = config.solver_iterations;
    if (config.friction_directions == 2) info.m_solverMode |= SOLVER_USE_2_FRICTION_DIRECTIONS;
    info.m_erp2 = config.contact_erp;
    info.m_globalCfm = config.contact_cfm;
    info.m_timeStep = config.dt / config.substeps;
    if (config.ground_multipoint) collision_config_.setPlaneConvexMultipointIterations(3, 3);

    bullet_ = std::make_unique<MultiBodyRobot>(m);
    btMultiBody* mb = bullet_->multibody();
    world_->addMultiBody(mb, kRobotGroup, kGroundGroup);

    // Collision shapes: every body's, merged per body, in the Bullet link frame.
    body_collider_.assign(static_cast<size_t>(m.nb), nullptr);
    for (int b = 0; b < m.nb; ++b) {
      const auto& body_shapes = shapes[static_cast<size_t>(b)];
      if (body_shapes.empty()) continue;
      auto compound = std::make_unique<btCompoundShape>();
      const SE3 X_LB = bullet_->bodies()[static_cast<size_t>(b)].X_BL.inverse();
      for (const CollisionShape& s : body_shapes) {
        std::unique_ptr<btCollisionShape> shape;
        switch (s.type) {
          case CollisionShape::Type::kBox:
            shape = std::make_unique<btBoxShape>(sim::to_bt(s.size));
            break;
          case CollisionShape::Type::kCylinder:
            shape = std::make_unique<btCylinderShapeZ>(btVector3(s.size.x(), s.size.x(), s.size.y()));
            break;
          case CollisionShape::Type::kSphere:
            shape = std::make_unique<btSphereShape>(s.size.x());
            break;
          case CollisionShape::Type::kHull: {
            auto hull = std::make_unique<btConvexHullShape>();
            for (const auto& p : s.points) hull->addPoint(sim::to_bt(p), false);
            hull->recalcLocalAabb();
            hull->setMargin(0.001);
            shape = std::move(hull);
            break;
          }
        }
        compound->addChildShape(to_bt(X_LB * s.X_BG), shape.get());
        shapes_.push_back(std::move(shape));
      }
      auto collider = std::make_unique<btMultiBodyLinkCollider>(mb, b - 1);
      collider->setCollisionShape(compound.get());
      collider->setFriction(config.ground_friction);
      // Friction anchors: static friction holds the contact point in place instead of letting the
      // iterative solver's residual creep the sole along the ground.
      collider->setCollisionFlags(collider->getCollisionFlags() | btCollisionObject::CF_HAS_FRICTION_ANCHOR);
      collider->setRestitution(config.ground_restitution);
      if (config.contact_stiffness > 0) collider->setContactStiffnessAndDamping(config.contact_stiffness, config.contact_damping);
      world_->addCollisionObject(collider.get(), kRobotGroup, kGroundGroup);
      if (b == 0) {
        mb->setBaseCollider(collider.get());
      } else {
        mb->getLink(b - 1).m_collider = collider.get();
      }
      body_collider_[static_cast<size_t>(b)] = collider.get();
      shapes_.push_back(std::move(compound));
      colliders_.push_back(std::move(collider));
    }
    if (config.joint_limits) add_joint_limits(m);
    add_ground(config.ground_friction, config.ground_restitution);
    omega_.resize(static_cast<size_t>(m.nb));
    vel_.resize(static_cast<size_t>(m.nb));
  }
  ~BulletEngine() override {
    for (auto& l : limits_) world_->removeMultiBodyConstraint(l.get());
    for (auto& c : colliders_) world_->removeCollisionObject(c.get());
    if (ground_) world_->removeCollisionObject(ground_.get());
    if (bullet_) world_->removeMultiBody(bullet_->multibody());
    world_.reset();
  }
  BulletEngine(const BulletEngine&) = delete;
  BulletEngine& operator=(const BulletEngine&) = delete;

  [[nodiscard]] const char* name() const override { return "bullet"; }
  void set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v) override {
    bullet_->set_state(q, v);
    refresh_kinematics();
  }
  void get_state(Eigen::VectorXd& q, Eigen::VectorXd& v) const override { bullet_->get_state(q, v); }
  [[nodiscard]] double joint_position(int j) const override { return bullet_->multibody()->getJointPos(j); }
  [[nodiscard]] double joint_velocity(int j) const override { return bullet_->multibody()->getJointVel(j); }
  void add_joint_torque(int j, double tau) override { bullet_->multibody()->addJointTorque(j, tau); }
  void add_force(int b, const Vector3d& F_W, const Vector3d& p_W) override {
    btMultiBody* mb = bullet_->multibody();
    const Vector3d torque = (p_W - bullet_->link_frame(b).p).cross(F_W);  // about the link's centre of mass
    if (b == 0) {
      mb->addBaseForce(sim::to_bt(F_W));
      mb->addBaseTorque(sim::to_bt(torque));
    } else {
      mb->addLinkForce(b - 1, sim::to_bt(F_W));
      mb->addLinkTorque(b - 1, sim::to_bt(torque));
    }
  }
  void step(double h, std::array<Vector6d, 2>& impulse_O) override {
    world_->stepSimulation(h, 0, h);
    refresh_kinematics();
    // Contact impulses on the feet (ground on foot), about the world origin.
    const int nm = dispatcher_.getNumManifolds();
    for (int i = 0; i < nm; ++i) {
      const btPersistentManifold* man = dispatcher_.getManifoldByIndexInternal(i);
      for (size_t k = 0; k < 2; ++k) {
        const btCollisionObject* foot = body_collider_[static_cast<size_t>(foot_body_[k])];
        const bool foot_is_a = man->getBody0() == foot, foot_is_b = man->getBody1() == foot;
        if (!foot_is_a && !foot_is_b) continue;
        for (int c = 0; c < man->getNumContacts(); ++c) {
          const btManifoldPoint& pt = man->getContactPoint(c);
          // Impulse on body A: normal (from B to A) and the two friction directions.
          const btVector3 imp = pt.m_normalWorldOnB * pt.m_appliedImpulse + pt.m_lateralFrictionDir1 * pt.m_appliedImpulseLateral1 +
                                pt.m_lateralFrictionDir2 * pt.m_appliedImpulseLateral2;
          const Vector3d J = (foot_is_a ? 1.0 : -1.0) * from_bt(imp);
          const Vector3d p = 0.5 * (from_bt(pt.getPositionWorldOnA()) + from_bt(pt.getPositionWorldOnB()));
          impulse_O[k].head<3>() += J;
          impulse_O[k].tail<3>() += p.cross(J);
        }
      }
    }
  }
  [[nodiscard]] SE3 body_placement(int b) const override { return bullet_->body_placement(b); }
  void body_motions(std::vector<BodyMotion>& out) const override {
    const btMultiBody* mb = bullet_->multibody();
    out.resize(static_cast<size_t>(model_->nb));
    mb->compTreeLinkVelocities(omega_.data(), vel_.data());
    for (int b = 0; b < model_->nb; ++b) {
      const auto bu = static_cast<size_t>(b);
      const SE3 X = bullet_->link_frame(b);  // Bullet's link frame: centre of mass, principal axes
      BodyMotion& o = out[bu];
      o.m = b == 0 ? mb->getBaseMass() : mb->getLink(b - 1).m_mass;
      o.I_principal = b == 0 ? from_bt(mb->getBaseInertia()) : from_bt(mb->getLink(b - 1).m_inertiaLocal);
      o.R_WI = X.R;
      o.c_W = X.p;
      o.v_W = X.R * from_bt(vel_[bu]);
      o.omega_W = X.R * from_bt(omega_[bu]);
    }
  }

 private:
  /// Every finite position limit of `m` as a constraint (after the colliders are attached).
  void add_joint_limits(const model::Model& m) {
    for (int j = 0; j < m.nj; ++j) {
      const double lo = m.q_lower[static_cast<size_t>(j)], hi = m.q_upper[static_cast<size_t>(j)];
      if (!std::isfinite(lo) || !std::isfinite(hi)) continue;
      auto c = std::make_unique<JointLimit>(bullet_->multibody(), j, lo, hi);
      world_->addMultiBodyConstraint(c.get());
      limits_.push_back(std::move(c));
    }
  }
  /// The ground: the plane z = 0.
  void add_ground(double friction, double restitution) {
    ground_shape_ = std::make_unique<btStaticPlaneShape>(btVector3(0, 0, 1), 0.0);
    ground_ = std::make_unique<btCollisionObject>();
    ground_->setCollisionShape(ground_shape_.get());
    btTransform gt;
    gt.setIdentity();
    ground_->setWorldTransform(gt);
    ground_->setFriction(friction);
    ground_->setRestitution(restitution);
    world_->addCollisionObject(ground_.get(), kGroundGroup, kRobotGroup);
  }
  void refresh_kinematics() {
    btMultiBody* mb = bullet_->multibody();
    mb->forwardKinematics(world_to_local_, local_origin_);
    mb->updateCollisionObjectWorldTransforms(world_to_local_, local_origin_);
  }

  const model::Model* model_;
  std::array<int, 2> foot_body_;
  btDefaultCollisionConfiguration collision_config_;
  btCollisionDispatcher dispatcher_{&collision_config_};
  btDbvtBroadphase broadphase_;
  btMultiBodyConstraintSolver solver_;
  std::unique_ptr<btMultiBodyDynamicsWorld> world_;
  std::unique_ptr<MultiBodyRobot> bullet_;
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btMultiBodyLinkCollider>> colliders_;
  std::vector<btMultiBodyLinkCollider*> body_collider_;  // per model body (may be null)
  std::vector<std::unique_ptr<JointLimit>> limits_;
  std::unique_ptr<btCollisionShape> ground_shape_;
  std::unique_ptr<btCollisionObject> ground_;
  mutable std::vector<btVector3> omega_, vel_;  // Bullet link velocities (local frames)
  btAlignedObjectArray<btQuaternion> world_to_local_;
  btAlignedObjectArray<btVector3> local_origin_;
};

}  // namespace

std::unique_ptr<Engine> make_bullet_engine(const model::Model& m, const SimConfig& config, const Shapes& shapes,
                                           const std::array<int, 2>& foot_body) {
  return std::make_unique<BulletEngine>(m, config, shapes, foot_body);
}

}  // namespace hpr::sim
