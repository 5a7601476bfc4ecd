// The simulator, whichever engine steps it: commands through the drive model, the held joints,
// pushes and the physics step (its readings in readings.cpp; the engines in bullet_engine.cpp and
// sim_mujoco).
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hpr/common/log.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

using Eigen::Vector3d;
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

}  // namespace

Simulator::Simulator(const model::RobotSpec& robot, SimConfig config, const EngineFactory& make_engine)
    : robot_(&robot), config_(config), full_(robot.full_model(config.held_rigid)), rng_(config.noise.seed) {
  apply_model_error(full_, config_.model_error);
  const model::Model& m = full_;
  for (const auto& name : robot.model.joint_name) joint_of_.push_back(m.joint_index(name));
  held_q_.resize(static_cast<Eigen::Index>(robot.model.held_joint_name.size()));
  held_tau_ = VectorXd::Zero(held_q_.size());
  for (size_t k = 0; k < robot.model.held_joint_name.size(); ++k) {
    if (!config_.held_rigid) held_joint_.push_back(m.joint_index(robot.model.held_joint_name[k]));
    held_q_(static_cast<Eigen::Index>(k)) = robot.model.held_q[k];
  }
  for (size_t k = 0; k < 2; ++k) {
    sole_frame_[k] = m.frame_index(robot.model.frames[static_cast<size_t>(robot.feet[k].sole_frame)].name);
    ft_frame_[k] = m.frame_index(robot.model.frames[static_cast<size_t>(robot.feet[k].ft_frame)].name);
    foot_body_[k] = m.frames[static_cast<size_t>(sole_frame_[k])].body;
  }
  imu_frame_ = m.frame_index(robot.model.frames[static_cast<size_t>(robot.imu_frame)].name);
  engine_ = make_engine(robot, m, config_, foot_body_);
  if (!engine_) throw std::invalid_argument(std::string("no ") + to_string(config_.engine) + " engine was made for the simulator");
  motion_.resize(static_cast<size_t>(m.nb));
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
  engine_->set_state(q_full_, v_full_);
  have_v_imu_prev_ = false;
  have_foot_momentum_prev_ = false;
  compute_truth();
  compute_sensors();
}

VectorXd Simulator::settle_torque() const {
  const model::Model& m = robot_->model;
  VectorXd tau(m.nj);
  for (int j = 0; j < m.nj; ++j) {
    const int b = joint_of_[static_cast<size_t>(j)];
    tau(j) = settle_kp_(j) * (robot_->q_joints_stand(j) - engine_->joint_position(b)) - settle_kd_(j) * engine_->joint_velocity(b);
  }
  return tau;
}

double Simulator::drive(int j, double tau, double kd, double qd, double lim, double friction) {
  const double applied = std::clamp(tau, -lim, lim);
  if (engine_->integrates_damping() && kd > 0.0 && applied == tau) {
    // τ = (τ − (−kd q̇)) − kd q̇: the engine integrates the −kd q̇ part implicitly.
    engine_->add_joint_torque(j, tau + kd * qd + friction);
    engine_->add_joint_damping(j, kd);
  } else {
    engine_->add_joint_torque(j, applied + friction);
  }
  return applied;
}

void Simulator::apply_hold(JointCommand::Mode mode) {
  for (size_t k = 0; k < held_joint_.size(); ++k) {
    const int b = held_joint_[k];
    const auto ku = static_cast<Eigen::Index>(k);
    const double q = engine_->joint_position(b), qd = engine_->joint_velocity(b);
    double tau = 0.0, kd = 0.0;
    if (held_external_) {
      // The drives of the held joints as the hal commands them.
      const JointCommand& c = held_command_;
      if (c.mode == JointCommand::Mode::kRun) {
        tau = c.tau_ff(ku) + c.kp(ku) * (c.q_des(ku) - q) + c.kd(ku) * (c.qd_des(ku) - qd);
        kd = c.kd(ku);
      } else if (c.mode == JointCommand::Mode::kDamp) {
        tau = -c.kd(ku) * qd;
        kd = c.kd(ku);
      }
    } else if (mode == JointCommand::Mode::kRun) {
      tau = held_kp_(ku) * (held_q_(ku) - q) - held_kd_(ku) * qd;
      kd = held_kd_(ku);
    } else if (mode == JointCommand::Mode::kDamp) {
      tau = -held_kd_(ku) * qd;
      kd = held_kd_(ku);
    }
    held_tau_(ku) = drive(b, tau, kd, qd, full_.tau_max[static_cast<size_t>(b)]);
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
  engine_->set_state(q_full_, v_full_);
  // Settle: hold the standing posture with stiff joint springs.
  const int settle_steps = static_cast<int>(std::round(config_.settle_time / config_.dt));
  const double h = config_.dt / config_.substeps;
  for (int k = 0; k < settle_steps * config_.substeps; ++k) {
    // The contact impulses of the last control period of the settling are tick 0's contact forces.
    if (k % config_.substeps == 0) {
      for (auto& w : contact_impulse_O_) w.setZero();
    }
    const VectorXd tau = settle_torque();
    for (int j = 0; j < m.nj; ++j) {
      const int b = joint_of_[static_cast<size_t>(j)];
      (void)drive(b, tau(j), settle_kd_(j), engine_->joint_velocity(b), m.tau_max[static_cast<size_t>(j)]);
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
  // The oldest command of the delay line (the newest one without a delay).
  const JointCommand& c = delay_line_[(delay_head_ + 1) % delay_line_.size()];
  stale_ = time_ - command_time_ > config_.command_timeout + 1e-9;
  JointCommand::Mode mode = stale_ ? JointCommand::Mode::kDamp : c.mode;
  for (int j = 0; j < m.nj; ++j) {
    const int b = joint_of_[static_cast<size_t>(j)];
    const double q = engine_->joint_position(b), qd = engine_->joint_velocity(b);
    double tau = 0.0, kd = 0.0;
    if (mode == JointCommand::Mode::kRun) {
      tau = c.tau_ff(j) + c.kp(j) * (c.q_des(j) - q) + c.kd(j) * (c.qd_des(j) - qd);
      kd = c.kd(j);
    } else if (mode == JointCommand::Mode::kDamp) {
      kd = stale_ ? config_.damping_kd : c.kd(j);
      tau = -kd * qd;
    }
    // Joint friction acts in the joint on top of the motor torque.
    double fric = -config_.joint_friction_viscous * qd;
    if (config_.joint_friction_coulomb > 0) fric -= config_.joint_friction_coulomb * std::tanh(qd / 0.01);
    applied_(j) = drive(b, tau, kd, qd, m.tau_max[static_cast<size_t>(j)], fric);
  }
  apply_hold(mode);
}

void Simulator::physics_substep(double h) {
  const model::Model& m = full_;
  for (const Push& p : pushes_) {
    const Vector3d F = p.force_at(time_);
    if (F.isZero()) continue;
    const model::Frame& frame = m.frames[static_cast<size_t>(m.frame_index(p.link))];
    const Vector3d point = (engine_->body_placement(frame.body) * frame.X_BF).act(p.point_L);
    engine_->add_force(frame.body, F, point);
    truth_.push_impulse_W += F * h;
    truth_.push_point_W = point;
  }
  engine_->step(h, contact_impulse_O_);
}

void Simulator::step() {
  const double h = config_.dt / config_.substeps;
  truth_.push_force_W.setZero();
  for (auto& w : contact_impulse_O_) w.setZero();
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
