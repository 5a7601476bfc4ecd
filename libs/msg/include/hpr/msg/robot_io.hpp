#pragma once
/// \file
/// Conversions between the LCM messages at the robot boundary and the plain data of the libraries,
/// with validation: a message whose sizes, joint names or values are wrong is refused with the reason.

#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <string>
#include <vector>

#include "hpr/common/robot_io.hpp"

namespace hpr::msg {

/// Names that messages must carry, in the model's joint order.
struct RobotNames {
  std::vector<std::string> joints;
  std::array<std::string, 2> feet{"right", "left"};
};

void to_message(const SensorSample& s, const RobotNames& names, humanoid::robot_sensors_t& m);
/// Empty when `m` is a valid sample for `names` (filled into `s`), else the reason.
std::string from_message(const humanoid::robot_sensors_t& m, const RobotNames& names, SensorSample& s);

void to_message(const JointCommand& c, const RobotNames& names, humanoid::joint_command_t& m);
/// Empty when `m` is a valid command for `names` (filled into `c`), else the reason. Non-finite values,
/// negative gains, unknown modes and wrong joint counts or names are refused.
std::string from_message(const humanoid::joint_command_t& m, const RobotNames& names, JointCommand& c);

}  // namespace hpr::msg
