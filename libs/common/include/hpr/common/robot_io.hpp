#pragma once
/// \file
/// What crosses the boundary between the robot (hardware or simulation) and the controllers, as
/// plain data without LCM: one sensor sample and one joint command. Joint order is the model's.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hpr {

/// One sample of every sensor for one tick.
struct SensorSample {
  std::int64_t tick = 0;
  double time = 0.0;                       ///< robot clock [s]
  Eigen::VectorXd q, qd, tau;              ///< joint position [rad], velocity [rad/s], torque [Nm]
  std::vector<std::int32_t> drive_status;  ///< robot_sensors_t::DRIVE_* bits
  Eigen::Vector4d imu_quat_WB{1, 0, 0, 0}; ///< IMU orientation (w, x, y, z)
  Eigen::Vector3d imu_gyro_B = Eigen::Vector3d::Zero();   ///< [rad/s], IMU frame
  Eigen::Vector3d imu_accel_B = Eigen::Vector3d::Zero();  ///< specific force [m/s²], IMU frame
  std::array<Eigen::Matrix<double, 6, 1>, 2> ft_wrench_S{};  ///< right, left: foot on leg, sensor frame

  void resize(int joints) {
    q = qd = tau = Eigen::VectorXd::Zero(joints);
    drive_status.assign(static_cast<std::size_t>(joints), 0);
  }
};

/// Per-joint impedance command evaluated at the drive: τ = τ_ff + kp (q_des − q) + kd (q̇_des − q̇).
struct JointCommand {
  enum class Mode : std::int8_t { kOff = 0, kDamp = 1, kRun = 2 };
  Mode mode = Mode::kOff;
  std::int64_t tick = -1;
  Eigen::VectorXd tau_ff, q_des, qd_des, kp, kd;

  void resize(int joints) { tau_ff = q_des = qd_des = kp = kd = Eigen::VectorXd::Zero(joints); }
  /// Empty when the command is usable for `joints` joints, else why not (size, non-finite, negative gain).
  [[nodiscard]] std::string check(int joints) const;
};

}  // namespace hpr
