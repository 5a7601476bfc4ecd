#pragma once
/// \file
/// Every channel of the stack with the message type it carries (names: hpr/common/ports.hpp;
/// contracts in lcmtypes/*.lcm; who reads and writes which: hpr/graph/data_flow.hpp).

#include <humanoid/balance_plan_t.hpp>
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/hal_status_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>
#include <humanoid/push_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <humanoid/supervisor_status_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <string_view>
#include <tuple>

#include "hpr/common/channel.hpp"
#include "hpr/common/ports.hpp"

namespace hpr::msg::channels {

// The control chain, one message per tick.
inline constexpr Channel<humanoid::robot_sensors_t> kRobotSensors{channel::kRobotSensors};
inline constexpr Channel<humanoid::robot_state_t> kRobotState{channel::kRobotState};
inline constexpr Channel<humanoid::balance_plan_t> kBalancePlan{channel::kBalancePlan};
inline constexpr Channel<humanoid::cam_reference_t> kCamReference{channel::kCamReference};
inline constexpr Channel<humanoid::wholebody_command_t> kWholebodyCommand{channel::kWholebodyCommand};
inline constexpr Channel<humanoid::joint_command_t> kJointCommand{channel::kJointCommand};
inline constexpr Channel<humanoid::balance_status_t> kBalanceStatus{channel::kBalanceStatus};
// The backends' own.
inline constexpr Channel<humanoid::sim_truth_t> kSimTruth{channel::kSimTruth};
inline constexpr Channel<humanoid::hal_status_t> kHalStatus{channel::kHalStatus};
inline constexpr Channel<humanoid::push_t> kPush{channel::kPush};
// Commands and reports.
inline constexpr Channel<humanoid::operator_t> kOperator{channel::kOperator};
inline constexpr Channel<humanoid::health_t> kHealth{channel::kHealth};
inline constexpr Channel<humanoid::params_t> kParams{channel::kParams};
inline constexpr Channel<humanoid::supervisor_command_t> kSupervisorCommand{channel::kSupervisorCommand};
inline constexpr Channel<humanoid::supervisor_status_t> kSupervisorStatus{channel::kSupervisorStatus};

/// Every channel above.
inline constexpr std::tuple kAll{kRobotSensors, kRobotState, kBalancePlan, kCamReference,      kWholebodyCommand,
                                 kJointCommand, kBalanceStatus, kSimTruth,   kHalStatus,    kPush,
                                 kOperator,     kHealth,        kParams,     kSupervisorCommand, kSupervisorStatus};

/// Whether `logged` is the channel `name` on LCM, under any prefix a runtime may add ("A/", "X_",
/// "x."): the name itself or the name after a '/', '_' or '.'. No channel's name is the end of
/// another's after such a separator.
constexpr bool names(std::string_view logged, std::string_view name) {
  if (logged.size() < name.size() || logged.substr(logged.size() - name.size()) != name) return false;
  if (logged.size() == name.size()) return true;
  const char sep = logged[logged.size() - name.size() - 1];
  return sep == '/' || sep == '_' || sep == '.';
}

/// Calls `f(channel)` with the stack's channel that `logged` names (see names()); false when it
/// names none.
template <class F>
bool with_channel(std::string_view logged, F&& f) {
  return std::apply([&](const auto&... c) { return ((names(logged, c.name) ? (f(c), true) : false) || ...); }, kAll);
}

}  // namespace hpr::msg::channels
