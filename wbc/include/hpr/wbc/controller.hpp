#pragma once
/// \file
/// Passivity-based whole-body controller (paper section II-B, after Ott, Henze, Mesesan) with the
/// virtual stance foot decomposition of section III-B.
///
/// Per tick, in the paper's coordinates ν = (ẋ_c, ω_b, q̇) and task coordinates ẋ = (ν_c, ν_r, ν_l, q̇_f):
///   ν^cmd = J⁻¹ ẋ^cmd, ν̇^cmd = J⁻¹ ẍ^cmd                       (5) (J̇ ν^cmd neglected)
///   w_c^imp: CoM spring-damper and a rotational spring on SO(3) for the base   (6)
///   τ_f^imp: joint spring-dampers for the free joints                         (7)
///   (w_c^ff; τ^ff) = M̄ ν̇^cmd + C̄ ν^cmd (C̄ Christoffel-consistent; CoM rows m ẍ_c^cmd)  (20)
///   Adᵀ w_grf = w_c^ff − w_g − w_c^imp − Ad_swᵀ w_sw      (8), signs of (4) and (6)
///   τ = τ^ff − J'ᵀ w_feet − S_fᵀ τ_f^imp                   (9)
/// where w_feet holds the distributed contact wrenches and, for a swing foot, its Cartesian
/// impedance wrench w_sw. Virtual stance foot: τ_v = τ_v^hip + τ_v^ankle (18), (19), (21) about the
/// support centre, with its CoP limits (22).

#include <array>

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/parameters.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/centroidal.hpp"
#include "hpr/wbc/contact_qp.hpp"

namespace hpr::wbc {

using model::Vector6d;

struct WbcConfig {
  Eigen::Vector3d K_com{1500, 1500, 3000}, D_com{400, 400, 600};  ///< [N/m], [N s/m]
  Eigen::Vector3d K_base{600, 600, 300}, D_base{60, 60, 30};      ///< [N m/rad], [N m s/rad]
  Eigen::VectorXd K_free, D_free;                                  ///< per free joint
  Vector6d K_swing = (Vector6d() << 2000, 2000, 2000, 200, 200, 200).finished();
  Vector6d D_swing = (Vector6d() << 80, 80, 80, 8, 8, 8).finished();
  ContactParams contact;
  bool impedance_at_drive = true;   ///< evaluate (7) in the drives (kp, kd, q_des) at their rate
  double joint_damping = 0.0;       ///< extra drive damping on every joint [N m s/rad]
  double tau_z_limit = 20.0;        ///< |τ_v,z| bound of the virtual stance foot [N m]
  double max_torque_fraction = 1.0; ///< torques are clamped to this fraction of the effort limits
  double drive_period = 1e-3;       ///< [s] period at which the drives evaluate (7)
  double control_period = 1e-3;     ///< [s] period at which the controller evaluates the swing foot impedance

  /// Reads the `wbc` section; free-joint gains per joint name with a default.
  static WbcConfig load(const Config& wbc_section, const model::RobotSpec& robot);
};

/// `c` with the free joints' impedance (default 300 N m/rad, 30 N m s/rad when empty) and the swing
/// foot's capped for explicit evaluation at their periods: a spring-damper evaluated every h is
/// stable only for kp ≤ 0.2 I/h², kd ≤ 0.5 I/h, with I the inertia the joint (1/(M⁻¹)_jj) or the
/// foot (1/(J M⁻¹ Jᵀ)_ii) meets in the standing posture. The controller applies it to whatever
/// configuration it is given, loaded or built in code.
WbcConfig cap_impedances(WbcConfig c, const model::RobotSpec& robot);

/// The controller's view of the robot: the model's coordinates (base pose, joint positions; base
/// twist in the base frame, joint velocities).
struct RobotState {
  double time = 0.0;
  std::int64_t tick = 0;
  Eigen::VectorXd q, v;
};

/// What goes out on BALANCE_STATUS (frame V: the virtual stance foot, yaw of the support).
using BalanceStatus = balance::BalanceStatus;

class WholeBodyController {
 public:
  WholeBodyController(const model::RobotSpec& robot, WbcConfig config);

