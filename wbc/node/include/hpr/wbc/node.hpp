#pragma once
/// \file The wbc process: WholeBodyController behind LCM (library hpr::wbc_node, shared with the
/// composed controllers for the OPERATOR requests).
///
/// Steps on every ROBOT_STATE (from the estimator, or in a simulated group from truth_state) with
/// the BALANCE_PLAN of the same tick, towards the WHOLEBODY_COMMAND of the same tick when motion_opt
/// runs (waiting for both up to a timeout), else towards the balance plan itself. Publishes
/// JOINT_COMMAND and BALANCE_STATUS every tick; damps while it has no plan.

#include <humanoid/balance_plan_t.hpp>
#include <humanoid/balance_status_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include "hpr/msg/commands.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/msg/balance.hpp"
#include "hpr/msg/plan.hpp"
#include "hpr/wbc/component.hpp"

#include <optional>

namespace hpr::wbc {

struct WbcNodeOptions {
  bool wait_for_wholebody = true;    ///< step only with the WHOLEBODY_COMMAND of the same tick
  double wholebody_timeout = 0.5;    ///< [s] wall time to wait for it
  int wholebody_stale_ticks = 50;    ///< older commands are ignored (the balance plan)
  int plan_stale_ticks = 20;         ///< older plans are ignored (damps)
  int bad_state_ticks = 20;          ///< damp after this many ticks of a state flagged stale, implausible or diverged
  static WbcNodeOptions load(const Config& wbc_section);
};

/// What an OPERATOR message asks of the wbc: damp and stop damp it, enable ends the damping (each
/// logged when it changes something). Returns the support mode a COMMAND_SET_SUPPORT requests (the
/// caller passes it on to the planner), nothing otherwise.
std::optional<balance::Support> apply_operator(WbcComponent& wbc, const humanoid::operator_t& m);

class WbcNode {
 public:
  WbcNode(node::Runtime& rt, const model::RobotSpec& robot, WbcComponent& wbc, WbcNodeOptions options);

 private:
  void step(const EstimatedState& state, bool planned, bool wholebody_fresh);
  void publish();
  /// Whether the planner plans this tick: it has, or the state can start it.
  [[nodiscard]] bool will_plan() const { return have_plan_ || state_.usable(); }

  node::Runtime& rt_;
  WbcComponent& wbc_;
  balance::BalancePlan plan_;
  WbcComponent::Outputs out_;
  WbcNodeOptions options_;
  msg::RobotNames names_;
  std::vector<std::string> free_names_;
  node::Input<humanoid::robot_state_t>* state_in_ = nullptr;
  node::Input<humanoid::balance_plan_t>* plan_in_ = nullptr;
  node::Input<humanoid::wholebody_command_t>* wholebody_in_ = nullptr;
  node::Output<humanoid::joint_command_t> command_out_;
  node::Output<humanoid::balance_status_t> status_out_;
  EstimatedState state_;
  balance::WholebodyCommand wholebody_;
  humanoid::joint_command_t command_msg_;
  humanoid::balance_status_t status_msg_;
  bool have_wholebody_ = false;
  bool have_plan_ = false;  ///< a BALANCE_PLAN since the state's clock started
};

}  // namespace hpr::wbc
