#pragma once
/// \file Conversions of ROBOT_STATE and WHOLEBODY_COMMAND with validation.

#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>
#include <string>

#include "hpr/balance/ports.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/msg/robot_io.hpp"

namespace hpr::msg {

/// ROBOT_STATE status bits of an estimate nothing may act on or start from: sensors stale or
/// incomplete, a reading implausible, the filter diverged.
inline constexpr std::int32_t kStateUnusable = EstimatedState::kUnusable;
static_assert(EstimatedState::kSensorStale == humanoid::robot_state_t::STATUS_SENSOR_STALE &&
              EstimatedState::kNoContact == humanoid::robot_state_t::STATUS_NO_CONTACT &&
              EstimatedState::kCovariance == humanoid::robot_state_t::STATUS_COVARIANCE &&
              EstimatedState::kImplausible == humanoid::robot_state_t::STATUS_IMPLAUSIBLE &&
              EstimatedState::kInitialising == humanoid::robot_state_t::STATUS_INITIALISING);

void to_message(const EstimatedState& s, const RobotNames& names, humanoid::robot_state_t& m);
/// Empty when `m` is valid for `names` (filled into `s`), else the reason.
std::string from_message(const humanoid::robot_state_t& m, const RobotNames& names, EstimatedState& s);

/// WHOLEBODY_COMMAND. `free_names` are the free joints in RobotSpec::free_joints order; c.adjusted_name
/// names the adjusted coordinates.
void to_message(const balance::WholebodyCommand& c, const std::vector<std::string>& free_names, const RobotNames& names,
                humanoid::wholebody_command_t& m);
/// Empty when `m` is valid for `free_names` (filled into `c`), else the reason. Empty `free_names`:
/// any free joints (for a reader of the diagnostics only, such as the reference generator).
std::string from_message(const humanoid::wholebody_command_t& m, const std::vector<std::string>& free_names,
                         balance::WholebodyCommand& c);

}  // namespace hpr::msg
