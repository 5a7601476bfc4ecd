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
using Eigen::VectorXd;
using model::SE3;
using Vector6d = Eigen::Matrix<double, 6, 1>;

namespace {
constexpr int kGroundGroup = 1, kRobotGroup = 2;

btTransform to_bt(const SE3& X) {
  btTransform t;
  t.setOrigin(sim::to_bt(X.p));
  t.setRotation(to_bt_quaternion(X.R));
  return t;
}

Eigen::Vector4d quat_wxyz(const Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.w(), q.x(), q.y(), q.z()};
}
}  // namespace

Eigen::Vector3d Push::force_at(double t) const {
  if (t < start || t >= start + duration || duration <= 0.0) return Vector3d::Zero();
  if (profile == Profile::kRectangle) return force_W;
  return force_W * std::sin(M_PI * (t - start) / duration);
}

Eigen::Vector3d Push::impulse() const {
  return profile == Profile::kRectangle ? Vector3d(force_W * duration) : Vector3d(force_W * (2.0 * duration / M_PI));
}

SimConfig SimConfig::load(const Config& c) {
  SimConfig s;
  s.dt = c.real_or("dt", s.dt, 1e-4, 0.01);
  s.substeps = static_cast<int>(c.integer_or("substeps", s.substeps, 1, 20));
  s.gravity = c.vec3_or("gravity", s.gravity, -100.0, 100.0);
  s.solver_iterations = static_cast<int>(c.integer_or("solver_iterations", s.solver_iterations, 1, 1000));
  if (c.has("ground")) {
    const Config g = c.section("ground");
    s.ground_friction = g.real_or("friction", s.ground_friction, 0.0, 5.0);
    s.ground_restitution = g.real_or("restitution", s.ground_restitution, 0.0, 1.0);
    s.ground_multipoint = g.boolean_or("multipoint", s.ground_multipoint);
    s.contact_stiffness = g.real_or("contact_stiffness", s.contact_stiffness, 0.0, 1e9);
    s.contact_damping = g.real_or("contact_damping", s.contact_damping, 0.0, 1e7);
    s.contact_erp = g.real_or("contact_erp", s.contact_erp, 0.0, 1.0);
    s.contact_cfm = g.real_or("contact_cfm", s.contact_cfm, 0.0, 1.0);
  }
  s.joint_limits = c.boolean_or("joint_limits", s.joint_limits);
  s.feet_only_collisions = c.choice_or("collisions", s.feet_only_collisions ? "feet" : "all", {"feet", "all"}) == "feet";
  s.friction_directions = static_cast<int>(c.integer_or("friction_directions", s.friction_directions, 1, 2));
  if (c.has("joint_friction")) {
    const Config j = c.section("joint_friction");
    s.joint_friction_coulomb = j.real_or("coulomb", s.joint_friction_coulomb, 0.0, 100.0);
    s.joint_friction_viscous = j.real_or("viscous", s.joint_friction_viscous, 0.0, 100.0);
  }
  s.actuation_delay_ticks = static_cast<int>(c.integer_or("actuation_delay_ticks", s.actuation_delay_ticks, 0, 10));
  if (c.has("model_error")) {
    for (const Config& e : c.items("model_error")) {
      BodyError b;
      b.body = e.string("body");
      b.mass_scale = e.real_or("mass_scale", b.mass_scale, 0.1, 10.0);
      b.com_offset = e.vec3_or("com_offset", b.com_offset, -0.5, 0.5);
      s.model_error.push_back(b);
    }
  }
  s.command_timeout = c.real_or("command_timeout", s.command_timeout, 1e-3, 10.0);
  s.damping_kd = c.real_or("damping_kd", s.damping_kd, 0.0, 1e3);
  if (c.has("start")) {
    const Config st = c.section("start");
    s.settle_time = st.real_or("settle_time", s.settle_time, 0.0, 10.0);
    s.settle_kp = st.real_or("kp", s.settle_kp, 0.0, 1e5);
    s.settle_kd = st.real_or("kd", s.settle_kd, 0.0, 1e4);
  }
  if (c.has("held_joints")) {
    const Config h = c.section("held_joints");
    s.held_kp = h.real_or("kp", s.held_kp, 0.0, 1e5);
    s.held_kd = h.real_or("kd", s.held_kd, 0.0, 1e4);
    s.held_rigid = h.boolean_or("rigid", s.held_rigid);
  }
  if (c.has("fallen")) {
    const Config f = c.section("fallen");
    s.fallen_base_height = f.real_or("base_height", s.fallen_base_height, 0.0, 3.0);
    s.fallen_tilt_deg = f.real_or("tilt_deg", s.fallen_tilt_deg, 1.0, 180.0);
  }
  if (c.has("noise")) {
    const Config n = c.section("noise");
    NoiseConfig& nc = s.noise;
    nc.enabled = n.boolean_or("enabled", nc.enabled);
    nc.seed = static_cast<unsigned>(n.integer_or("seed", nc.seed, 0, 1L << 31));
    nc.gyro_noise_density = n.real_or("gyro_noise_density", nc.gyro_noise_density, 0.0, 1.0);
    nc.gyro_bias_random_walk = n.real_or("gyro_bias_random_walk", nc.gyro_bias_random_walk, 0.0, 1.0);
    nc.gyro_bias_initial = n.real_or("gyro_bias_initial", nc.gyro_bias_initial, 0.0, 1.0);
    nc.accel_noise_density = n.real_or("accel_noise_density", nc.accel_noise_density, 0.0, 10.0);
    nc.encoder_bits = static_cast<int>(n.integer_or("encoder_bits", nc.encoder_bits, 0, 32));
    nc.joint_torque_noise = n.real_or("joint_torque_noise", nc.joint_torque_noise, 0.0, 100.0);
    nc.ft_force_noise = n.real_or("ft_force_noise", nc.ft_force_noise, 0.0, 100.0);
    nc.ft_torque_noise = n.real_or("ft_torque_noise", nc.ft_torque_noise, 0.0, 10.0);
  }
  return s;
}

