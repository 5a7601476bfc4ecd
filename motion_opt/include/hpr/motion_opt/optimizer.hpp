#pragma once
/// \file
/// CAM-based whole-body motion optimisation (paper section III-A).
///
/// The task velocity ẋ of (2) is split into adjusted DoF ẋ_a and unchanged DoF ẋ_u (10), (11), and
/// every tick the QP (13)
///     min ½ δ_lᵀ Q_l δ_l + ½ δ_pᵀ Q_p δ_p,
///     δ_l = Ā_a ẋ_a + Ā_u ẋ_u^ref − l_c^ref              (14a)
///     δ_p = ẋ_a − ẋ_a^d,  ẋ_a^d = ẋ_a^ref + K_p (x_a^ref − x_a^opt)   (14b), (16)
///     s.t. max(K_a (x_min − x_a^opt), ẋ_min) ≤ ẋ_a ≤ min(K_a (x_max − x_a^opt), ẋ_max)   (15), (17)
/// is solved, hot-started, with a cap on working-set changes. x_a^opt is integrated from ẋ_a^opt,
/// accelerations come from numerical differentiation, and the unchanged DoF follow the reference.
///
/// Adjusted coordinates are kept as offsets δ = x^opt − x^ref: the base orientation (a rotation
/// vector in world axes, R^opt = exp(δ) R^ref), free joints, and a swing foot's translation. A
/// coordinate that leaves the adjusted set keeps its offset and lets it decay with K_p, so changing
/// the set (double to single support and back) never makes the command jump. The swing foot is
/// adjusted only while the single support is settled (not while it is lifted or set down), so that
/// its offset has decayed when it touches the ground.

#include <array>
#include <map>
#include <string>
#include <vector>

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/parameters.hpp"
#include "hpr/model/centroidal.hpp"
#include "hpr/qp/qp_solver.hpp"

namespace hpr::motion_opt {

struct MotionOptConfig {
  std::vector<std::string> adjusted_double, adjusted_single;  ///< "base_rotation", "swing_foot", joint names
  Eigen::Vector3d Q_l{10.0, 10.0, 10.0};                      ///< CAM weight (14a)
  double Q_p = 0.1;                                            ///< posture weight (14b), default
  std::map<std::string, double> Q_p_overrides;                 ///< per coordinate name
  double cam_idle_fraction = 0.05;                             ///< Q_l scale while no CAM is generated (idle, phase 3)
  double cam_release_time = 0.5;                               ///< [s] smooth ramp of Q_l down to that fraction
  double K_p = 2.0;                                            ///< posture convergence [1/s] (16)
  double K_a = 10.0;                                           ///< limit approach gain [1/s] (17)
  Eigen::Vector3d base_min{-0.25, -0.35, -0.3}, base_max{0.25, 0.35, 0.3};  ///< base rotation offsets [rad]
  double base_velocity = 3.0;                                  ///< [rad/s]
  double joint_limit_margin = 0.05;                            ///< [rad] inside the URDF limits
  double joint_velocity_fraction = 0.8;                        ///< of the URDF velocity limits
  double swing_range = 0.15;                                   ///< swing foot offsets [m]
  double swing_clearance = 0.02;  ///< [m] the swing sole stays this far above the stance sole at least
  double swing_velocity = 1.0;                                 ///< [m/s]
  double swing_return_rate = 10.0;                             ///< [1/s] offset decay once the foot is not adjusted
  double acceleration_filter = 0.005;                          ///< [s] time constant of the differentiated acceleration
  int max_working_set_changes = 10;
  double dt = 1e-3;                                            ///< control period [s]
  static MotionOptConfig load(const Config& section, const model::RobotSpec& robot);
};

/// One optimisation coordinate (an entry of x_a or a coordinate that may become one).
struct Coordinate {
  enum class Kind { kBaseRotation, kFreeJoint, kFoot };
  Kind kind;
  int axis = 0;        ///< 0..2 for the base rotation and the foot translation
  int index = 0;       ///< free joint index (RobotSpec::free_joints order) or foot (0 right, 1 left)
  int task = 0;        ///< index in ẋ = (ν_c, ν_r, ν_l, q̇_f)
  std::string name;
};

/// WHOLEBODY_COMMAND: the command with what was optimised (`adjusted` indexes coordinates()).
using MotionOptOutput = balance::WholebodyCommand;

class MotionOptimizer {
 public:
  MotionOptimizer(const model::RobotSpec& robot, MotionOptConfig config);

