// The estimator's two Kalman filters: the attitude filter with gyro bias (IMU propagation, gravity
// and level-ground corrections) and the position/velocity filter (IMU acceleration, leg kinematics
// of the soles in contact). The rest of the tick is in estimator.cpp.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hpr/estimator/estimator.hpp"

namespace hpr::estimator {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using model::Vector6d;

namespace {

constexpr double kAnchorTrust = 0.1;  // [s] a sole in contact this long may override the estimate alone

}  // namespace

void Estimator::attitude_correct(const Vector3d& r, double sigma, const Matrix3d& H) {
  // δ = K r on the error state (δθ, δb) with measurement Jacobian [H 0].
  Eigen::Matrix<double, 6, 3> PHt = P_att_.leftCols<3>() * H.transpose();
  const Matrix3d S = H * PHt.topRows<3>() + Matrix3d::Identity() * sigma * sigma;
  const Eigen::Matrix<double, 6, 3> K = PHt * S.inverse();
  const Vector6d delta = K * r;
  R_ = R_ * model::exp3(delta.head<3>());
  b_ += delta.tail<3>();
  Eigen::Matrix<double, 6, 6> IKH = Eigen::Matrix<double, 6, 6>::Identity();
  IKH.leftCols<3>() -= K * H;
  P_att_ = IKH * P_att_ * IKH.transpose() + K * (sigma * sigma) * K.transpose();
}

void Estimator::attitude(const SensorSample& s, double dt) {
  // Prediction with the gyro: R ← R exp((R_BI (ω_m − b̂) − ω_rel) dt); the right-invariant error δθ
  // (base frame) follows δθ̇ = −[ω]× δθ − R_BI δb − R_BI n_g.
  const Vector3d w_gyro = R_BI_ * (s.imu_gyro_B - b_) - w_BI_;
  R_ = R_ * model::exp3(w_gyro * dt);
  Eigen::Matrix<double, 6, 6> F = Eigen::Matrix<double, 6, 6>::Identity();
  F.topLeftCorner<3, 3>() = model::exp3(-w_gyro * dt);
  F.topRightCorner<3, 3>() = -R_BI_ * dt;
  P_att_ = F * P_att_ * F.transpose();
  P_att_.topLeftCorner<3, 3>().diagonal().array() += config_.gyro_noise * config_.gyro_noise * dt;
  P_att_.bottomRightCorner<3, 3>().diagonal().array() += config_.gyro_bias_walk * config_.gyro_bias_walk * dt;
  // Corrections: each sole in contact gives R_WB = R_WS,hold R_BSᵀ(q).
  bool any = false;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!contact_[ku]) continue;
    any = true;
    if (!anchor_[ku]) continue;
    const Matrix3d R_meas = R_WS_hold_[ku] * X_BS_[ku].R.transpose();
    attitude_correct(model::log3(R_.transpose() * R_meas), config_.kinematic_orientation_noise, Matrix3d::Identity());
  }
  // Without contact, the accelerometer's gravity direction when it reads about 1 g.
  const Vector3d f_B = R_BI_ * s.imu_accel_B;
  const double gn = robot_->model.gravity.norm();
  if (!any && std::abs(f_B.norm() - gn) < 0.1 * gn) {
    const Vector3d u = R_.transpose() * Vector3d::UnitZ();
    attitude_correct(f_B.normalized() - u, config_.accel_orientation_noise, model::skew(u));
  }
  // Angular velocity of the base: gyro and, for each sole in contact, ω_B = −ω_S,rel.
  P_w_ += config_.angular_accel_noise * config_.angular_accel_noise * dt;
  const double r_gyro = config_.gyro_noise * config_.gyro_noise / dt + P_att_.bottomRightCorner<3, 3>().trace() / 3.0;
  double K = P_w_ / (P_w_ + r_gyro);
  w_ += K * (R_BI_ * (s.imu_gyro_B - b_) - w_BI_ - w_);
  P_w_ *= 1.0 - K;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!anchor_[ku]) continue;
    K = P_w_ / (P_w_ + config_.kinematic_rate_noise * config_.kinematic_rate_noise);
    w_ += K * (-w_BS_[ku] - w_);
    P_w_ *= 1.0 - K;
  }
}