std::vector<Push> load_scenario(const std::string& path) {
  const Config cfg = Config::load(path);
  std::vector<Push> out;
  std::int64_t id = 1;
  for (const Config& p : cfg.items("pushes")) {
    Push push;
    push.id = id++;
    push.link = p.string("link");
    push.point_L = p.vec3_or("point", Vector3d::Zero(), -Push::kMaxPoint, Push::kMaxPoint);
    push.force_W = p.vec3("force", -Push::kMaxForce, Push::kMaxForce);
    push.start = p.real("start", 0.0, Push::kMaxStart);
    push.duration = p.real("duration", Push::kMinDuration, Push::kMaxDuration);
    push.profile = p.choice_or("profile", "half_sine", {"half_sine", "rectangle"}) == "rectangle"
                       ? Push::Profile::kRectangle
                       : Push::Profile::kHalfSine;
    out.push_back(push);
  }
  return out;
}

void hold_gains(const model::RobotSpec& robot, const VectorXd& q, double kp, double kd, double dt, VectorXd& kp_out,
                VectorXd& kd_out) {
  const model::Model& m = robot.model;
  model::Data data(m);
  model::crba(m, data, q);
  // The inertia a joint's torque meets when every other joint is torque-driven: 1 / (M⁻¹)_jj.
  const Eigen::MatrixXd Minv = data.M.llt().solve(Eigen::MatrixXd::Identity(m.nv, m.nv));
  kp_out = VectorXd::Constant(m.nj, kp);
  kd_out = VectorXd::Constant(m.nj, kd);
  for (int j : robot.free_joints) {
    const double I = 1.0 / Minv(6 + j, 6 + j);
    kp_out(j) = std::min(kp, 0.2 * I / (dt * dt));
    kd_out(j) = std::min(kd, 0.5 * I / dt);
  }
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

namespace {

/// The simulated robot's bodies as `errors` say they differ from the description.
void apply_model_error(model::Model& m, const std::vector<SimConfig::BodyError>& errors) {
  for (const auto& e : errors) {
    int b = 0;
    try {
      b = m.body_index(e.body);
    } catch (const model::ModelError& err) {
      std::string bodies;
      for (const auto& name : m.body_name) bodies += (bodies.empty() ? "" : ", ") + name;
      throw std::invalid_argument(std::string("sim.model_error: ") + err.what() + " (bodies: " + bodies + ")");
    }
    const model::Inertia& old = m.inertia[static_cast<std::size_t>(b)];
    m.set_inertia(b, model::Inertia::from_com(e.mass_scale * old.m, old.com() + e.com_offset, e.mass_scale * old.inertia_about_com()));
    const model::Inertia& I = m.inertia[static_cast<std::size_t>(b)];
    log::info("sim.model_error: body '{}' simulated with {:.3f} kg (x{:.3f}), CoM moved by ({:.3f}, {:.3f}, {:.3f}) m", e.body, I.m,
              e.mass_scale, e.com_offset.x(), e.com_offset.y(), e.com_offset.z());
  }
}

}  // namespace

Simulator::Simulator(const model::RobotSpec& robot, SimConfig config)
    : robot_(&robot), config_(config), full_(robot.full_model(config.held_rigid)), impl_(std::make_unique<Impl>()), rng_(config.noise.seed) {
  apply_model_error(full_, config_.model_error);
  const model::Model& m = full_;
  const model::RobotDescription& description = robot.description;
  Impl& I = *impl_;
  for (const auto& name : robot.model.joint_name) joint_of_.push_back(m.joint_index(name));
  held_q_.resize(static_cast<Eigen::Index>(robot.model.held_joint_name.size()));
  held_tau_ = VectorXd::Zero(held_q_.size());
  for (size_t k = 0; k < robot.model.held_joint_name.size(); ++k) {
    if (!config_.held_rigid) held_joint_.push_back(m.joint_index(robot.model.held_joint_name[k]));
    held_q_(static_cast<Eigen::Index>(k)) = robot.model.held_q[k];
  }
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    sole_frame_[ku] = m.frame_index(robot.model.frames[static_cast<size_t>(robot.feet[ku].sole_frame)].name);
    ft_frame_[ku] = m.frame_index(robot.model.frames[static_cast<size_t>(robot.feet[ku].ft_frame)].name);
  }
  imu_frame_ = m.frame_index(robot.model.frames[static_cast<size_t>(robot.imu_frame)].name);
  I.world->setGravity(to_bt(config_.gravity));
  btContactSolverInfo& info = I.world->getSolverInfo();
  info.m_numIterations = config_.solver_iterations;
  if (config_.friction_directions == 2) info.m_solverMode |= SOLVER_USE_2_FRICTION_DIRECTIONS;
  info.m_erp2 = config_.contact_erp;
  info.m_globalCfm = config_.contact_cfm;
  info.m_timeStep = config_.dt / config_.substeps;
  if (config_.ground_multipoint) I.collision_config.setPlaneConvexMultipointIterations(3, 3);

  I.bullet = std::make_unique<MultiBodyRobot>(m);
  btMultiBody* mb = I.bullet->multibody();
  I.world->addMultiBody(mb, kRobotGroup, kGroundGroup);

  // Collision shapes: every URDF link's geometries, merged per body, in the Bullet link frame.
  I.body_collider.assign(static_cast<size_t>(m.nb), nullptr);
  std::array<int, 2> foot_bodies{};
  for (int k = 0; k < 2; ++k) foot_bodies[static_cast<size_t>(k)] = m.frames[static_cast<size_t>(sole_frame_[static_cast<size_t>(k)])].body;
  for (int b = 0; b < m.nb; ++b) {
    if (config_.feet_only_collisions && b != foot_bodies[0] && b != foot_bodies[1]) continue;
    auto compound = std::make_unique<btCompoundShape>();
    const SE3 X_LB = I.bullet->bodies()[static_cast<size_t>(b)].X_BL.inverse();
    for (const auto& frame : m.frames) {
      if (frame.body != b) continue;
      const model::LinkDesc* link = description.find_link(frame.name);
      if (link == nullptr) continue;
      for (const auto& g : link->collisions) {
        SE3 X_BG = frame.X_BF * g.X_LG;
        std::unique_ptr<btCollisionShape> shape;
        switch (g.type) {
          case model::Geometry::Type::kBox:
            shape = std::make_unique<btBoxShape>(to_bt(Vector3d(0.5 * g.size)));
            break;
          case model::Geometry::Type::kCylinder:
            shape = std::make_unique<btCylinderShapeZ>(btVector3(g.size.x(), g.size.x(), 0.5 * g.size.y()));
            break;
          case model::Geometry::Type::kSphere:
            shape = std::make_unique<btSphereShape>(g.size.x());
            break;
          case model::Geometry::Type::kMesh: {
            std::vector<Vector3d> points;
            try {
              points = mesh::load(g.mesh, g.mesh_scale).vertices;
            } catch (const mesh::MeshError& e) {
              throw model::ModelError(fmt::format("{}: link '{}': {}", m.source, link->name, e.what()));
            }
            if (robot.mesh_collision == model::MeshCollision::kBox) {
              Vector3d lo = points.front(), hi = points.front();
              for (const auto& p : points) {
                lo = lo.cwiseMin(p);
                hi = hi.cwiseMax(p);
              }
              shape = std::make_unique<btBoxShape>(to_bt(Vector3d(0.5 * (hi - lo))));
              SE3 X_GC;
              X_GC.p = 0.5 * (hi + lo);
              X_BG = X_BG * X_GC;
            } else {
              auto hull = std::make_unique<btConvexHullShape>();
              for (const auto& p : mesh::hull_points(points, robot.mesh_hull_points)) hull->addPoint(sim::to_bt(p), false);
              hull->recalcLocalAabb();
              hull->setMargin(0.001);
              shape = std::move(hull);
            }
            break;
          }
        }
        compound->addChildShape(to_bt(X_LB * X_BG), shape.get());
        I.shapes.push_back(std::move(shape));
      }
    }
    for (int k = 0; k < 2; ++k) {
      // A foot without collision geometry (a description with inertias only) stands on the sole the
      // configuration declares: a box of its rectangle, 2 cm thick, its bottom face on the sole.
      const auto ku = static_cast<size_t>(k);
      if (b != foot_bodies[ku] || compound->getNumChildShapes() != 0) continue;
      const model::FootSpec& foot = robot.feet[ku];
      constexpr double kThickness = 0.02;
      SE3 X_SC;
      X_SC.p = Vector3d(0.0, 0.0, 0.5 * kThickness);
      const SE3 X_BS = m.frames[static_cast<size_t>(sole_frame_[ku])].X_BF;
      auto box = std::make_unique<btBoxShape>(to_bt(Vector3d(0.5 * foot.length, 0.5 * foot.width, 0.5 * kThickness)));
      compound->addChildShape(to_bt(X_LB * X_BS * X_SC), box.get());
      I.shapes.push_back(std::move(box));
      log::info("the {} foot link '{}' has no collision geometry: it collides with its configured sole, a box of {:.3f} x {:.3f} x "
                "{:.3f} m", model::kFootNames[ku], foot.link, foot.length, foot.width, kThickness);
    }
    if (compound->getNumChildShapes() == 0) continue;
    auto collider = std::make_unique<btMultiBodyLinkCollider>(mb, b - 1);
    collider->setCollisionShape(compound.get());
    collider->setFriction(config_.ground_friction);
    // Friction anchors: static friction holds the contact point in place instead of letting the
    // iterative solver's residual creep the sole along the ground.
    collider->setCollisionFlags(collider->getCollisionFlags() | btCollisionObject::CF_HAS_FRICTION_ANCHOR);
    collider->setRestitution(config_.ground_restitution);
    if (config_.contact_stiffness > 0) {
      collider->setContactStiffnessAndDamping(config_.contact_stiffness, config_.contact_damping);
    }
    I.world->addCollisionObject(collider.get(), kRobotGroup, kGroundGroup);
    if (b == 0) {
      mb->setBaseCollider(collider.get());
    } else {
      mb->getLink(b - 1).m_collider = collider.get();
    }
    I.body_collider[static_cast<size_t>(b)] = collider.get();
    I.shapes.push_back(std::move(compound));
    I.colliders.push_back(std::move(collider));
  }
  for (int k = 0; k < 2; ++k) I.foot_body[static_cast<size_t>(k)] = foot_bodies[static_cast<size_t>(k)];
  if (config_.joint_limits) {
    for (int j = 0; j < m.nj; ++j) {
      const double lo = m.q_lower[static_cast<size_t>(j)], hi = m.q_upper[static_cast<size_t>(j)];
      if (!std::isfinite(lo) || !std::isfinite(hi)) continue;
      auto c = std::make_unique<JointLimit>(mb, j, lo, hi);
      I.world->addMultiBodyConstraint(c.get());
      I.limits.push_back(std::move(c));
    }
  }
  // Ground: the plane z = 0.
  I.ground_shape = std::make_unique<btStaticPlaneShape>(btVector3(0, 0, 1), 0.0);
  I.ground = std::make_unique<btCollisionObject>();
  I.ground->setCollisionShape(I.ground_shape.get());
  btTransform gt;
  gt.setIdentity();
  I.ground->setWorldTransform(gt);
  I.ground->setFriction(config_.ground_friction);
  I.ground->setRestitution(config_.ground_restitution);
  I.world->addCollisionObject(I.ground.get(), kGroundGroup, kRobotGroup);

  I.omega.resize(static_cast<size_t>(m.nb));
  I.vel.resize(static_cast<size_t>(m.nb));
  I.c_W.resize(static_cast<size_t>(m.nb));
  I.v_W.resize(static_cast<size_t>(m.nb));
  I.omega_W.resize(static_cast<size_t>(m.nb));
  I.R_W.resize(static_cast<size_t>(m.nb));
  applied_ = VectorXd::Zero(robot.model.nj);
  sensors_.resize(robot.model.nj);
  q_full_.resize(m.nq);
  v_full_.resize(m.nv);
  reset();
}

