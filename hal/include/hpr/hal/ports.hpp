#pragma once
/// \file The ports of the hal process and of the drive emulator (hpr/common/ports.hpp).

#include <string_view>

#include "hpr/common/ports.hpp"

namespace hpr::hal {

inline constexpr Read kReads[] = {{channel::kJointCommand, -1, false, true, "drive commands (stale ones time out to damping)"},
                                  {channel::kOperator, 0, false, true, "enable, damp, stop"}};
inline constexpr std::string_view kWrites[] = {channel::kRobotSensors, channel::kHalStatus};
inline constexpr Ports kPorts{"hal", kReads, kWrites};

/// The drive emulator: the drives' side of the CAN buses, backed by the simulation.
inline constexpr Read kEmulatorReads[] = {{channel::kPush, 0, false, true, "pushes to apply"}};
inline constexpr std::string_view kEmulatorWrites[] = {channel::kSimTruth};
inline constexpr Ports kEmulatorPorts{"drive_emulator", kEmulatorReads, kEmulatorWrites};

}  // namespace hpr::hal
