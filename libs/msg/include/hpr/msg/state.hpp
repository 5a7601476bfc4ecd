#pragma once
/// \file Conversions of ROBOT_STATE and WHOLEBODY_COMMAND with validation.

#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>
#include <string>

#include "hpr/balance/task_reference.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/msg/robot_io.hpp"

namespace hpr::msg {

/// ROBOT_STATE status bits of an estimate nothing may act on or start from: sensors stale or
/// incomplete, a reading implausible, the filter diverged.
inline constexpr std::int32_t kStateUnusable = std::int32_t{humanoid::robot_state_t::STATUS_SENSOR_STALE} |
                                               std::int32_t{humanoid::robot_state_t::STATUS_IMPLAUSIBLE} |
                                               std::int32_t{humanoid::robot_state_t::STATUS_COVARIANCE};

void to_message(const EstimatedState& s, const RobotNames& names, humanoid::robot_state_t& m);
/// Empty when `m` is valid for `names` (filled into `s`), else the reason.
std::string from_message(const humanoid::robot_state_t& m, const RobotNames& names, EstimatedState& s);

/// `free_names` are the free joints in RobotSpec::free_joints order.
void to_message(const balance::TaskReference& r, const std::vector<std::string>& free_names, const RobotNames& names,
                humanoid::wholebody_command_t& m);
std::string from_message(const humanoid::wholebody_command_t& m, const std::vector<std::string>& free_names,
                         balance::TaskReference& r);

}  // namespace hpr::msg