Simulator::~Simulator() = default;

void Simulator::expand_state(const VectorXd& q, const VectorXd& v) {
  q_full_.head<7>() = q.head<7>();
  v_full_.head<6>() = v.head<6>();
  for (size_t j = 0; j < joint_of_.size(); ++j) {
    q_full_(7 + joint_of_[j]) = q(7 + static_cast<Eigen::Index>(j));
    v_full_(6 + joint_of_[j]) = v(6 + static_cast<Eigen::Index>(j));
  }
  for (size_t k = 0; k < held_joint_.size(); ++k) {
    q_full_(7 + held_joint_[k]) = held_q_(static_cast<Eigen::Index>(k));
    v_full_(6 + held_joint_[k]) = 0.0;
  }
}

void Simulator::set_state(const VectorXd& q, const VectorXd& v) {
  expand_state(q, v);
  impl_->bullet->set_state(q_full_, v_full_);
  impl_->refresh_kinematics();
  have_v_imu_prev_ = false;
  have_foot_momentum_prev_ = false;
  compute_truth();
  compute_sensors();
}

VectorXd Simulator::settle_torque() const {
  const model::Model& m = robot_->model;
  const btMultiBody* mb = impl_->bullet->multibody();
  VectorXd tau(m.nj);
  for (int j = 0; j < m.nj; ++j) {
    const int b = joint_of_[static_cast<size_t>(j)];
    tau(j) = settle_kp_(j) * (robot_->q_joints_stand(j) - mb->getJointPos(b)) - settle_kd_(j) * mb->getJointVel(b);
  }
  return tau;
}

