#pragma once
/// \file The simulation processes' ports (hpr/common/ports.hpp).

#include <string_view>

#include "hpr/common/ports.hpp"

namespace hpr::sim {

inline constexpr Read kReads[] = {
    {channel::kJointCommand, -1, false, true, "drive commands (in lockstep the step waits for the answer to its last sensors)"},
    {channel::kPush, 0, false, true, "pushes to apply"}};
inline constexpr std::string_view kWrites[] = {channel::kRobotSensors, channel::kSimTruth};
inline constexpr Ports kPorts{"sim_bullet", kReads, kWrites};
/// The same simulation over MuJoCo (sim_mujoco).
inline constexpr Ports kMujocoPorts{"sim_mujoco", kReads, kWrites};

}  // namespace hpr::sim
