#pragma once
/// \file Clocks used across the stack.

#include <poll.h>

#include <chrono>
#include <cstdint>
#include <ctime>
#include <span>

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

namespace hpr {

/// A fixed-rate schedule on the monotonic clock (absolute deadlines, so periods never drift).
/// next() advances the deadline one period; when more than `max_behind` late it restarts from now
/// rather than bursting through the missed periods.
class PeriodicClock {
 public:
  explicit PeriodicClock(double period_s) : period_ns_(static_cast<std::int64_t>(period_s * 1e9 + 0.5)), next_ns_(monotonic_ns()) {}
  /// Deadline of the current period [s].
  [[nodiscard]] double deadline() const { return static_cast<double>(next_ns_) * 1e-9; }
  /// Seconds left until the deadline (negative when late).
  [[nodiscard]] double left() const { return static_cast<double>(next_ns_ - monotonic_ns()) * 1e-9; }
  /// Starts the next period; returns how late [s] the current deadline was met when called.
  double next(double max_behind_s = 0.1) {
    const std::int64_t now = monotonic_ns();
    const double late = static_cast<double>(now - next_ns_) * 1e-9;
    next_ns_ += period_ns_;
    if (late > max_behind_s) next_ns_ = now + period_ns_;
    return late;
  }
  [[nodiscard]] double period() const { return static_cast<double>(period_ns_) * 1e-9; }

 private:
  std::int64_t period_ns_, next_ns_;
};

}  // namespace hpr

namespace hpr {

/// poll(2) with a timeout in seconds at nanosecond resolution (ppoll): poll's millisecond timeout
/// rounds a sub-millisecond wait down to zero, which turns a real-time loop into a busy spin.
/// Returns what ppoll returns; revents are reset first.
inline int poll_for(std::span<pollfd> fds, double timeout_s) {
  for (auto& p : fds) p.revents = 0;
  const double wait = timeout_s > 0 ? timeout_s : 0.0;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(wait);
  ts.tv_nsec = static_cast<long>((wait - static_cast<double>(ts.tv_sec)) * 1e9);
  return ::ppoll(fds.data(), fds.size(), &ts, nullptr);
}

}  // namespace hpr
