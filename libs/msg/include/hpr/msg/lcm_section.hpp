#pragma once
/// \file The `lcm` section of a configuration: how the processes exchange messages. Read by the node
/// runtime of every process, and validated (every key, each in its range) by the in-process pipeline
/// too, so that a misspelt key is refused whichever way the stack runs.

#include <cstdint>
#include <string>

#include "hpr/common/config.hpp"

namespace hpr::msg {

struct LcmSection {
  std::string url;                     ///< empty: $LCM_DEFAULT_URL, else LCM's default
  std::string channel_prefix;          ///< prepended to every channel name
  double health_rate_hz = 10.0;
  double decode_fault_quiet_s = 2.0;   ///< [s] a channel's decode fault clears after this long
  std::int64_t tick_window = 1000;     ///< [ticks] how far ahead of its last tick a stream's next may be
  double source_quiet_s = 0.1;         ///< [s] quiet time after which a held stream is followed
  double tick_period_max_s = 0.01;     ///< [s] a stream's time may run this much per tick ahead of the wall clock
  double time_slack_s = 0.05;          ///< [s] and this much more
  double command_window_s = 2.0;       ///< [s] how far a command's time may be from the receiver's clock (0: unchecked)
  double spin_s = 0.0;                 ///< [s] busy-poll window around the next sensor tick
  /// `receive: liblcm` (the default): liblcm's receive thread reads LCM's socket while the node
  /// computes; `direct`: the node's own loop reads it (hpr/node/udpm.hpp; one wake-up per message
  /// fewer, for a process with a core of its own).
  bool receive_direct = false;
  /// `authentication: required` (the default) or `off` (a bench): whether the commands and the
  /// clocked channels carry and are checked for the deployment key's code (hpr/common/auth.hpp).
  bool authenticate = true;

  /// The configuration's `lcm` section (defaults where it has none); throws ConfigError naming the
  /// file, key and value of an entry out of range.
  static LcmSection load(const Config& cfg);
};

}  // namespace hpr::msg