void Simulator::apply_hold(JointCommand::Mode mode) {
  btMultiBody* mb = impl_->bullet->multibody();
  for (size_t k = 0; k < held_joint_.size(); ++k) {
    const int b = held_joint_[k];
    const auto ku = static_cast<Eigen::Index>(k);
    const double q = mb->getJointPos(b), qd = mb->getJointVel(b);
    double tau = 0.0;
    if (held_external_) {
      // The drives of the held joints as the hal commands them.
      const JointCommand& c = held_command_;
      if (c.mode == JointCommand::Mode::kRun) {
        tau = c.tau_ff(ku) + c.kp(ku) * (c.q_des(ku) - q) + c.kd(ku) * (c.qd_des(ku) - qd);
      } else if (c.mode == JointCommand::Mode::kDamp) {
        tau = -c.kd(ku) * qd;
      }
    } else if (mode == JointCommand::Mode::kRun) {
      tau = held_kp_(ku) * (held_q_(ku) - q) - held_kd_(ku) * qd;
    } else if (mode == JointCommand::Mode::kDamp) {
      tau = -held_kd_(ku) * qd;
    }
    const double lim = full_.tau_max[static_cast<size_t>(b)];
    tau = std::clamp(tau, -lim, lim);
    held_tau_(ku) = tau;
    mb->addJointTorque(b, tau);
  }
}

