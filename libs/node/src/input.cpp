// The rules of a clocked input (docs/SAFETY.md, "Faults in the running stack"): the tick window,
// the time rule, one source per stream, following a restarted source, one message per tick, and
// the authentication code; what is refused is counted and reported through the runtime.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hpr/common/time.hpp"
#include "hpr/common/log.hpp"
#include "hpr/node/input.hpp"

namespace hpr::node {

void InputBase::accept(std::int64_t tick, std::int64_t utime, std::int64_t source) {
  source_ = source;
  receive_time_ = monotonic_s();
  // A repeated tick (a source republishing while it waits) does not show that its clock runs.
  if (tick > tick_ || tick_ < 0) advance_time_ = receive_time_;
  tick_ = tick;
  utime_ = utime;
  ++count_;
}

void InputBase::notify() { events_.on_input(*this); }

void InputBase::reject(std::size_t bytes, const std::string& why) {
  ++errors_;
  last_error_ = why;
  events_.on_reject(*this, bytes, why);
}

bool InputBase::authentic(const void* bytes, std::size_t n, const auth::Key* key) {
  if (key == nullptr || auth::verify(static_cast<const std::uint8_t*>(bytes), n, channel_, *key)) return true;
  ++unauthenticated_;
  reject(n, "no valid authentication code: not signed with this deployment's key (" + key->path + ")");
  return false;
}

bool InputBase::fresh(const std::string& source, std::int64_t utime, bool stop, std::size_t bytes) {
  std::string why;
  switch (freshness_.check(source, utime, wall_us(), why)) {
    case CommandFreshness::Verdict::kFresh: return true;
    case CommandFreshness::Verdict::kCopy: ++copies_; return false;
    case CommandFreshness::Verdict::kStale:
    case CommandFreshness::Verdict::kReplayed: break;
  }
  if (stop) {
    ++stale_stops_;
    log::warn("{}: a stop taken although {}", channel_, why);
    return true;
  }
  ++stale_commands_;
  reject(bytes, why);
  return false;
}

bool InputBase::in_window(std::int64_t tick) const {
  return tick_ < 0 || (tick >= tick_ && tick - tick_ <= rules_.tick_window);
}

std::string InputBase::implausible_time(std::int64_t tick, std::int64_t utime, double now) const {
  // utime 0: the source's clock has not started (an estimator that is still initialising).
  if (tick_ < 0 || (utime_ == 0 && utime >= 0)) return {};
  const StreamRules& o = rules_;
  // In seconds, as doubles: a corrupted utime may be anywhere in int64's range.
  const double dt = (static_cast<double>(utime) - static_cast<double>(utime_)) * 1e-6;
  const double allowed = static_cast<double>(tick - tick_) * o.tick_period_max_s + std::max(0.0, now - receive_time_) + o.time_slack_s;
  if (dt < 0.0) {
    return fmt::format("time {:.6f} s at tick {} goes back {:.6f} s from {:.6f} s at tick {}", static_cast<double>(utime) * 1e-6, tick,
                       -dt, static_cast<double>(utime_) * 1e-6, tick_);
  }
  if (dt > allowed) {
    return fmt::format("time {:.6f} s at tick {} is {:.6g} s ahead of {:.6f} s at tick {} (at most {:.3f} s for {} ticks)",
                       static_cast<double>(utime) * 1e-6, tick, dt, static_cast<double>(utime_) * 1e-6, tick_, allowed, tick - tick_);
  }
  return {};
}

std::string InputBase::second_source(std::int64_t source) const {
  if (tick_ < 0 || source_identity(source) == source_identity(source_)) return {};
  return fmt::format("source {:08x} is not the stream's source {:08x} (a second sender on the channel)", source_identity(source),
                     source_identity(source_));
}

bool InputBase::retired(std::int64_t source) const {
  const std::uint32_t id = source_identity(source);
  return id != 0 && std::find(retired_.begin(), retired_.end(), id) != retired_.end();
}

std::string InputBase::replay(std::int64_t source, std::int64_t tick) const {
  const std::uint32_t id = source_identity(source);
  if (tick_ < 0 || id == 0) return {};  // 0: unstamped (a tool's or a test's message), judged by its ticks alone
  if (retired(source)) {
    // A restarted process draws a new identity: one the input followed once and left is a replay.
    return fmt::format("tick {} of source {:08x}, a source this input followed once and left: a replay, never followed", tick, id);
  }
  if (id != source_identity(source_)) return {};
  // The sender's counter goes up by one a message (modulo 2^32): one that is not ahead of the
  // latest taken is a copy or a recording. (Its ticks may go back: its upstream restarted.)
  const std::uint32_t ahead = source_counter(source) - source_counter(source_);
  if (ahead != 0 && ahead < 0x80000000U) return {};
  return fmt::format("tick {} of source {:08x} is message {} of its sender, not after message {} taken: a replay, never followed", tick,
                     id, source_counter(source), source_counter(source_));
}

void InputBase::hold(std::size_t bytes, std::int64_t tick, std::int64_t source, const std::string& why) {
  const double now = monotonic_s();
  held_ = true;
  held_tick_ = tick;
  held_source_ = source;
  ++out_of_window_;
  const double quiet = rules_.source_quiet_s;
  if (why == "tick") {
    const std::string where = tick > tick_ ? fmt::format("{} ahead of", tick - tick_) : fmt::format("{} behind", tick_ - tick);
    reject(bytes, fmt::format("tick {} is {} the last tick {} (window {}): held until the stream is quiet for {} s", tick, where,
                              tick_, rules_.tick_window, quiet));
  } else {
    reject(bytes, fmt::format("{}: held until the stream is quiet for {} s", why, quiet));
  }
  follow_if_quiet(now);
}

double InputBase::follow_time() const {
  if (!held_) return std::numeric_limits<double>::infinity();
  return advance_time_ + rules_.source_quiet_s;
}

void InputBase::follow_if_quiet(double now) {
  if (!held_ || now < follow_time()) return;
  const std::int64_t old_tick = tick_, new_tick = held_tick_;
  const double quiet = now - advance_time_;
  if (source_identity(source_) != 0 && source_identity(source_) != source_identity(held_source_)) {
    retired_[retired_next_] = source_identity(source_);
    retired_next_ = (retired_next_ + 1) % retired_.size();
  }
  restart_stream();
  ++follows_;
  log::warn("{}: following tick {} (no tick near {} for {:.3f} s: the source restarted or its clock jumped)", channel_,
            new_tick, old_tick, quiet);
  events_.on_follow(*this, old_tick, new_tick);
  adopt_held();
}

void InputBase::restart_stream() { tick_ = -1; }

bool InputBase::repeats_waiting_step(std::int64_t tick) {
  if (tick != tick_ || tick_ < 0 || !events_.step_waits_at(*this, tick)) return false;
  ++repeats_;
  return true;
}

}  // namespace hpr::node
