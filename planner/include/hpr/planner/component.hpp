#pragma once
/// \file
/// The balance planner's tick as the stack runs it (README.md, "The processes"): the task-space
/// reference of every coordinate of (2) that motion_opt optimises around and the wbc tracks. It
/// plays the paper's high-level planner: it holds the posture (ramped in from the first usable
/// estimate), shifts the support on request, and with the configuration's `balance.stepping` and
/// `balance.push_compensation` it watches the external force and the capture point, steps, swings
/// and lands (balance::PostureReference). Stepped once per tick, before the components that read
/// its plan. No LCM, no allocation per tick.

#include <Eigen/Core>
#include <array>
#include <string_view>

#include "hpr/balance/ports.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::planner {

class BalancePlanner {
 public:
  /// The component's tick (hpr/common/component.hpp). No faults of its own; not ready, with no
  /// plan, while no usable estimate has started the posture.
  static constexpr std::array<std::string_view, 0> kFaultKeys{};
  /// The planner process's ports.
  static constexpr Read kReads[] = {
      {channel::kRobotState, 0, true, false, "the state it plans from"},
      {channel::kOperator, 0, false, true, "support requests"}};
  static constexpr std::string_view kWrites[] = {channel::kBalancePlan};
  static constexpr Ports kPorts{"planner", kReads, kWrites};
  struct Inputs {
    const EstimatedState& state;  ///< ROBOT_STATE of tick k (an unusable one: the plan goes on without it)
  };
  struct Outputs {
    balance::BalancePlan plan;  ///< BALANCE_PLAN of tick k (when `valid`)
    bool valid = false;         ///< a usable estimate has started the posture
    StepReport report{kFaultKeys};
    /// The task-space reference for the components that follow the plan; empty without one.
    [[nodiscard]] OptionalRef<balance::TaskReference> reference() const {
      return OptionalRef<balance::TaskReference>::when(valid, plan.reference);
    }
  };

  BalancePlanner(const model::RobotSpec& robot, balance::PostureReferenceConfig config);

  void step(const Inputs& in, Outputs& out);
  /// Whether step() with state `s` makes a plan: the posture has started, or `s` can start it.
  [[nodiscard]] bool will_plan(const EstimatedState& s) const { return reference_.started() || s.usable(); }
  /// A support mode requested by the operator, from time t on.
  void request_support(balance::Support s, double t) { reference_.request_support(s, t); }
  /// The posture starts again from the next usable estimate (a clock that restarted).
  void reset() { reference_.reset(); }

  [[nodiscard]] const balance::PostureReference& posture_reference() const { return reference_; }

 private:
  balance::PostureReference reference_;
};

static_assert(Component<BalancePlanner>);

}  // namespace hpr::planner