bool Simulator::set_held_command(const JointCommand& c, std::string* why) {
  const std::string reason = c.check(static_cast<int>(held_q_.size()));
  if (!reason.empty()) {
    if (why != nullptr) *why = reason;
    return false;
  }
  held_command_ = c;
  held_external_ = true;
  return true;
}

void Simulator::reset() {
  const model::Model& m = robot_->model;
  time_ = 0.0;
  tick_ = 0;
  pushes_.clear();
  have_command_ = false;
  held_external_ = false;
  stale_ = false;
  rng_.seed(config_.noise.seed);
  gyro_bias_.setZero();
  if (config_.noise.enabled) {
    std::uniform_int_distribution<int> sign(0, 1);
    for (int k = 0; k < 3; ++k) gyro_bias_(k) = (sign(rng_) != 0 ? 1.0 : -1.0) * config_.noise.gyro_bias_initial;
  }
  VectorXd q = robot_->standing_configuration();
  hold_gains(*robot_, q, config_.settle_kp, config_.settle_kd, config_.dt / config_.substeps, settle_kp_, settle_kd_);
  q(2) += 1e-4;  // a hair above the ground
  expand_state(q, VectorXd::Zero(m.nv));
  // Held joints: a drive's joint impedance, capped for the inertia each meets (as hold_gains).
  held_kp_.resize(held_q_.size());
  held_kd_.resize(held_q_.size());
  if (!held_joint_.empty()) {
    model::Data data(full_);
    model::crba(full_, data, q_full_);
    const Eigen::MatrixXd Minv = data.M.llt().solve(Eigen::MatrixXd::Identity(full_.nv, full_.nv));
    const double h = config_.dt / config_.substeps;
    for (size_t k = 0; k < held_joint_.size(); ++k) {
      const double I_j = 1.0 / Minv(6 + held_joint_[k], 6 + held_joint_[k]);
      held_kp_(static_cast<Eigen::Index>(k)) = std::min(config_.held_kp, 0.2 * I_j / (h * h));
      held_kd_(static_cast<Eigen::Index>(k)) = std::min(config_.held_kd, 0.5 * I_j / h);
    }
  }
  impl_->bullet->set_state(q_full_, v_full_);
  impl_->refresh_kinematics();
  // Settle: hold the standing posture with stiff joint springs.
  const int settle_steps = static_cast<int>(std::round(config_.settle_time / config_.dt));
  const double h = config_.dt / config_.substeps;
  for (int k = 0; k < settle_steps * config_.substeps; ++k) {
    // The contact impulses of the last control period of the settling are tick 0's contact forces.
    if (k % config_.substeps == 0) {
      for (auto& w : impl_->contact_impulse_O) w.setZero();
    }
    const VectorXd tau = settle_torque();
    btMultiBody* mb = impl_->bullet->multibody();
    for (int j = 0; j < m.nj; ++j) {
      const double lim = m.tau_max[static_cast<size_t>(j)];
      mb->addJointTorque(joint_of_[static_cast<size_t>(j)], std::clamp(tau(j), -lim, lim));
    }
    apply_hold(JointCommand::Mode::kRun);
    physics_substep(h);
  }
  have_v_imu_prev_ = false;
  have_foot_momentum_prev_ = false;
  q_meas_prev_.resize(0);
  // Tick 0 is the settled state; without a command the drives hold it with the settle gains.
  JointCommand settle;
  settle.mode = JointCommand::Mode::kRun;
  settle.tau_ff = VectorXd::Zero(m.nj);
  settle.q_des = robot_->q_joints_stand;
  settle.qd_des = VectorXd::Zero(m.nj);
  settle.kp = settle_kp_;
  settle.kd = settle_kd_;
  delay_line_.assign(static_cast<std::size_t>(config_.actuation_delay_ticks) + 1, settle);
  delay_head_ = 0;
  command_time_ = 0.0;
  truth_.fallen = false;  // latched by compute_truth until the next reset
  compute_truth();
  compute_sensors();
}

bool Simulator::set_command(const JointCommand& c, std::string* why) {
  const std::string reason = c.check(robot_->model.nj);
  if (!reason.empty()) {
    ++rejected_;
    if (why != nullptr) *why = reason;
    return false;
  }
  delay_head_ = (delay_head_ + 1) % delay_line_.size();
  delay_line_[delay_head_] = c;
  command_time_ = time_;
  have_command_ = true;
  return true;
}

void Simulator::add_push(Push push) {
  if (push.start < 0) push.start = time_;
  pushes_.push_back(std::move(push));
}

