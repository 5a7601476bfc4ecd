#pragma once
/// \file
/// What a process of the stack reads and writes, declared once as constants beside the component
/// it runs (README.md, "The processes"): for each channel it reads, which tick (relative to the
/// tick it steps on), whether it steps on it and whether it can go on without it; and the channels
/// it writes. The node runtime refuses a channel its process does not declare; the composition
/// (hpr/graph/data_flow.hpp) gathers the declarations into the stack's data flow, from which the
/// composed process's ports, the supervisor's group checks and replay_check's comparisons follow.
/// No LCM here: a channel is its name (the message type it carries: hpr/msg/channels.hpp).

#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace hpr {

/// Every channel's name on LCM (before a runtime's prefix), spelled once.
namespace channel {
// The control chain, one message per tick.
inline constexpr const char* kRobotSensors = "ROBOT_SENSORS";
inline constexpr const char* kRobotState = "ROBOT_STATE";
inline constexpr const char* kBalancePlan = "BALANCE_PLAN";
inline constexpr const char* kCamReference = "CAM_REFERENCE";
inline constexpr const char* kWholebodyCommand = "WHOLEBODY_COMMAND";
inline constexpr const char* kJointCommand = "JOINT_COMMAND";
inline constexpr const char* kBalanceStatus = "BALANCE_STATUS";
// The backends' own.
inline constexpr const char* kSimTruth = "SIM_TRUTH";
inline constexpr const char* kHalStatus = "HAL_STATUS";
inline constexpr const char* kPush = "PUSH";
// Commands and reports.
inline constexpr const char* kOperator = "OPERATOR";
inline constexpr const char* kHealth = "HEALTH";
inline constexpr const char* kParams = "PARAMS";
inline constexpr const char* kSupervisorCommand = "SUPERVISOR_COMMAND";
inline constexpr const char* kSupervisorStatus = "SUPERVISOR_STATUS";
}  // namespace channel

/// How a process reads a channel.
struct Read {
  std::string_view channel;
  int tick_offset = 0;    ///< the tick read, relative to the tick of the step (−1: the previous tick's)
  bool trigger = false;   ///< the process steps on each tick of this channel
  bool optional = false;  ///< the step goes on without it (after its timeout, with a fallback)
  std::string_view use;   ///< what the process does with it
};

/// A process's ports. HEALTH and PARAMS, which every node has, are left out.
struct Ports {
  std::string_view name;  ///< the process (and its executable)
  std::span<const Read> reads;
  std::span<const std::string_view> writes;

  /// How the process reads `channel`; nullptr when it does not.
  [[nodiscard]] constexpr const Read* read(std::string_view channel) const {
    for (const Read& r : reads) {
      if (r.channel == channel) return &r;
    }
    return nullptr;
  }
  /// How the process reads `channel`; throws std::invalid_argument when it does not.
  [[nodiscard]] constexpr const Read& at(std::string_view channel) const {
    const Read* r = read(channel);
    if (r == nullptr) throw std::invalid_argument(std::string(name) + " does not read " + std::string(channel));
    return *r;
  }
  /// Whether the process reads `channel` at `tick_offset` (no pointers: a check that holds in
  /// constant expressions under every compiler's instrumentation too).
  [[nodiscard]] constexpr bool reads_at(std::string_view channel, int tick_offset) const {
    for (const Read& r : reads) {
      if (r.channel == channel) return r.tick_offset == tick_offset;
    }
    return false;
  }
  /// Whether the process steps on each tick of `channel`.
  [[nodiscard]] constexpr bool steps_on(std::string_view channel) const {
    for (const Read& r : reads) {
      if (r.channel == channel) return r.trigger;
    }
    return false;
  }
  [[nodiscard]] constexpr bool writes_to(std::string_view channel) const {
    for (std::string_view w : writes) {
      if (w == channel) return true;
    }
    return false;
  }
};

/// Whether `to` reads what `from` writes on `channel`, at `tick_offset` (a composition's wiring,
/// checked against both declarations at compile time).
constexpr bool wired(const Ports& from, std::string_view ch, const Ports& to, int tick_offset) {
  return from.writes_to(ch) && to.reads_at(ch, tick_offset);
}

}  // namespace hpr
