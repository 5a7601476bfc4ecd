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
  std::vector<std::int32_t> drive_status;  ///< per joint, kDrive* bits (robot_sensors_t::DRIVE_*)
  /// drive_status bits. Stale: the drive did not answer this tick; q, qd, tau hold older values.
  static constexpr std::int32_t kDriveEnabled = 1, kDriveDamping = 2, kDriveFault = 4, kDriveStale = 8;
  /// The reading of `joint` is older than this tick (its drive did not answer).
  [[nodiscard]] bool stale(int joint) const {
    const auto j = static_cast<std::size_t>(joint);
    return j < drive_status.size() && (drive_status[j] & kDriveStale) != 0;
  }
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
  double time = 0.0;  ///< [s] the time of the sample the command answers (its stream's clock: the time rule holds it)
  Eigen::VectorXd tau_ff, q_des, qd_des, kp, kd;

  void resize(int joints) { tau_ff = q_des = qd_des = kp = kd = Eigen::VectorXd::Zero(joints); }
  /// Empty when the command is usable for `joints` joints, else why not (size, non-finite, negative gain).
  [[nodiscard]] std::string check(int joints) const;
};

/// The floating-base state the estimator publishes (ROBOT_STATE), in the model's coordinates:
/// q = (p_WB, quat (x, y, z, w), joints), v = (base twist in the base frame, joint velocities).
struct EstimatedState {
  std::int64_t tick = 0;
  double time = 0.0;
  Eigen::VectorXd q, v;
  Eigen::Vector3d p_com = Eigen::Vector3d::Zero(), v_com = Eigen::Vector3d::Zero();
  Eigen::VectorXd tau;                          ///< measured joint torques
  std::array<bool, 2> contact{};                ///< right, left
  std::array<double, 2> foot_force_z{};
  /// Ground on foot at the sole centre, world axes, from each ankle sensor less the weight of the foot
  /// below it: the momentum rate of the foot is not taken off, so a foot in the air reads its inertia.
  std::array<Eigen::Matrix<double, 6, 1>, 2> foot_wrench_W{};
  Eigen::Vector3d l_com = Eigen::Vector3d::Zero(), ldot_com = Eigen::Vector3d::Zero();  ///< measured CAM and rate
  std::int32_t status = 0;                      ///< robot_state_t::STATUS_* bits

  /// Status bits (robot_state_t::STATUS_*).
  static constexpr std::int32_t kSensorStale = 1, kNoContact = 2, kCovariance = 4, kImplausible = 8, kInitialising = 16;
  /// Bits of an estimate nothing may act on or start from: sensors stale or incomplete, a reading
  /// implausible, the filter diverged.
  static constexpr std::int32_t kUnusable = kSensorStale | kImplausible | kCovariance;
  [[nodiscard]] bool usable() const { return (status & kUnusable) == 0; }
};

/// Ground truth of a simulation step (SIM_TRUTH): what no sensor measures directly, for tests,
/// figures and the evaluation of trials. W world, B the root link, F a sole centre, Com the CoM.
struct SimTruth {
  std::int64_t tick = 0;
  double time = 0.0;
  Eigen::Vector3d p_WB, v_WB, omega_WB, p_WCom, v_WCom, h_lin_W, l_WCom;
  Eigen::Vector4d quat_WB{1, 0, 0, 0};  ///< (w, x, y, z)
  std::array<Eigen::Vector3d, 2> p_WF;
  std::array<Eigen::Vector4d, 2> quat_WF;  ///< (w, x, y, z)
  std::array<Eigen::Matrix<double, 6, 1>, 2> contact_wrench_W;  ///< ground on foot at the sole centre
  std::array<bool, 2> foot_contact{};
  std::array<double, 2> foot_tilt{};  ///< [rad] between the sole normal and world z
  std::int64_t push_id = -1;
  bool push_active = false;
  Eigen::Vector3d push_force_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d push_impulse_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d push_point_W = Eigen::Vector3d::Zero();  ///< where the current or last push acts [m]
  bool fallen = false;
  Eigen::VectorXd q, v;  ///< Bullet's state in the controlled model's coordinates (held joints left out)
  Eigen::VectorXd q_held;  ///< positions of the held joints, in the order of RobotSpec::model.held_joint_name
  Eigen::VectorXd v_held;  ///< their velocities
  Eigen::VectorXd tau_held;  ///< the torques their drives applied in the last sub-step
};

}  // namespace hpr
