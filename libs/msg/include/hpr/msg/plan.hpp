#pragma once
/// \file Conversions of BALANCE_PLAN with validation: the plan goes through its message bit for bit
/// (orientations as rotation matrices), and a plan that is not one (a rotation that is not, a
/// non-finite value, an unknown stage or support) is refused whole.

#include <humanoid/balance_plan_t.hpp>
#include <string>
#include <vector>

#include "hpr/balance/ports.hpp"
#include "hpr/msg/robot_io.hpp"

namespace hpr::msg {

/// `free_names`: the free joints in RobotSpec::free_joints order.
void to_message(const balance::BalancePlan& p, const std::vector<std::string>& free_names, const RobotNames& names,
                humanoid::balance_plan_t& m);
/// Empty when `m` is a valid plan for `free_names` (filled into `p`), else the reason. A rotation
/// must be one to 1e-9 (RᵀR = I, det R = 1): the planner's are orthonormal to rounding.
std::string from_message(const humanoid::balance_plan_t& m, const std::vector<std::string>& free_names, balance::BalancePlan& p);

}  // namespace hpr::msg