  /// One tick: state (q, v) in the model's coordinates, the reference posture trajectory, and the
  /// CAM reference (world axes about the CoM; `l_ref_fresh` false treats it as zero). `cam_active`
  /// tells whether the generator is in phase 1 or 2 on some axis: otherwise (idle, phase 3, stale)
  /// the CAM weight ramps down to `cam_idle_fraction` of Q_l so that the posture converges at about
  /// K_p (with the full weight the momentum-producing directions of the return slow down to
  /// K_p Q_p / (Q_p + σ² Q_l), σ a singular value of Ā_a: several seconds). Phase 1 restores the
  /// full weight at once.
  const MotionOptOutput& step(const Eigen::VectorXd& q, const Eigen::VectorXd& v, const balance::TaskReference& ref,
                              const Eigen::Vector3d& l_ref, bool l_ref_fresh, double dt, bool cam_active = true);

  [[nodiscard]] const std::vector<Coordinate>& coordinates() const { return coords_; }
  [[nodiscard]] const MotionOptOutput& output() const { return out_; }
  [[nodiscard]] const model::TaskSpace& task_space() const { return task_; }
  [[nodiscard]] const MotionOptConfig& config() const { return config_; }
  /// The weights and gains, changeable between steps (every step reads them afresh). The adjusted
  /// sets and limits are not: they size the QP.
  [[nodiscard]] MotionOptConfig& tunable_config() { return config_; }
  /// Offsets δ of every coordinate.
  [[nodiscard]] const Eigen::VectorXd& offsets() const { return delta_; }
  /// Sets the offsets (a deflected posture, for tests and tools).
  void set_offsets(const Eigen::VectorXd& delta) { delta_ = delta; }
  /// Offsets and their rates back to zero, no active set kept (for a clock that restarted).
  void reset();
  /// The QP data of the last tick (for tests): H, g and the bounds over the adjusted coordinates.
  [[nodiscard]] const qp::Solver& solver() const { return *solver_; }

 private:
  /// The coordinates adjusted this tick (x_a of (10)), into `set`.
  void adjusted_set(const balance::TaskReference& ref, std::vector<int>& set) const;
  // The stages of step(), in order.
  /// x_a for the reference's support; a new set size gets its QP workspace.
  void select_adjusted(const balance::TaskReference& ref);
  /// ẋ^ref, and the offsets of the unadjusted coordinates decaying with K_p (feet faster).
  void decay_unadjusted(const balance::TaskReference& ref);
  /// H, g and the bounds of (13)-(17), with the CAM weight of the phase.
  void build_qp(const balance::TaskReference& ref, const Eigen::Vector3d& lref, double dt, bool cam_active);
  /// ẋ_a^opt, or the posture task within the limits when the QP fails.
  void solve_qp();
  /// δ̇, δ and the filtered δ̈ of every coordinate.
  void integrate_offsets(const balance::TaskReference& ref, double dt);
  /// The commanded trajectory (the reference with the offsets) and the commanded CAM.
  void compose_command(const balance::TaskReference& ref, double dt);
  void limits(int c, const balance::TaskReference& ref, double& dmin, double& dmax, double& vmax) const;

  const model::RobotSpec* robot_;
  MotionOptConfig config_;
  model::Data data_;
  model::TaskSpace task_;
  std::vector<Coordinate> coords_;
  std::vector<std::vector<int>> segment_coords_;
  Eigen::VectorXd delta_, delta_dot_, delta_dot_prev_, delta_acc_;
  Eigen::VectorXd xdot_ref_, xdot_cmd_;
  std::unique_ptr<qp::Solver> solver_;
  int solver_size_ = -1;
  std::vector<int> set_, last_set_;  ///< x_a this tick and the last
  std::vector<char> adjusted_;       ///< per coordinate: in set_
  Eigen::VectorXd xu_, xd_, xa_;     ///< ẋ_u (task order), ẋ_a^d (16), ẋ_a^opt
  Eigen::Matrix<double, 3, Eigen::Dynamic> Aa_;  ///< Ā_a
  Eigen::Vector3d l_cmd_prev_ = Eigen::Vector3d::Zero();
  std::array<bool, 2> contact_prev_{true, true};  ///< the feet's contacts of the last step
  bool first_ = true;
  double cam_scale_ = 1.0, release_progress_ = 1.0;
  MotionOptOutput out_;
  Eigen::MatrixXd H_, A_;
  Eigen::VectorXd g_, lb_, ub_, lbA_, ubA_;
};

/// Registers the live-tunable parameters (weights.cam (all axes, or .x/.y/.z), weights.posture, weights.cam_idle_fraction, weights.cam_release_time, gains.posture, gains.limits) under the keys of the
/// configuration section, with the ranges its loader accepts; the process that runs the component
/// (its own node, or the composed controllers) answers OPERATOR sets with them.
void add_parameters(ParameterSet& params, MotionOptConfig& c);

}  // namespace hpr::motion_opt
