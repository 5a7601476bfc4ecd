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
#include <optional>

#include "hpr/balance/force_observer.hpp"
#include "hpr/balance/stepping.hpp"
#include "hpr/balance/trajectories.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::balance {

enum class Support : std::int8_t { kDouble = 0, kLeft = 1, kRight = 2 };
const char* to_string(Support s);
Support support_from_string(const std::string& s);

/// What the balance plan is doing (PostureReference's stages, BALANCE_PLAN.stage): ramping in from
/// the measured posture, holding, a support change (shift the CoM, lift or lower a foot, shift
/// back), or a step (unload, swing, settle on the new support, recover the posture).
enum class PlanStage : std::int8_t {
  kInit = 0, kHold, kShift, kLift, kLower, kShiftBack, kStepUnload, kStepSwing, kStepSettle, kStepRecover
};
inline constexpr int kPlanStages = 10;
/// "init", "hold", "shift", "lift", "lower", "shift back", "step unload", "step swing",
/// "step settle", "step recover".
const char* to_string(PlanStage s);

struct FootReference {
  model::SE3 X_WS;                                            ///< sole pose
  Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Zero();  ///< (v, ω) world, at the sole
  Eigen::Matrix<double, 6, 1> accel = Eigen::Matrix<double, 6, 1>::Zero();
  bool contact = true;        ///< the foot carries load (else it is a swing foot under impedance)
  double load_limit = 1.0;    ///< fraction of the maximum normal force it may carry, for load transfer
};

/// What the stepping strategy watches and plans, for display and logs (the wbc does not use it).
struct StepStatus {
  bool enabled = false;           ///< balance.stepping.enabled: the fields below are computed
  /// The capture point the decision watches [m]: ξ = c + ċ/ω, shifted by the external force the
  /// robot resists, push_shift(F̂, m, ω, r t) after t seconds of it (r = step.push_duration_ratio;
  /// F̂ / (m ω²), the CMP that would hold it, as r t grows), until a step's touchdown.
  Eigen::Vector2d xi_W = Eigen::Vector2d::Zero();
  double excess = 0.0;            ///< [m] how far xi_W lies beyond what the ankle and hip strategies
                                  ///< hold (StepPlanner::excess; > 0: a step is due)
  int swing = -1;                 ///< the stepping foot (model::kRight, model::kLeft), −1: no step under way
  Eigen::Vector2d target_W = Eigen::Vector2d::Zero();  ///< landing sole centre [m] of the step under way
  double target_yaw = 0.0;        ///< [rad] its yaw
  double time_left = 0.0;         ///< [s] to the planned touchdown
  int steps_taken = 0;            ///< since start
  int follow_steps = 0;           ///< of those, a trailing foot that carried almost nothing closing up
                                  ///< (steps_taken − follow_steps: the steps the capture point asked for)
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
  StepStatus stepping;
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
  SteppingConfig stepping;          ///< section `stepping`: the third strategy, off unless enabled
  /// Section `push_compensation`: standing settled, the CoM reference's acceleration is −F̂ / m,
  /// F̂ the horizontal external force of the momentum observer, so that the CoM wrench the wbc asks
  /// the contacts for cancels the push instead of the CoM impedance's deflection (under a steady
  /// force F at height h the CoP then sits F h / (m g) ahead of the CoM, not F / K_com further).
  struct PushCompensation {
    bool enabled = false;
    double filter = 0.1;       ///< [s] time constant of a low-pass on F̂ (the observer's own is stepping.force_filter)
    double max_force = 150.0;  ///< [N] the compensated force is clamped to this magnitude
  } push_compensation;
  /// How a step is carried out (section `stepping` too).
  struct StepExecution {
    double unload_time = 0.05;        ///< [s] of the step's duration spent unloading the swing foot before lift-off
    double swing_height = 0.05;       ///< [m] the swing sole's highest point above the ground
    double replan_fraction = 0.8;     ///< the landing is replanned each tick until this fraction of the swing
    double replan_min_time = 0.15;    ///< [s] and while at least this much of the swing remains (a landing moved
                                      ///< late asks the swing foot for accelerations it cannot make)
    double touchdown_depth = 0.02;    ///< [m] the swing reference ends this far below the ground
    double touchdown_height = 0.015;  ///< [m] a swing sole reported loaded is down once its kinematics put it this
                                      ///< close to the ground (a sensor also reads the swing's own inertia)
    double transfer_time = 0.15;      ///< [s] after touchdown the CMP moves from the stance foot to where
                                      ///< the DCM regulation wants it
    double com_drop = 0.04;           ///< [m] the CoM sinks this much while stepping (the legs reach further)
    /// [m] the same when the first step goes backwards (a push from the front, which goes on
    /// pushing the robot onto a stance knee the drop bends further)
    double com_drop_backward = 0.04;
    double drop_time = 0.3;           ///< [s] over this time from the first step
    double follow_load = 0.1;         ///< after a step, the trailing foot steps too when its share of the
                                      ///< weight stays below this
    double follow_delay = 0.08;       ///< [s] for this long
    double follow_reach = 0.01;       ///< [m] and the capture point lies within this of the landed sole (a
                                      ///< DCM still crossing towards it is no rest over it)
    double target_rate = 2.0;         ///< [m/s] fastest change of the landing while it is replanned
    double force_filter = 0.04;       ///< [s] time constant of the external-force estimate
    /// [N] |F̂| above which a push counts as under way (below, it shifts no capture point)
    double push_onset = 10.0;
    /// A push under way is expected to last this many times as long again as it has so far: the
    /// capture point is shifted by push_shift(F̂, m, ω, push_duration_ratio · elapsed), not by the
    /// F̂ / (m ω²) of a force that lasts for good (a sharp push of 130 N shifted it 15.6 cm)
    double push_duration_ratio = 2.0;
    double cop_margin = 0.02;         ///< [m] the CMP of a step stays this far inside the soles
    double settle_gain = 3.0;         ///< [1/s] after touchdown, the rate at which ξ is driven to the support's centre
    double settle_time = 1.5;         ///< [s] longest DCM settling after touchdown
    double recover_time = 0.8;        ///< [s] then the CoM blends to rest at the support's centre
    double landing_load_time = 0.03;  ///< [s] the landed foot's load limit ramps to full
  } step;
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
  /// The reference at time t (t never decreasing). With the estimated `state` (its CoM, velocity
  /// and contacts) and stepping enabled, standing in double support, it steps when the capture
  /// point leaves what the ankle and hip strategies can hold (StepPlanner), and keeps stepping until
  /// it is back inside.
  const TaskReference& update(double t, const EstimatedState* state = nullptr);
  [[nodiscard]] const TaskReference& reference() const { return ref_; }
  [[nodiscard]] Support target_support() const { return target_; }
  /// The horizontal external force F̂ the robot is resisting (a momentum observer, stepping or
  /// push compensation enabled only); the capture point, the step under way and the steps taken
  /// are the reference's `stepping` (StepStatus).
  [[nodiscard]] const Eigen::Vector2d& external_force() const { return observer_.force(); }
  /// What the reference is doing.
  [[nodiscard]] PlanStage stage() const { return stage_; }
  [[nodiscard]] const char* stage_name() const { return to_string(stage_); }

