// What the simulator reports each tick: the truth (SIM_TRUTH: state, contacts, momentum) and the
// sensors (ROBOT_SENSORS: encoders, IMU, ankle force/torque, with their noise).
#include <algorithm>
#include <cmath>

#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using model::SE3;
using model::Vector6d;

namespace {
Eigen::Vector4d quat_wxyz(const Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return {q.w(), q.x(), q.y(), q.z()};
}
}  // namespace

void Simulator::refresh_motion() { engine_->body_motions(motion_); }

void Simulator::compute_truth() {
  const model::Model& m = full_;
  TruthData& t = truth_;
  t.tick = tick_;
  t.time = time_;
  engine_->get_state(q_full_, v_full_);
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
  const SE3 X_WB = engine_->body_placement(0);
  t.p_WB = X_WB.p;
  t.quat_WB = quat_wxyz(X_WB.R);
  t.v_WB = X_WB.R * t.v.head<3>();
  t.omega_WB = X_WB.R * t.v.segment<3>(3);
  // Centre of mass, momentum and CAM from the engine's link states.
  refresh_motion();
  double mass = 0;
  Vector3d mc = Vector3d::Zero(), p = Vector3d::Zero();
  for (const BodyMotion& b : motion_) {
    mass += b.m;
    mc += b.m * b.c_W;
    p += b.m * b.v_W;
  }
  t.p_WCom = mc / mass;
  t.v_WCom = p / mass;
  t.h_lin_W = p;
  Vector3d l = Vector3d::Zero();
  for (const BodyMotion& b : motion_) {
    l += b.m * (b.c_W - t.p_WCom).cross(b.v_W) + b.R_WI * b.I_principal.asDiagonal() * b.R_WI.transpose() * b.omega_W;
  }
  t.l_WCom = l;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const int frame = sole_frame_[ku];
    const int body = m.frames[static_cast<size_t>(frame)].body;
    const SE3 X_WS = engine_->body_placement(body) * m.frames[static_cast<size_t>(frame)].X_BF;
    t.p_WF[ku] = X_WS.p;
    t.quat_WF[ku] = quat_wxyz(X_WS.R);
    t.foot_tilt[ku] = std::acos(std::clamp(X_WS.R(2, 2), -1.0, 1.0));
    Vector6d wrench = contact_impulse_O_[ku] / config_.dt;
    wrench.tail<3>() -= X_WS.p.cross(wrench.head<3>());
    t.contact_wrench_W[ku] = wrench;
    t.foot_contact[ku] = wrench(2) > 1.0;
  }
  const double tilt = std::acos(std::clamp(X_WB.R(2, 2), -1.0, 1.0)) * 180.0 / M_PI;
  t.fallen = t.fallen || X_WB.p.z() < config_.fallen_base_height || tilt > config_.fallen_tilt_deg;
}

void Simulator::compute_sensors() {
  const model::Model& m = robot_->model;  // the controlled joints; bodies and frames of full_
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
    const double q = engine_->joint_position(joint_of_[static_cast<size_t>(j)]);
    qm(j) = res > 0 ? res * std::round(q / res) : q;
  }
  for (int j = 0; j < m.nj; ++j) {
    if (res > 0 && q_meas_prev_.size() == m.nj) {
      s.qd(j) = (qm(j) - q_meas_prev_(j)) / config_.dt;
    } else {
      s.qd(j) = engine_->joint_velocity(joint_of_[static_cast<size_t>(j)]);
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
  const BodyMotion& bm = motion_[static_cast<size_t>(body)];  // refreshed by compute_truth
  const SE3 X_WI = engine_->body_placement(body) * imu.X_BF;
  const Vector3d& w = bm.omega_W;
  const Vector3d v_imu = bm.v_W + w.cross(X_WI.p - bm.c_W);
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
    const SE3 X_WS = engine_->body_placement(fb) * ft.X_BF;
    const BodyMotion& f = motion_[static_cast<size_t>(fb)];
    const double mf = f.m;
    // Momentum of the foot about the world origin.
    Vector6d h;
    h.head<3>() = mf * f.v_W;
    h.tail<3>() = f.c_W.cross(h.head<3>()) + f.R_WI * f.I_principal.asDiagonal() * f.R_WI.transpose() * f.omega_W;
    const Vector6d hdot = have_foot_momentum_prev_ ? Vector6d((h - foot_momentum_prev_[ku]) / config_.dt) : Vector6d::Zero();
    foot_momentum_prev_[ku] = h;
    Vector6d w_O = contact_impulse_O_[ku] / config_.dt;  // ground on foot, about O
    w_O.head<3>() += mf * config_.gravity;
    w_O.tail<3>() += f.c_W.cross(mf * config_.gravity);
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
