#pragma once
/// \file Clocks used across the stack.

#include <chrono>
#include <cstdint>

namespace hpr {

/// Monotonic time in seconds (for durations, timeouts, cycle statistics).
inline double monotonic_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Monotonic time in nanoseconds.
inline std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// Wall-clock time in microseconds since the epoch (for HEALTH and OPERATOR stamps).
inline std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace hpr
