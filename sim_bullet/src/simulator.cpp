// The simulator: building the Bullet multibody and its colliders from the robot's description,
// commands through the drive model, pushes and the physics step (its readings in readings.cpp).
#include "simulator_impl.hpp"

namespace hpr::sim {

using Eigen::VectorXd;

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

/// The Bullet shape of a collision geometry of `link`; `X_BG` (the geometry in its body's frame) is
/// moved to the shape's centre where the shape needs it (a mesh's bounding box).
std::unique_ptr<btCollisionShape> collision_shape(const model::Geometry& g, const model::RobotSpec& robot, const model::Model& m,
                                                  const model::LinkDesc* link, SE3& X_BG) {
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
  return shape;
}

/// A foot's configured sole as its collision shape: a box of the sole's rectangle, 2 cm thick, its
/// bottom face on the sole (`X_LS`: the sole frame in the Bullet link frame).
void add_sole_box(const model::FootSpec& foot, const char* side, const SE3& X_LS, btCompoundShape& compound,
                  std::vector<std::unique_ptr<btCollisionShape>>& shapes) {
  constexpr double kThickness = 0.02;
  SE3 X_SC;
  X_SC.p = Vector3d(0.0, 0.0, 0.5 * kThickness);
  auto box = std::make_unique<btBoxShape>(to_bt(Vector3d(0.5 * foot.length, 0.5 * foot.width, 0.5 * kThickness)));
  compound.addChildShape(to_bt(X_LS * X_SC), box.get());
  shapes.push_back(std::move(box));
  log::info("the {} foot link '{}' has no collision geometry: it collides with its configured sole, a box of {:.3f} x {:.3f} x {:.3f} m",
            side, foot.link, foot.length, foot.width, kThickness);
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
        std::unique_ptr<btCollisionShape> shape = collision_shape(g, robot, m, link, X_BG);
        compound->addChildShape(to_bt(X_LB * X_BG), shape.get());
        I.shapes.push_back(std::move(shape));
      }
    }
    for (int k = 0; k < 2; ++k) {
      // A foot without collision geometry (a description with inertias only) stands on its sole.
      const auto ku = static_cast<size_t>(k);
      if (b == foot_bodies[ku] && compound->getNumChildShapes() == 0) {
        add_sole_box(robot.feet[ku], model::kFootNames[ku], X_LB * m.frames[static_cast<size_t>(sole_frame_[ku])].X_BF, *compound, I.shapes);
      }
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
  if (config_.joint_limits) I.add_joint_limits(m);
  I.add_ground(config_.ground_friction, config_.ground_restitution);

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

}  // namespace hpr::sim
