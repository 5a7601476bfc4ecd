#include "hpr/msg/commands.hpp"

#include <fmt/format.h>

#include <cmath>
#include <humanoid/balance_status_t.hpp>

namespace hpr::msg {

std::string check_operator(const humanoid::operator_t& m) {
  using O = humanoid::operator_t;
  if (m.command < O::COMMAND_NONE || m.command > O::COMMAND_GET_PARAMS) {
    return fmt::format("unknown command {} (expected {} to {})", int{m.command}, int{O::COMMAND_NONE}, int{O::COMMAND_GET_PARAMS});
  }
  if (m.command == O::COMMAND_SET_SUPPORT &&
      (m.support < humanoid::balance_status_t::SUPPORT_DOUBLE || m.support > humanoid::balance_status_t::SUPPORT_RIGHT)) {
    return fmt::format("set support: unknown support {} (expected {} to {})", int{m.support},
                       int{humanoid::balance_status_t::SUPPORT_DOUBLE}, int{humanoid::balance_status_t::SUPPORT_RIGHT});
  }
  if (m.command == O::COMMAND_SET_PARAMS) {
    for (std::size_t i = 0; i < m.param_value.size(); ++i) {
      if (!std::isfinite(m.param_value[i])) return fmt::format("set params: {} = {} is not a finite number", m.param_name[i], m.param_value[i]);
    }
  }
  return {};
}

std::string check_supervisor_command(const humanoid::supervisor_command_t& m) {
  using C = humanoid::supervisor_command_t;
  if (m.command != C::COMMAND_DOWN && m.command != C::COMMAND_RESTART) {
    return fmt::format("unknown command {} (expected {} down or {} restart)", int{m.command}, int{C::COMMAND_DOWN}, int{C::COMMAND_RESTART});
  }
  if (m.command == C::COMMAND_RESTART && m.process.empty()) return "restart without a process name";
  return {};
}

}  // namespace hpr::msg