void Simulator::apply_actuation() {
  const model::Model& m = robot_->model;
  btMultiBody* mb = impl_->bullet->multibody();
  // The oldest command of the delay line (the newest one without a delay).
  const JointCommand& c = delay_line_[(delay_head_ + 1) % delay_line_.size()];
  stale_ = time_ - command_time_ > config_.command_timeout + 1e-9;
  JointCommand::Mode mode = stale_ ? JointCommand::Mode::kDamp : c.mode;
  for (int j = 0; j < m.nj; ++j) {
    const int b = joint_of_[static_cast<size_t>(j)];
    const double q = mb->getJointPos(b), qd = mb->getJointVel(b);
    double tau = 0.0;
    if (mode == JointCommand::Mode::kRun) {
      tau = c.tau_ff(j) + c.kp(j) * (c.q_des(j) - q) + c.kd(j) * (c.qd_des(j) - qd);
    } else if (mode == JointCommand::Mode::kDamp) {
      const double kd = stale_ ? config_.damping_kd : c.kd(j);
      tau = -kd * qd;
    }
    const double lim = m.tau_max[static_cast<size_t>(j)];
    tau = std::clamp(tau, -lim, lim);
    applied_(j) = tau;
    // Joint friction acts in the joint on top of the motor torque.
    double fric = -config_.joint_friction_viscous * qd;
    if (config_.joint_friction_coulomb > 0) fric -= config_.joint_friction_coulomb * std::tanh(qd / 0.01);
    mb->addJointTorque(b, tau + fric);
  }
  apply_hold(mode);
}

void Simulator::physics_substep(double h) {
  Impl& I = *impl_;
  btMultiBody* mb = I.bullet->multibody();
  const model::Model& m = full_;
  // Pushes.
  for (const Push& p : pushes_) {
    const Vector3d F = p.force_at(time_);
    if (F.isZero()) continue;
    const int frame = m.frame_index(p.link);
    const int body = m.frames[static_cast<size_t>(frame)].body;
    const SE3 X_WL = I.link_frame(body);  // Bullet link frame (CoM)
    const SE3 X_WB = X_WL * I.bullet->bodies()[static_cast<size_t>(body)].X_BL.inverse();
    const Vector3d point = (X_WB * m.frames[static_cast<size_t>(frame)].X_BF).act(p.point_L);
    const Vector3d torque = (point - X_WL.p).cross(F);
    if (body == 0) {
      mb->addBaseForce(to_bt(F));
      mb->addBaseTorque(to_bt(torque));
    } else {
      mb->addLinkForce(body - 1, to_bt(F));
      mb->addLinkTorque(body - 1, to_bt(torque));
    }
    truth_.push_impulse_W += F * h;
    truth_.push_point_W = point;
  }
  I.world->stepSimulation(h, 0, h);
  I.refresh_kinematics();
  static const bool debug = std::getenv("HPR_SIM_DEBUG") != nullptr;
  if (debug && tick_ % 1000 == 0) {
    int pts = 0;
    for (int i = 0; i < I.dispatcher.getNumManifolds(); ++i) pts += I.dispatcher.getManifoldByIndexInternal(i)->getNumContacts();
    log::info("t {:.3f}: {} manifolds, {} contact points", time_, I.dispatcher.getNumManifolds(), pts);
  }
  // Contact impulses on the feet (ground on foot), about the world origin.
  const int nm = I.dispatcher.getNumManifolds();
  for (int i = 0; i < nm; ++i) {
    const btPersistentManifold* man = I.dispatcher.getManifoldByIndexInternal(i);
    for (int k = 0; k < 2; ++k) {
      const btCollisionObject* foot = I.body_collider[static_cast<size_t>(I.foot_body[static_cast<size_t>(k)])];
      const bool foot_is_a = man->getBody0() == foot, foot_is_b = man->getBody1() == foot;
      if (!foot_is_a && !foot_is_b) continue;
      for (int c = 0; c < man->getNumContacts(); ++c) {
        const btManifoldPoint& pt = man->getContactPoint(c);
        // Impulse on body A: normal (from B to A) and the two friction directions.
        const btVector3 imp = pt.m_normalWorldOnB * pt.m_appliedImpulse + pt.m_lateralFrictionDir1 * pt.m_appliedImpulseLateral1 +
                              pt.m_lateralFrictionDir2 * pt.m_appliedImpulseLateral2;
        const Vector3d J = (foot_is_a ? 1.0 : -1.0) * from_bt(imp);
        const Vector3d p = 0.5 * (from_bt(pt.getPositionWorldOnA()) + from_bt(pt.getPositionWorldOnB()));
        I.contact_impulse_O[static_cast<size_t>(k)].head<3>() += J;
        I.contact_impulse_O[static_cast<size_t>(k)].tail<3>() += p.cross(J);
      }
    }
  }
}

void Simulator::step() {
  const double h = config_.dt / config_.substeps;
  truth_.push_force_W.setZero();
  for (auto& w : impl_->contact_impulse_O) w.setZero();
  // Push bookkeeping: the active or most recent push.
  for (const Push& p : pushes_) {
    if (time_ >= p.start && time_ < p.start + p.duration) {
      if (truth_.push_id != p.id) truth_.push_impulse_W.setZero();
      truth_.push_id = p.id;
      truth_.push_force_W = p.force_at(time_);
    }
  }
  truth_.push_active = !truth_.push_force_W.isZero();
  for (int s = 0; s < config_.substeps; ++s) {
    apply_actuation();
    physics_substep(h);
    time_ += h;
  }
  ++tick_;
  compute_truth();
  compute_sensors();
}

