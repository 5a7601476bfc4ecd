#pragma once
/// \file
/// The data that flows between the balance components, one struct per channel (README.md,
/// "The processes") that the controllers exchange among themselves (the robot boundary's SensorSample,
/// EstimatedState and JointCommand are in hpr/common/robot_io.hpp, the task reference in
/// task_reference.hpp). Plain data without LCM: hpr::msg converts each to and from its message,
/// once; the components (wbc, reference_gen, motion_opt) read and write these.
///
/// Frames: W world, V the virtual stance foot (support centre, yaw of the support; paper
/// section III-B), Com the centre of mass with world axes.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hpr/balance/task_reference.hpp"
#include "hpr/model/spatial.hpp"

namespace hpr::balance {

using model::Vector6d;

/// BALANCE_PLAN: the balance planner's plan of one tick, which motion_opt optimises around and the
/// wbc tracks, with what the planner decided.
struct BalancePlan {
  std::int64_t tick = 0;
  TaskReference reference;          ///< the task-space reference of the tick (its `stepping`: the capture point and the step)
  PlanStage stage = PlanStage::kInit;
  Eigen::Vector2d f_ext_W = Eigen::Vector2d::Zero();  ///< F̂: the horizontal external force resisted [N]
};

/// BALANCE_STATUS: the wbc's balance state of one tick (frame V).
struct BalanceStatus {
  std::int64_t tick = 0;
  double time = 0.0;  ///< [s] of the state the wbc stepped on
  Support support = Support::kDouble;
  Eigen::Vector3d p_WV = Eigen::Vector3d::Zero();  ///< virtual stance foot [m]
  double yaw_WV = 0.0;                             ///< [rad]
  Eigen::Vector3d tau_ankle_V = Eigen::Vector3d::Zero(),  ///< τ_v^ankle (19) [N m]
      tau_hip_V = Eigen::Vector3d::Zero(),                ///< τ_v^hip (19), (21) [N m]
      tau_V = Eigen::Vector3d::Zero(),                    ///< τ_v (18) [N m]
      tau_min_V = Eigen::Vector3d::Zero(),                ///< limits of τ_v from (22) [N m]
      tau_max_V = Eigen::Vector3d::Zero();
  Eigen::Vector2d cop_V = Eigen::Vector2d::Zero(), cop_measured_V = Eigen::Vector2d::Zero();  ///< [m]
  double f_vz = 0.0;                                                 ///< total normal force [N]
  Vector6d w_des = Vector6d::Zero(), w_achieved = Vector6d::Zero();  ///< CoM wrench (8) [N, N m]
  std::array<Vector6d, 2> contact_wrench_W{};  ///< per foot (right, left), world axes at the sole centre
  std::array<bool, 2> contact_active{};
  int qp_status = 0, qp_iterations = 0;
  double qp_solve_time_us = 0.0;
  bool qp_fallback = false;
  bool qp_exact = false;   ///< the desired CoM wrench was met exactly (else: least error)
  bool singular = false;
  bool saturated = false;  ///< a torque, velocity or position target was cut to the joint's limit
  double compute_time_us = 0.0;  ///< the whole wbc step
};

/// Phases of the CAM reference per axis (paper section III-C).
enum class Phase : std::int8_t { kIdle = 0, kGenerate = 1, kReduce = 2, kRecover = 3 };

/// CAM_REFERENCE: l_c^ref of one tick, in V (the generator's axes) and in W.
struct CamReference {
  std::int64_t tick = 0;
  double time = 0.0;  ///< [s]
  Eigen::Vector3d l_ref_V = Eigen::Vector3d::Zero(), ldot_ref_V = Eigen::Vector3d::Zero();  ///< [N m s], [N m]
  Eigen::Vector3d l_ref_W = Eigen::Vector3d::Zero(), ldot_ref_W = Eigen::Vector3d::Zero();
  double yaw_WV = 0;
  std::array<Phase, 3> phase{};
  std::array<std::array<double, 3>, 3> t_phase_start{};  ///< [axis][phase 1..3] [s], -1 not reached
  Eigen::Vector3d tau_thres_V = Eigen::Vector3d::Zero(), ldot_max_V = Eigen::Vector3d::Zero();  ///< (23), (27)
  bool stale = false, ramping = false;  ///< BALANCE_STATUS too old: held, then ramping to zero
  std::int64_t balance_tick = -1;       ///< tick of the BALANCE_STATUS used

  /// Some axis generates or reduces CAM (phases 1, 2): the motion optimiser weights the CAM task.
  [[nodiscard]] bool generating() const {
    for (Phase p : phase) {
      if (p == Phase::kGenerate || p == Phase::kReduce) return true;
    }
    return false;
  }
};

/// WHOLEBODY_COMMAND: the motion optimiser's task-space command with what it optimised.
struct WholebodyCommand {
  std::int64_t tick = 0;
  TaskReference command;  ///< full commanded task-space trajectory
  Eigen::Vector3d l_cmd = Eigen::Vector3d::Zero(), ldot_cmd = Eigen::Vector3d::Zero(),
                  l_ref = Eigen::Vector3d::Zero();  ///< world axes about the CoM
  std::vector<int> adjusted;                        ///< indices into the optimiser's coordinates
  std::vector<std::string> adjusted_name;           ///< their names (set with `adjusted`)
  Eigen::VectorXd xa_opt, xad_opt, xa_min, xa_max, xad_min, xad_max;  ///< per adjusted coordinate (offset form)
  std::vector<std::string> segment_names;
  std::vector<Eigen::Vector3d> segment_l;  ///< contribution of each segment to l_cmd (Fig. 7d)
  double posture_error = 0.0;
  int qp_status = 0, qp_iterations = 0;
  double qp_solve_time_us = 0.0;
  double cam_weight_scale = 1.0;  ///< the factor applied to Q_l this tick
  bool qp_failed = false, reference_stale = false, singular = false;
};

}  // namespace hpr::balance
