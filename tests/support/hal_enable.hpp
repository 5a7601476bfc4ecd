#pragma once
/// \file Enabling the hal's drives from a test, as an operator does: once the controllers'
/// JOINT_COMMAND flows, OPERATOR enable, then HAL_STATUS must say enabled.

#include <humanoid/hal_status_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "hpr/common/time.hpp"
#include "lcm_listener.hpp"

namespace hpr::test {

/// Empty when the hal reported STATE_ENABLED within `enabled_within` of the enable, which is sent
/// once more than 200 commands arrived (within `commands_within`); else what did not happen.
inline std::string enable_drives(LcmListener& lcm, const std::shared_ptr<std::vector<humanoid::joint_command_t>>& commands,
                                 const std::shared_ptr<std::vector<humanoid::hal_status_t>>& status,
                                 std::chrono::milliseconds commands_within, std::chrono::milliseconds enabled_within) {
  if (!lcm.wait_for([&] { return commands->size() > 200; }, commands_within)) return "no JOINT_COMMAND from the control processes";
  humanoid::operator_t op{};
  op.source = "test";
  op.utime = hpr::wall_us();  // a command is taken only when fresh
  op.command = humanoid::operator_t::COMMAND_ENABLE;
  op.num_params = 0;
  lcm.publish("OPERATOR", op);
  const auto enabled = [&] { return !status->empty() && status->back().state == humanoid::hal_status_t::STATE_ENABLED; };
  if (lcm.wait_for(enabled, enabled_within)) return {};
  return status->empty() ? std::string("no HAL_STATUS")
                         : "hal state " + std::to_string(status->back().state) + ": " + status->back().state_reason;
}

}  // namespace hpr::test