  /// One control step towards the commanded task-space trajectory `cmd`. Returns the joint command;
  /// status() describes the step. A non-finite result yields a damping command.
  const JointCommand& step(const RobotState& state, const balance::TaskReference& cmd);

  [[nodiscard]] const BalanceStatus& status() const { return status_; }
  [[nodiscard]] const JointCommand& command() const { return command_; }
  [[nodiscard]] const WbcConfig& config() const { return config_; }
  /// The impedance gains and the extra joint damping, changeable between steps (every step reads
  /// them afresh). The free-joint and swing-foot gains are not: they are capped for their periods at construction (cap_impedances).
  [[nodiscard]] WbcConfig& tunable_config() { return config_; }
  /// μ of the contact wrench distribution, from the next step.
  void set_contact_friction(double mu) {
    config_.contact.friction = mu;
    qp_.set_friction(mu);
  }
  [[nodiscard]] const model::RobotSpec& robot() const { return *robot_; }

  // Intermediate quantities of the last step (for tests, logs and tools).
  [[nodiscard]] const model::TaskSpace& task_space() const { return task_; }
  [[nodiscard]] const model::Data& data() const { return data_; }
  [[nodiscard]] const Eigen::VectorXd& nu_cmd() const { return nu_cmd_; }
  [[nodiscard]] const Eigen::VectorXd& nudot_cmd() const { return nudot_cmd_; }
  [[nodiscard]] const Eigen::VectorXd& feedforward() const { return y_; }     ///< M̄ ν̇^cmd + C̄ ν^cmd
  [[nodiscard]] const Vector6d& w_imp() const { return w_imp_; }
  [[nodiscard]] const Eigen::VectorXd& tau_free_imp() const { return tau_f_imp_; }
  [[nodiscard]] const std::array<Vector6d, 2>& foot_wrenches() const { return w_feet_; }  ///< w_grf or w_sw
  /// The full joint torque of (9), including the free-joint impedance whether the drives evaluate it or not.
  [[nodiscard]] const Eigen::VectorXd& tau_total() const { return tau_total_; }

 private:
  // The stages of step, in order.
  /// ν^cmd and ν̇^cmd from the task velocities and accelerations.
  void command_velocities(const balance::TaskReference& cmd);
  /// w_imp (6), τ_f^imp (7) and the swing feet's Cartesian impedance wrenches.
  void impedances(const RobotState& state, const balance::TaskReference& cmd);
  /// The contact wrenches for w_des (the last valid ones while the QP has none); w_feet.
  void distribute(const balance::TaskReference& cmd, const Vector6d& w_des);
  /// The joint command from τ (9), within the joints' limits, never a non-finite number.
  void joint_command(const RobotState& state, const balance::TaskReference& cmd);
  void virtual_stance_foot(const balance::TaskReference& cmd, const Vector6d& w_ff, const Vector6d& w_rest);

  const model::RobotSpec* robot_;
  WbcConfig config_;
  model::Data data_;
  model::TaskSpace task_;
  ContactQp qp_;
  JointCommand command_;
  BalanceStatus status_;
  Eigen::VectorXd xdot_cmd_, xddot_cmd_, nu_cmd_, nudot_cmd_, y_, tau_f_imp_, tau_total_, w_task_, jt_;
  Vector6d w_imp_ = Vector6d::Zero();
  std::array<Vector6d, 2> w_feet_{}, last_valid_grf_{}, w_swing_{};
  bool have_valid_grf_ = false;
};

/// Registers the live-tunable parameters (com.stiffness, com.damping, base.stiffness, base.damping (.x/.y/.z), joint_damping, contact.friction) under the keys of the
/// configuration section, with the ranges its loader accepts; the process that runs the component
/// (its own node, or the composed controllers) answers OPERATOR sets with them.
void add_parameters(ParameterSet& params, WholeBodyController& wbc);

}  // namespace hpr::wbc
