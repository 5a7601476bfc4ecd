#pragma once
/// \file
/// What a bad message in a log is, said once for every tool that reads logs (lcm_export,
/// lcm_recorder --check): an event on a channel of the stack whose bytes do not decode as that
/// channel's type (the hardened decoders: wrong fingerprint, truncated, forged counts or lengths).

#include <string>

namespace hpr::msg {

/// The LCM type a channel of the stack carries ("humanoid.robot_sensors_t"), by the channel's name
/// with any prefix ("robotA/ROBOT_SENSORS"); empty for a channel that is not the stack's.
std::string type_of_channel(const std::string& channel);

/// Whether the channel's type carries an authentication code (hpr/common/auth.hpp: the commands
/// and the clocked channels); false for a channel that is not the stack's.
bool carries_code(const std::string& channel);

/// Empty when `data` decodes as the channel's type, or the channel is not the stack's; else why not.
std::string check_message(const std::string& channel, const void* data, int size);

}  // namespace hpr::msg
