#pragma once
/// \file
/// The task-space reference of a balancing robot: every coordinate of the task vector of (2) —
/// CoM, base orientation, both feet and the free joints — with velocities and accelerations, the
/// support mode and the contact state of each foot. PostureReference produces it for standing in
/// double or single support, with smooth transitions (CoM shift and load transfer, then lift).
/// It plays the part of the paper's high-level planner, which holds a fixed posture when balancing.

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "hpr/common/config.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::balance {

enum class Support : std::int8_t { kDouble = 0, kLeft = 1, kRight = 2 };
const char* to_string(Support s);
Support support_from_string(const std::string& s);

struct FootReference {
  model::SE3 X_WS;                                            ///< sole pose
  Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Zero();  ///< (v, ω) world, at the sole
  Eigen::Matrix<double, 6, 1> accel = Eigen::Matrix<double, 6, 1>::Zero();
  bool contact = true;        ///< the foot carries load (else it is a swing foot under impedance)
  double load_limit = 1.0;    ///< fraction of the maximum normal force it may carry, for load transfer
};

struct TaskReference {
  double time = 0.0;
  Support support = Support::kDouble;
  Eigen::Vector3d p_com = Eigen::Vector3d::Zero(), v_com = Eigen::Vector3d::Zero(), a_com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_base = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_base = Eigen::Vector3d::Zero(), omegadot_base = Eigen::Vector3d::Zero();
  std::array<FootReference, 2> feet;
  Eigen::VectorXd q_free, qd_free, qdd_free;  ///< free joints in RobotSpec::free_joints order
  bool settled = false;  ///< no transition under way
};

struct PostureReferenceConfig {
  Eigen::Vector2d com_offset = Eigen::Vector2d::Zero();  ///< CoM xy relative to the support centre, support frame [m]
  double com_height = 0.0;          ///< 0: the standing posture's CoM height above the soles
  Eigen::Vector2d base_tilt = Eigen::Vector2d::Zero();   ///< base roll, pitch [rad]
  double init_time = 1.0;           ///< blend from the measured state to the reference [s]
  double shift_time = 1.2;          ///< CoM shift and load transfer [s]
  double lift_time = 0.6;           ///< swing foot lift or set-down [s]
  double lift_height = 0.05;        ///< [m]
  double unloaded_fraction = 0.02;  ///< load limit of a foot about to lift
  Support support = Support::kDouble;  ///< support to reach after the start
  static PostureReferenceConfig load(const Config& balance_section);
};

class PostureReference {
 public:
  PostureReference(const model::RobotSpec& robot, PostureReferenceConfig config);

  /// Starts from the measured state (q in the model's coordinates, soles on the ground) at time t.
  void start(const Eigen::VectorXd& q, double t);
  /// Not started again until the next start() (for a clock that restarted).
  void reset() { started_ = false; }
  [[nodiscard]] bool started() const { return started_; }
  /// Requests a support mode from time t on (a transition follows).
  void request_support(Support s, double t);
  /// The reference at time t (t never decreasing).
  const TaskReference& update(double t);
  [[nodiscard]] const TaskReference& reference() const { return ref_; }
  [[nodiscard]] Support target_support() const { return target_; }

 private:
  enum class Stage { kInit, kHold, kShift, kLift, kLower, kShiftBack };
  void begin_stage(Stage s, double t);
  Eigen::Vector3d com_target(Support s) const;

  const model::RobotSpec* robot_;
  PostureReferenceConfig config_;
  TaskReference ref_;
  bool started_ = false;
  Stage stage_ = Stage::kInit;
  double stage_start_ = 0.0;
  Support current_ = Support::kDouble, target_ = Support::kDouble;
  int moving_foot_ = -1;
  // Stage start and end values.
  Eigen::Vector3d com0_ = Eigen::Vector3d::Zero(), com1_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R0_ = Eigen::Matrix3d::Identity(), R1_ = Eigen::Matrix3d::Identity();
  Eigen::VectorXd qf0_, qf1_;
  std::array<model::SE3, 2> ground_soles_;  ///< sole poses on the ground
  double com_height_ = 0.0;
};

/// Quintic blend s(τ) from 0 to 1 over [0, 1] with zero velocity and acceleration at both ends;
/// returns (s, ds/dτ, d²s/dτ²).
Eigen::Vector3d quintic(double tau);

}  // namespace hpr::balance