void Estimator::position_correct(int at, const Vector3d& residual, double sigma, bool velocity) {
  // Measurement H x with H = [−I at p, +I at the foot] (position) or [I at v] (velocity).
  Eigen::Matrix<double, 12, 3> PHt;
  Matrix3d HPHt;
  if (velocity) {
    PHt = P_.middleCols<3>(3);
    HPHt = P_.block<3, 3>(3, 3);
  } else {
    PHt = P_.middleCols<3>(at) - P_.leftCols<3>();
    HPHt = PHt.middleRows<3>(at) - PHt.topRows<3>();
  }
  const Matrix3d S = HPHt + Matrix3d::Identity() * sigma * sigma;
  const Eigen::Matrix<double, 12, 3> K = PHt * S.inverse();
  x_ += K * residual;
  P_ -= K * PHt.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
}

void Estimator::position(const SensorSample& s, double dt) {
  const Vector3d g = robot_->model.gravity;
  // Prediction with the IMU's acceleration a_I = R_WI f_I + g.
  const Vector3d a = R_ * R_BI_ * s.imu_accel_B + g;
  x_.head<3>() += x_.segment<3>(3) * dt + 0.5 * a * dt * dt;
  x_.segment<3>(3) += a * dt;
  Eigen::Matrix<double, 12, 12> F = Eigen::Matrix<double, 12, 12>::Identity();
  F.block<3, 3>(0, 3) = Matrix3d::Identity() * dt;
  P_ = F * P_ * F.transpose();
  const double qa = config_.accel_noise * config_.accel_noise;
  for (int i = 0; i < 3; ++i) {
    P_(i, i) += qa * dt * dt * dt / 3.0;
    P_(i, 3 + i) += qa * dt * dt / 2.0;
    P_(3 + i, i) += qa * dt * dt / 2.0;
    P_(3 + i, 3 + i) += qa * dt;
  }
  for (int k = 0; k < 2; ++k) {
    const double sf = anchor_[static_cast<size_t>(k)] ? config_.foot_contact_noise : config_.foot_swing_noise;
    P_.block<3, 3>(6 + 3 * k, 6 + 3 * k).diagonal().array() += sf * sf * dt;
  }
  // Corrections from each sole in contact: its position relative to the IMU point, and the IMU
  // point's velocity with the sole at rest (imu_velocity_at_rest).
  // A sole that reads as loaded while it moves (a swing foot's own inertia on its sensor, a sliding
  // sole) is no anchor either: an anchor whose velocity measurement disagrees with the estimate by
  // more than anchor_velocity_gate is left out, as long as another anchor agrees (when none does,
  // the estimate is what is wrong, and every anchor that has stayed in contact corrects it).
  // Whether a velocity measurement of the IMU point agrees with the estimate as it stands.
  const auto agrees = [this](const Vector3d& v_I) {
    return config_.anchor_velocity_gate <= 0.0 || (v_I - x_.segment<3>(3)).norm() <= config_.anchor_velocity_gate;
  };
  std::array<Vector3d, 2> v_meas{};
  std::array<bool, 2> use{};
  bool any_agrees = false;
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    const int i = 6 + 3 * k;
    const Vector3d d = X_BS_[ku].p - p_BI_;
    if (!anchor_[ku]) {
      // A sole in the air, or in contact but rotating about an edge or settling: it follows the leg.
      x_.segment<3>(i) = x_.head<3>() + R_ * d;
      continue;
    }
    v_meas[ku] = imu_velocity_at_rest(ku, Vector3d::Zero());
    const bool agreed = agrees(v_meas[ku]);
    // A sole that touched down moments ago and disagrees may not be down at all (a swing foot's
    // inertia on its sensor): it overrides the estimate only once it has stayed in contact.
    use[ku] = agreed || s.time - touchdown_time_[ku] >= kAnchorTrust;
    any_agrees = any_agrees || agreed;
  }
  // A sole rolling on an edge: the velocity with its point at the CoP at rest, when it agrees with
  // the estimate (it never overrides it).
  for (int k = 0; k < 2 && config_.edge_velocity_noise > 0.0; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!rolling_[ku]) continue;
    const Vector3d v = imu_velocity_at_rest(ku, cop_S_[ku]);
    if (agrees(v)) position_correct(3, v - x_.segment<3>(3), config_.edge_velocity_noise, true);
  }
  for (int k = 0; k < 2; ++k) {
    const auto ku = static_cast<size_t>(k);
    if (!use[ku]) continue;
    if (any_agrees && !agrees(v_meas[ku])) continue;
    const int i = 6 + 3 * k;
    const Vector3d d = X_BS_[ku].p - p_BI_;
    const Vector3d r_pos = R_ * d - (x_.segment<3>(i) - x_.head<3>());
    position_correct(i, r_pos, config_.kinematic_position_noise, false);
    position_correct(3, v_meas[ku] - x_.segment<3>(3), config_.kinematic_velocity_noise, true);
  }
}

}  // namespace hpr::estimator
