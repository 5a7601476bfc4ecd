#pragma once
/// \file
/// The wbc's tick as the stack runs it, whatever carries the data (a process behind LCM, or the
/// in-process pipeline): towards the motion optimiser's command of the tick when there is one,
/// else the balance planner's plan itself (the ankle strategy); a damping command while there is
/// no plan yet, while the operator asks for it, or once the estimate has been unusable for
/// `bad_state_ticks` ticks. No LCM, no allocation per tick.

#include <chrono>
#include <array>
#include <cstdint>
#include <string_view>

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/wbc/controller.hpp"

namespace hpr::wbc {

class WbcComponent {
 public:
  /// The component's tick (hpr/common/component.hpp). Faults: "damping" (why the tick damps),
  /// "contact_qp" (the contact QP failed: the last valid wrenches kept), "singular" (the task
  /// Jacobian singular: the last valid inverse kept) and "wholebody" (the motion optimiser's
  /// command, seen before, missing this tick: the balance plan); not ready while there is no
  /// plan (BALANCE_PLAN) yet, damping while it damps (a plan lost included).
  static constexpr std::array<std::string_view, 4> kFaultKeys{"damping", "contact_qp", "singular", "wholebody"};
  /// The wbc process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotState, 0, true, false, "the state it controls"},
      {channel::kBalancePlan, 0, false, false, "the balance plan (without it: damps)"},
      {channel::kWholebodyCommand, 0, false, true, "the task-space command (without it: the balance plan)"},
      {channel::kOperator, 0, false, true, "enable, damp, stop"}};
  static constexpr std::string_view kWrites[] = {channel::kJointCommand, channel::kBalanceStatus};
  static constexpr Ports kPorts{"wbc", kReads, kWrites};
  struct Inputs {
    const EstimatedState& state;                    ///< ROBOT_STATE of tick k
    OptionalRef<balance::TaskReference> plan;       ///< BALANCE_PLAN of tick k; empty: none yet, or stale (damps)
    OptionalRef<balance::TaskReference> wholebody;  ///< WHOLEBODY_COMMAND of tick k; empty: the plan
  };
  /// What the tick did.
  enum class Mode : std::int8_t {
    kBalance,       ///< balancing: `command` and `status` are the controller's
    kDampNoState,   ///< no plan yet (no usable estimate has started the posture)
    kDampOperator,  ///< the operator asked for damping (or stop)
    kDampBadState,  ///< the estimate has been unusable for bad_state_ticks ticks
  };
  struct Outputs {
    JointCommand command;            ///< JOINT_COMMAND of tick k
    balance::BalanceStatus status;   ///< BALANCE_STATUS of tick k (mode kBalance only)
    Mode mode = Mode::kDampNoState;
    StepReport report{kFaultKeys};
  };

  /// `bad_state_ticks`: consecutive unusable estimates tolerated (one refused sample keeps the
  /// previous estimate) before the robot goes limp.
  WbcComponent(const model::RobotSpec& robot, WbcConfig config, int bad_state_ticks = 20);

  /// One tick.
  void step(const Inputs& in, Outputs& out);
  /// The mode step() takes with state `s` and a plan (`planned`) or none: no plan, the
  /// operator's damp, `s` unusable for bad_state_ticks in a row, else balancing.
  [[nodiscard]] Mode mode_for(const EstimatedState& s, bool planned) const;
  /// Whether step() with state `s` balances, and so follows the plan and the motion optimiser's
  /// command of the tick. A node waits for BALANCE_PLAN and WHOLEBODY_COMMAND exactly then, so that
  /// the processes step on the same inputs as the composed pipeline.
  [[nodiscard]] bool balances(const EstimatedState& s, bool planned) const {
    return mode_for(s, planned) == Mode::kBalance;
  }
  /// A damping command for `tick` (every joint: zero torque, damping gain kDampGain) without
  /// stepping, for a tick whose inputs are unusable.
  void damp(const EstimatedState& s, Mode why, Outputs& out) const;
  static constexpr double kDampGain = 5.0;  ///< [N m s/rad]

  /// Operator damp (true) until enable (false).
  void set_damping(bool on) { damping_ = on; }
  [[nodiscard]] bool damping() const { return damping_; }
  /// Forgets the count of unusable estimates (a clock that restarted); an operator damp stays.
  void reset();

  [[nodiscard]] int bad_state_count() const { return bad_state_count_; }
  [[nodiscard]] WholeBodyController& controller() { return wbc_; }
  [[nodiscard]] const WholeBodyController& controller() const { return wbc_; }

 private:
  WholeBodyController wbc_;
  int bad_state_ticks_;
  RobotState robot_state_;  ///< the controller's input, kept between ticks
  JointCommand damp_;       ///< the damping command, sized once
  bool damping_ = false;
  int bad_state_count_ = 0;
  bool had_wholebody_ = false;  ///< a command of the motion optimiser came since the start
  bool had_plan_ = false;       ///< a plan came since the start (without one now: lost, damping)

  void report(const EstimatedState& s, const Inputs& in, Outputs& out) const;
};

}  // namespace hpr::wbc