void Simulator::compute_truth() {
  Impl& I = *impl_;
  const model::Model& m = full_;
  btMultiBody* mb = I.bullet->multibody();
  TruthData& t = truth_;
  t.tick = tick_;
  t.time = time_;
  I.bullet->get_state(q_full_, v_full_);
  const int nj = robot_->model.nj;
  t.q.resize(7 + nj);
  t.v.resize(6 + nj);
  t.q.head<7>() = q_full_.head<7>();
  t.v.head<6>() = v_full_.head<6>();
  for (int j = 0; j < nj; ++j) {
    t.q(7 + j) = q_full_(7 + joint_of_[static_cast<size_t>(j)]);
    t.v(6 + j) = v_full_(6 + joint_of_[static_cast<size_t>(j)]);
  }
  if (config_.held_rigid) {
    t.q_held = held_q_;
    t.v_held.setZero(held_q_.size());
  } else {
    const auto nh = static_cast<Eigen::Index>(held_joint_.size());
    t.q_held.resize(nh);
    t.v_held.resize(nh);
    for (Eigen::Index k = 0; k < nh; ++k) {
      t.q_held(k) = q_full_(7 + held_joint_[static_cast<size_t>(k)]);
      t.v_held(k) = v_full_(6 + held_joint_[static_cast<size_t>(k)]);
    }
  }
  t.tau_held = held_tau_;
  const SE3 X_WB = I.bullet->body_placement(0);
  t.p_WB = X_WB.p;
  t.quat_WB = quat_wxyz(X_WB.R);
  t.v_WB = X_WB.R * t.v.head<3>();
  t.omega_WB = X_WB.R * t.v.segment<3>(3);
  // Centre of mass, momentum and CAM from Bullet's link states (CoM frames, local velocities).
  mb->compTreeLinkVelocities(I.omega.data(), I.vel.data());
  double mass = 0;
  Vector3d mc = Vector3d::Zero(), p = Vector3d::Zero();
  std::vector<Vector3d>& c = I.c_W;
  std::vector<Vector3d>& v = I.v_W;
  std::vector<Vector3d>& w = I.omega_W;
  std::vector<Matrix3d>& R = I.R_W;
  for (int b = 0; b < m.nb; ++b) {
    const SE3 X = I.link_frame(b);
    const auto bu = static_cast<size_t>(b);
    const double mi = b == 0 ? mb->getBaseMass() : mb->getLink(b - 1).m_mass;
    R[bu] = X.R;
    c[bu] = X.p;
    v[bu] = X.R * from_bt(I.vel[bu]);
    w[bu] = X.R * from_bt(I.omega[bu]);
    mass += mi;
    mc += mi * c[bu];
    p += mi * v[bu];
  }
  t.p_WCom = mc / mass;
  t.v_WCom = p / mass;
  t.h_lin_W = p;
  Vector3d l = Vector3d::Zero();
  for (int b = 0; b < m.nb; ++b) {
    const auto bu = static_cast<size_t>(b);
    const double mi = b == 0 ? mb->getBaseMass() : mb->getLink(b - 1).m_mass;
    const Vector3d Id = b == 0 ? from_bt(mb->getBaseInertia()) : from_bt(mb->getLink(b - 1).m_inertiaLocal);
    l += mi * (c[bu] - t.p_WCom).cross(v[bu]) + R[bu] * Id.asDiagonal() * R[bu].transpose() * w[bu];
  }
  t.l_WCom = l;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const int frame = sole_frame_[ku];
    const int body = m.frames[static_cast<size_t>(frame)].body;
    const SE3 X_WS = I.bullet->body_placement(body) * m.frames[static_cast<size_t>(frame)].X_BF;
    t.p_WF[ku] = X_WS.p;
    t.quat_WF[ku] = quat_wxyz(X_WS.R);
    t.foot_tilt[ku] = std::acos(std::clamp(X_WS.R(2, 2), -1.0, 1.0));
    Vector6d wrench = I.contact_impulse_O[ku] / config_.dt;
    wrench.tail<3>() -= X_WS.p.cross(wrench.head<3>());
    t.contact_wrench_W[ku] = wrench;
    t.foot_contact[ku] = wrench(2) > 1.0;
  }
  const double tilt = std::acos(std::clamp(X_WB.R(2, 2), -1.0, 1.0)) * 180.0 / M_PI;
  t.fallen = t.fallen || X_WB.p.z() < config_.fallen_base_height || tilt > config_.fallen_tilt_deg;
}

