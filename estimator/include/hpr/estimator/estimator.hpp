#pragma once
/// \file
/// Floating-base state estimation from a real robot's sensors (joint encoders and torques, a pelvis
/// IMU, ankle force/torque sensors):
///  - joints: positions from the encoders; velocities by an α-β (steady-state Kalman) filter per
///    joint, which removes quantisation noise with little lag;
///  - attitude: an error-state Kalman filter on (R_WB, gyro bias), predicted with the gyro and
///    corrected by the orientation the legs in contact give (feet flat on level ground, yaw held
///    from the touchdown) and by the accelerometer's gravity direction;
///  - position and velocity: a linear Kalman filter on (p_WB, v_WB, p_right, p_left) driven by the
///    IMU's acceleration, corrected by the leg kinematics of the feet in contact (the feet stay put
///    while in contact and are free otherwise);
///  - contact: each foot's normal force from its ankle sensor (less the foot's weight), with
///    hysteresis;
///  - CAM: a momentum observer l̂̇ = Σ_contacts (torque about the CoM) + K (A_G q̇ − l̂): the measured
///    contact wrenches give the fast part, the kinematic momentum the slow part, and the residual is
///    the disturbance torque (a push).

#include <Eigen/Core>
#include <array>
#include <string>

#include "hpr/common/config.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::estimator {

struct EstimatorConfig {
  // Joint velocity filter (α-β): white acceleration noise of the joints and encoder noise.
  double joint_accel_noise = 200.0;       ///< [rad/s²/√Hz]
  double encoder_noise = 3e-5;            ///< [rad]
  bool filter_joint_velocity = true;
  // Attitude.
  double gyro_noise = 0.005;              ///< [rad/s/√Hz]
  double gyro_bias_walk = 1e-4;           ///< [rad/s²/√Hz]
  double gyro_bias_initial = 0.01;        ///< [rad/s] prior standard deviation
  double kinematic_orientation_noise = 2e-3;  ///< [rad] of the leg-kinematics orientation
  double accel_orientation_noise = 0.05;  ///< [rad] of the gravity direction when not accelerating
  bool level_ground = true;               ///< feet in contact are flat
  // Position.
  double accel_noise = 0.05;              ///< [m/s²/√Hz]
  double foot_contact_noise = 1e-4;       ///< [m/√s] random walk of a foot in contact
  double foot_swing_noise = 1.0;          ///< [m/√s] of a foot in the air
  double kinematic_position_noise = 1e-3; ///< [m]
  // Contact.
  double contact_on = 50.0;               ///< [N] normal force to declare contact
  double contact_off = 20.0;              ///< [N] to release it
  // Momentum observer.
  double cam_observer_gain = 20.0;        ///< [1/s]
  // Health.
  double max_covariance = 1.0;            ///< trace of the position covariance beyond which it diverged
  double max_accel_norm = 60.0;           ///< [m/s²] beyond this a reading is implausible
  double max_ft_force = 5000.0;           ///< [N]
  static EstimatorConfig load(const Config& section);
};

/// One step's flags (robot_state_t::STATUS_* bits).
enum StatusBits : int { kOk = 0, kSensorStale = 1, kNoContact = 2, kCovariance = 4, kImplausible = 8, kInitialising = 16 };

class Estimator {
 public:
  Estimator(const model::RobotSpec& robot, EstimatorConfig config);

  /// Processes one sensor sample (dt from the previous one). Returns the estimated state.
  const EstimatedState& update(const SensorSample& s);
  /// Resets to uninitialised (the next sample initialises).
  void reset();

  [[nodiscard]] const EstimatedState& state() const { return state_; }
  [[nodiscard]] bool initialised() const { return initialised_; }
  [[nodiscard]] const Eigen::Vector3d& gyro_bias() const { return bias_; }
  [[nodiscard]] const std::string& implausible_reason() const { return implausible_; }
  [[nodiscard]] double position_covariance_trace() const;

 private:
  void initialise(const SensorSample& s);
  void update_joints(const SensorSample& s, double dt);
  void update_contacts(const SensorSample& s);
  void attitude_predict(const Eigen::Vector3d& gyro, double dt);
  void attitude_correct(const Eigen::Matrix3d& R_meas, double sigma, bool full);
  void position_predict(const Eigen::Vector3d& a_W, double dt);
  void position_correct();
  void momentum_observer(double dt);
  bool plausible(const SensorSample& s);

  const model::RobotSpec* robot_;
  EstimatorConfig config_;
  model::Data data_;
  EstimatedState state_;
  bool initialised_ = false;
  double last_time_ = 0.0;
  // Joints.
  Eigen::VectorXd q_, qd_;
  // Attitude: R_WB, gyro bias, covariance of (δθ, δb).
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero(), omega_W_ = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> P_att_;
  std::array<Eigen::Matrix3d, 2> R_foot_hold_;  // sole orientation held since touchdown
  // Position: x = (p, v, p_r, p_l), covariance.
  Eigen::Matrix<double, 12, 1> x_;
  Eigen::Matrix<double, 12, 12> P_;
  // Contact and wrenches.
  std::array<bool, 2> contact_{};
  std::array<double, 2> foot_mass_{};
  std::array<Eigen::Vector3d, 2> foot_com_B_{};  // CoM of the part below each sensor, in its body frame
  // Momentum observer.
  Eigen::Vector3d l_hat_ = Eigen::Vector3d::Zero();
  std::string implausible_;
};

}  // namespace hpr::estimator