 private:
  using Stage = PlanStage;
  void begin_stage(Stage s, double t);
  // The steps of update, in order: what the estimate says (stepping_stages.cpp), the stage's
  // references, the stepping status.
  void observe(double t, const EstimatedState& state);
  bool blend_com(double elapsed, double duration);  ///< the CoM from com0_ to com1_; true at the end
  void stage_init(double t, double elapsed);
  void stage_hold(const EstimatedState* state);
  void stage_shift(double t, double elapsed);
  void stage_lift_or_lower(double t, double elapsed);
  void stage_shift_back(double t, double elapsed);
  void stage_step_unload(double t, double elapsed, const EstimatedState* state);
  void stage_step_swing(double t, const EstimatedState* state);
  void stage_step_settle(double t, double elapsed, const EstimatedState* state);
  void stage_step_recover(double t, double elapsed);
  void report_stepping(double t);
  /// The momentum observer's F̂ from the estimated state at time t, and its low-passed, clamped
  /// copy for push_compensation.
  void observe_external_force(double t, const EstimatedState& state);
  Eigen::Vector3d com_target(Support s) const;
  std::array<Sole, 2> soles() const;
  /// Starts a step from the estimated state when the capture point asks for one.
  void check_step(double t, const EstimatedState& state);
  void begin_step(double t);
  /// The CoM reference of a step: the measured CoM moving as the LIP does with the CMP at p.
  void follow_lip(const EstimatedState& state, const Eigen::Vector2d& p);
  /// After touchdown: the CMP that drives the measured DCM to the support's centre at settle_gain,
  /// within the support; true once the DCM is there and the CoM at rest.
  bool settle_dcm(const EstimatedState& state);
  /// The CoM blends from where it is, at its velocity, to rest at the support's centre.
  void begin_recover(double t, const EstimatedState* state);
  /// The load limits of both feet ramp to full over landing_load_time after a touchdown.
  void ramp_landing_load(double since_touchdown);
  void update_swing(double t, const EstimatedState* state);
  /// A sole's placement by the kinematics of the estimated state (its ground pose when the state
  /// has no configuration).
  model::SE3 measured_sole(const EstimatedState& state, int foot);
  void land(double t, const EstimatedState* state);

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
  // Stepping.
  StepPlanner planner_;
  StepPlan step_;
  ExternalForceObserver observer_;  ///< F̂ (stepping or push_compensation enabled)
  Eigen::Vector2d xi_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d lean_ = Eigen::Vector2d::Zero();  ///< horizontal part of the base's z axis less the standing one's (world)
  double excess_ = -1.0;
  Eigen::Vector2d p_hold_ = Eigen::Vector2d::Zero();  ///< the CMP the CoM reference last followed
  int last_swing_ = -1;     ///< the foot that stepped last (the next step is the other's)
  bool stepped_ = false;    ///< a step landed and the robot has not come to rest since
  double land_time_ = 0.0;  ///< the last touchdown
  double drop_start_ = 0.0, drop_z0_ = 0.0;  ///< when the CoM started to sink, from which height
  double drop_ = 0.0;                          ///< [m] by how much (com_drop or com_drop_backward)
  double unloaded_since_ = -1.0;  ///< since when the trailing foot carries less than follow_load (−1: it does not)
  double omega_ = 0.0, step_start_ = 0.0, swing_start_ = 0.0, swing_time_ = 0.0, last_t_ = 0.0;
  Eigen::Vector3d swing_p_ = Eigen::Vector3d::Zero(), swing_v_ = Eigen::Vector3d::Zero(), swing_a_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d com_v0_ = Eigen::Vector3d::Zero();  ///< CoM velocity the recovery blend starts from
  model::Matrix3d swing_R0_ = model::Matrix3d::Identity();  ///< the swing sole's orientation at lift-off
  double swing_z0_ = 0.0;  ///< its height above the ground then [m]
  std::optional<model::Data> fk_;  ///< kinematics workspace (the sole at lift-off)
  int steps_taken_ = 0, follow_steps_ = 0;
};

}  // namespace hpr::balance
