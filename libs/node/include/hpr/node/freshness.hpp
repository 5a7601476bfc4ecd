#pragma once
/// \file
/// Freshness of commands (OPERATOR, SUPERVISOR_COMMAND; docs/SAFETY.md, "Replayed messages"). A
/// signature says who made a command, not when: a recorded signed ENABLE, DOWN or SET_PARAMS sent
/// again would be acted on again. A command is fresh when
///  - its time `utime` [us, the sender's wall clock] is within `window` of the receiver's wall
///    clock (a recording played later is too old), and
///  - it is newer than every command the receiver took from the same sender (`source`): a sender's
///    times only increase, so a replay within the window is older than, or a copy of, one taken.
/// A copy (the same sender and time: the operator tool sends each command three times against
/// datagram loss) is dropped without being an error. Hosts of a deployment keep their clocks within
/// a fraction of the window of each other (NTP or PTP).

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>

#include <humanoid/operator_t.hpp>

namespace hpr::node {

/// A command type: a signed message naming its sender (`std::string source`) and its time (`utime`).
template <class Msg>
concept Command = requires(const Msg& m) {
  { m.source } -> std::convertible_to<std::string>;
  { m.utime } -> std::convertible_to<std::int64_t>;
} && std::is_same_v<decltype(Msg::source), std::string>;

/// Commands every receiver acts on however old they are: a stop is the safe side (an OPERATOR damp
/// or stop replayed damps the robot, which a controller must survive anyway).
inline bool acted_on_when_stale(const humanoid::operator_t& m) {
  return m.command == humanoid::operator_t::COMMAND_DAMP || m.command == humanoid::operator_t::COMMAND_STOP;
}
template <class Msg>
bool acted_on_when_stale(const Msg& /*m*/) {
  return false;
}

class CommandFreshness {
 public:
  enum class Verdict { kFresh, kCopy, kStale, kReplayed };
  /// The senders remembered; beyond, the one heard longest ago is forgotten (its replays are then
  /// refused by the window only).
  static constexpr std::size_t kMaxSenders = 64;

  /// `window_s` [s]: how far a command's time may be from the receiver's clock (0: not checked).
  explicit CommandFreshness(double window_s = 2.0) : window_us_(static_cast<std::int64_t>(window_s * 1e6)) {}

  /// Judges the command of `source` at `utime` received at `now_us` (the receiver's wall clock
  /// [us]); a fresh one is remembered. `why` says what is wrong with a stale or replayed one.
  Verdict check(std::string_view source, std::int64_t utime, std::int64_t now_us, std::string& why);
  [[nodiscard]] bool checks() const { return window_us_ > 0; }

 private:
  std::int64_t window_us_;
  std::unordered_map<std::string, std::int64_t> last_;  ///< sender -> time of the newest command taken
};

}  // namespace hpr::node
