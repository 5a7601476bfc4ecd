#pragma once
/// \file
/// The wbc's tick as the stack runs it, whatever carries the data (a process behind LCM, or the
/// in-process pipeline): the held posture started from the first usable estimate, towards the
/// motion optimiser's command of the tick when there is one (else the own posture reference: the
/// ankle strategy), a damping command while the operator asks for it or the estimate has been
/// unusable for `bad_state_ticks` ticks. No LCM, no allocation per tick.

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
  /// command, seen before, missing this tick: its own posture reference); not ready while no
  /// estimate has started the posture, damping while it damps.
  static constexpr std::array<std::string_view, 4> kFaultKeys{"damping", "contact_qp", "singular", "wholebody"};
  /// The wbc process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotState, 0, true, false, "the state it controls"},
      {channel::kWholebodyCommand, 0, false, true, "the task-space command (without it: its own posture reference)"},
      {channel::kOperator, 0, false, true, "enable, damp, stop, support requests"}};
  static constexpr std::string_view kWrites[] = {channel::kJointCommand, channel::kBalanceStatus};
  static constexpr Ports kPorts{"wbc", kReads, kWrites};
  struct Inputs {
    const EstimatedState& state;                    ///< ROBOT_STATE of tick k
    OptionalRef<balance::TaskReference> wholebody;  ///< WHOLEBODY_COMMAND of tick k; empty: own posture
  };
  /// What the tick did.
  enum class Mode : std::int8_t {
    kBalance,       ///< balancing: `command` and `status` are the controller's
    kDampNoState,   ///< no usable estimate yet to start the posture from
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
  WbcComponent(const model::RobotSpec& robot, WbcConfig config, balance::PostureReferenceConfig posture,
               int bad_state_ticks = 20);

  /// One tick.
  void step(const Inputs& in, Outputs& out);
  /// The mode step() takes with state `s`: no posture started and `s` cannot start it, the
  /// operator's damp, `s` unusable for bad_state_ticks in a row, else balancing.
  [[nodiscard]] Mode mode_for(const EstimatedState& s) const;
  /// Whether step() with state `s` uses the motion optimiser's command (it balances). A node waits
  /// for WHOLEBODY_COMMAND exactly then, so that the processes step on the same inputs as the
  /// composed pipeline.
  [[nodiscard]] bool uses_wholebody(const EstimatedState& s) const { return mode_for(s) == Mode::kBalance; }
  /// A damping command for `tick` (every joint: zero torque, damping gain kDampGain) without
  /// stepping, for a tick whose inputs are unusable.
  void damp(const EstimatedState& s, Mode why, Outputs& out) const;
  static constexpr double kDampGain = 5.0;  ///< [N m s/rad]

  /// Operator damp (true) until enable (false).
  void set_damping(bool on) { damping_ = on; }
  [[nodiscard]] bool damping() const { return damping_; }
  /// A support mode requested by the operator, from time t on.
  void request_support(balance::Support s, double t) { reference_.request_support(s, t); }
  /// The posture starts again from the next usable estimate (a clock that restarted); an operator
  /// damp stays.
  void reset();

  [[nodiscard]] int bad_state_count() const { return bad_state_count_; }
  [[nodiscard]] WholeBodyController& controller() { return wbc_; }
  [[nodiscard]] const WholeBodyController& controller() const { return wbc_; }
  [[nodiscard]] const balance::PostureReference& posture_reference() const { return reference_; }

 private:
  WholeBodyController wbc_;
  balance::PostureReference reference_;
  int bad_state_ticks_;
  RobotState robot_state_;  ///< the controller's input, kept between ticks
  JointCommand damp_;       ///< the damping command, sized once
  bool damping_ = false;
  int bad_state_count_ = 0;
  bool had_wholebody_ = false;  ///< a command of the motion optimiser came since the start

  void report(const EstimatedState& s, const Inputs& in, Outputs& out) const;
};

}  // namespace hpr::wbc
