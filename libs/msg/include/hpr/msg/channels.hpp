#pragma once
/// \file
/// Every channel of the stack, each name spelled here once, with the message type it carries
/// (contracts in lcmtypes/*.lcm; who reads and writes which: hpr/msg/graph.hpp).

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

namespace hpr::msg::channels {

// The control chain, one message per tick.
inline constexpr Channel<humanoid::robot_sensors_t> kRobotSensors{"ROBOT_SENSORS"};
inline constexpr Channel<humanoid::robot_state_t> kRobotState{"ROBOT_STATE"};
inline constexpr Channel<humanoid::cam_reference_t> kCamReference{"CAM_REFERENCE"};
inline constexpr Channel<humanoid::wholebody_command_t> kWholebodyCommand{"WHOLEBODY_COMMAND"};
inline constexpr Channel<humanoid::joint_command_t> kJointCommand{"JOINT_COMMAND"};
inline constexpr Channel<humanoid::balance_status_t> kBalanceStatus{"BALANCE_STATUS"};
// The backends' own.
inline constexpr Channel<humanoid::sim_truth_t> kSimTruth{"SIM_TRUTH"};
inline constexpr Channel<humanoid::hal_status_t> kHalStatus{"HAL_STATUS"};
inline constexpr Channel<humanoid::push_t> kPush{"PUSH"};
// Commands and reports.
inline constexpr Channel<humanoid::operator_t> kOperator{"OPERATOR"};
inline constexpr Channel<humanoid::health_t> kHealth{"HEALTH"};
inline constexpr Channel<humanoid::params_t> kParams{"PARAMS"};
inline constexpr Channel<humanoid::supervisor_command_t> kSupervisorCommand{"SUPERVISOR_COMMAND"};
inline constexpr Channel<humanoid::supervisor_status_t> kSupervisorStatus{"SUPERVISOR_STATUS"};

/// Every channel above.
inline constexpr std::tuple kAll{kRobotSensors, kRobotState,     kCamReference,      kWholebodyCommand, kJointCommand,
                                 kBalanceStatus, kSimTruth,      kHalStatus,         kPush,             kOperator,
                                 kHealth,        kParams,        kSupervisorCommand, kSupervisorStatus};

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