void Simulator::compute_sensors() {
  Impl& I = *impl_;
  const model::Model& m = robot_->model;  // the controlled joints; bodies and frames of full_
  const btMultiBody* mb = I.bullet->multibody();
  const NoiseConfig& nc = config_.noise;
  const bool noisy = nc.enabled;
  std::normal_distribution<double> nd(0.0, 1.0);
  SensorData& s = sensors_;
  s.tick = tick_;
  s.time = time_;
  // Joints: quantised encoders and a velocity differentiated from them when noise is on.
  const double res = noisy && nc.encoder_bits > 0 ? 2.0 * M_PI / std::ldexp(1.0, nc.encoder_bits) : 0.0;
  VectorXd qm(m.nj);
  for (int j = 0; j < m.nj; ++j) {
    const double q = mb->getJointPos(joint_of_[static_cast<size_t>(j)]);
    qm(j) = res > 0 ? res * std::round(q / res) : q;
  }
  for (int j = 0; j < m.nj; ++j) {
    if (res > 0 && q_meas_prev_.size() == m.nj) {
      s.qd(j) = (qm(j) - q_meas_prev_(j)) / config_.dt;
    } else {
      s.qd(j) = mb->getJointVel(joint_of_[static_cast<size_t>(j)]);
    }
    s.tau(j) = applied_(j) + (noisy ? nc.joint_torque_noise * nd(rng_) : 0.0);
    std::int32_t st = 0;
    const JointCommand::Mode commanded = delay_line_[delay_head_].mode;  // the latest command's mode
    if (commanded == JointCommand::Mode::kRun && !stale_) st |= 1;
    if (commanded == JointCommand::Mode::kDamp || stale_) st |= 2;
    if (stale_) st |= 8;
    if (std::abs(applied_(j)) >= m.tau_max[static_cast<size_t>(j)] - 1e-9) st |= 16;
    s.drive_status[static_cast<size_t>(j)] = st;
  }
  s.q = qm;
  q_meas_prev_ = qm;
  // IMU: orientation, angular rate and specific force of the IMU frame.
  const model::Frame& imu = full_.frames[static_cast<size_t>(imu_frame_)];
  const int body = imu.body;
  const SE3 X_WL = I.link_frame(body);
  const SE3 X_WI = I.bullet->body_placement(body) * imu.X_BF;
  mb->compTreeLinkVelocities(I.omega.data(), I.vel.data());
  const Vector3d w = X_WL.R * from_bt(I.omega[static_cast<size_t>(body)]);
  const Vector3d v_com = X_WL.R * from_bt(I.vel[static_cast<size_t>(body)]);
  const Vector3d v_imu = v_com + w.cross(X_WI.p - X_WL.p);
  const Vector3d a_imu = have_v_imu_prev_ ? Vector3d((v_imu - v_imu_prev_) / config_.dt) : Vector3d::Zero();
  v_imu_prev_ = v_imu;
  have_v_imu_prev_ = true;
  s.imu_quat_WB = quat_wxyz(X_WI.R);
  s.imu_gyro_B = X_WI.R.transpose() * w;
  s.imu_accel_B = X_WI.R.transpose() * (a_imu - config_.gravity);
  if (noisy) {
    const double sg = nc.gyro_noise_density / std::sqrt(config_.dt), sa = nc.accel_noise_density / std::sqrt(config_.dt);
    for (int k = 0; k < 3; ++k) {
      gyro_bias_(k) += nc.gyro_bias_random_walk * std::sqrt(config_.dt) * nd(rng_);
      s.imu_gyro_B(k) += gyro_bias_(k) + sg * nd(rng_);
      s.imu_accel_B(k) += sa * nd(rng_);
    }
  }
  // Ankle force/torque: the wrench the part below the sensor applies to the leg, in the sensor frame
  // S: contact wrench + its weight − the rate of its momentum (all about the sensor origin).
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const model::Frame& ft = full_.frames[static_cast<size_t>(ft_frame_[ku])];
    const int fb = ft.body;
    const SE3 X_WS = I.bullet->body_placement(fb) * ft.X_BF;
    const SE3 X_WF = I.link_frame(fb);
    const double mf = fb == 0 ? mb->getBaseMass() : mb->getLink(fb - 1).m_mass;
    const Vector3d If = fb == 0 ? from_bt(mb->getBaseInertia()) : from_bt(mb->getLink(fb - 1).m_inertiaLocal);
    const Vector3d wf = X_WF.R * from_bt(I.omega[static_cast<size_t>(fb)]);
    const Vector3d vf = X_WF.R * from_bt(I.vel[static_cast<size_t>(fb)]);
    // Momentum of the foot about the world origin.
    Vector6d h;
    h.head<3>() = mf * vf;
    h.tail<3>() = X_WF.p.cross(h.head<3>()) + X_WF.R * If.asDiagonal() * X_WF.R.transpose() * wf;
    const Vector6d hdot = have_foot_momentum_prev_ ? Vector6d((h - foot_momentum_prev_[ku]) / config_.dt) : Vector6d::Zero();
    foot_momentum_prev_[ku] = h;
    Vector6d w_O = I.contact_impulse_O[ku] / config_.dt;  // ground on foot, about O
    w_O.head<3>() += mf * config_.gravity;
    w_O.tail<3>() += X_WF.p.cross(mf * config_.gravity);
    w_O -= hdot;
    // About the sensor origin, in the sensor frame.
    Vector6d w_S;
    w_S.head<3>() = X_WS.R.transpose() * w_O.head<3>();
    w_S.tail<3>() = X_WS.R.transpose() * (w_O.tail<3>() - X_WS.p.cross(w_O.head<3>()));
    if (noisy) {
      for (int a = 0; a < 3; ++a) {
        w_S(a) += nc.ft_force_noise * nd(rng_);
        w_S(3 + a) += nc.ft_torque_noise * nd(rng_);
      }
    }
    s.ft_wrench_S[ku] = w_S;
  }
  have_foot_momentum_prev_ = true;
}

}  // namespace hpr::sim
