#pragma once
/// \file The tick of an encoded message and the per-tick data flow of the stack's channels
/// (README.md, "The processes"; hpr/graph/data_flow.hpp), for tools that read raw LCM traffic or logs without decoding.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hpr::msg {

/// The int64 tick every message of the stack starts with (after LCM's 8-byte type hash); -1 when
/// the buffer is too short to hold one.
std::int64_t tick_of(const void* data, int size);

/// Position of a channel in one tick's data flow: ROBOT_SENSORS, ROBOT_STATE, BALANCE_PLAN,
/// CAM_REFERENCE (with the previous tick's BALANCE_STATUS), WHOLEBODY_COMMAND, JOINT_COMMAND, BALANCE_STATUS, then
/// SIM_TRUTH. kNotInFlow for channels published at their own rate (HEALTH, PUSH, OPERATOR, ...).
int flow_rank(const std::string& channel);
inline constexpr int kNotInFlow = 99;

/// Which ticks of each data-flow channel were seen, to find the ones a log or a listener lacks
/// between a channel's first and last tick. One bit per tick; messages may arrive out of order.
class TickCoverage {
 public:
  /// Records `tick` for `channel` (ignored for channels outside the flow and negative ticks).
  void add(const std::string& channel, std::int64_t tick);
  /// The ticks each channel lacks between its first and its last, in order (channels without a
  /// gap are not listed).
  [[nodiscard]] std::map<std::string, std::vector<std::int64_t>> lacking() const;

 private:
  struct Seen {
    std::int64_t first = 0;
    std::vector<bool> bits;  // bits[t - first]
  };
  std::map<std::string, Seen> seen_;
};

/// "1811-1813, 1902, 1926" for a sorted list of ticks, at most `limit` ranges then "...".
std::string tick_ranges(const std::vector<std::int64_t>& ticks, std::size_t limit = 6);

}  // namespace hpr::msg
