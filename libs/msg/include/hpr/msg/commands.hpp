#pragma once
/// \file
/// The documented ranges of the command channels. A command outside them is refused whole, with
/// the reason, by every receiver (a corrupted or forged command must not be half understood).

#include <humanoid/operator_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <string>

namespace hpr::msg {

/// OPERATOR: a known command (operator_t.COMMAND_*); SET_SUPPORT with a support of
/// balance_status_t.SUPPORT_*; SET_PARAMS with finite values. Empty when acceptable.
std::string check_operator(const humanoid::operator_t& m);

/// SUPERVISOR_COMMAND: DOWN, or RESTART naming a process. Empty when acceptable.
std::string check_supervisor_command(const humanoid::supervisor_command_t& m);

}  // namespace hpr::msg
