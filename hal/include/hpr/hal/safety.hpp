#pragma once
/// \file
/// The hal's safety state machine (the table is in docs/SAFETY.md).
///
///   OFF ──enable──▶ ENABLED ──stale command / operator damp or stop──▶ DAMPING ──torque_off_after──▶ TORQUE_OFF
///                      │                                                  │
///                      └──drive fault / missed replies / bus-off──▶ FAULT (damping, then torque off)
///
/// Only an explicit enable leaves DAMPING, TORQUE_OFF or FAULT, and an enable is refused while a
/// fault condition is still present. Damping is kd only towards zero velocity, no feed-forward.
#include <cstdint>
#include <cstdint>
#include <limits>
#include <string>

namespace hpr::hal {

enum class SafetyState : std::int8_t { kOff = 0, kEnabled = 1, kDamping = 2, kTorqueOff = 3, kFault = 4 };
const char* to_string(SafetyState s);

/// What every drive is told this tick.
enum class DriveMode : std::int8_t { kOff, kRun, kDamp };

struct SafetyConfig {
  double command_max_age = 0.005;  ///< [s] JOINT_COMMAND older than this: damping
  double torque_off_after = 1.0;   ///< [s] damping (or fault) this long: torque off
  int missed_replies_fault = 5;    ///< replies missed in a row by one drive: fault
};

class SafetyMachine {
 public:
  explicit SafetyMachine(SafetyConfig config = {}) : config_(config) {}

  /// Operator enable issued at `issued_us` (the command's time [us, the sender's wall clock]).
  /// Refused (returns the reason) while a fault condition is present, and unless it was issued
  /// after the latest stop: a stop latches (docs/SAFETY.md, "Stops latch").
  std::string enable(double now, std::int64_t issued_us, bool fault_present, const std::string& fault_text);
  /// Operator damp or stop issued at `issued_us`: damping now, and held until an enable issued later.
  void stop(double now, std::int64_t issued_us, const std::string& reason);
  /// Damping now (a stale command, a report): not latched.
  void damp(double now, const std::string& reason);
  /// The time the latest operator stop was issued [us] (INT64_MIN: none yet).
  [[nodiscard]] std::int64_t stop_issued_us() const { return stop_issued_us_; }
  /// A fault condition (drive fault, missed replies, bus-off): FAULT now (damping).
  void fault(double now, const std::string& reason);
  /// Advances the timers: a stale command while enabled damps within this tick; damping or a
  /// fault lasting torque_off_after switches the torque off.
  void update(double now, double command_age);

  [[nodiscard]] SafetyState state() const { return state_; }
  [[nodiscard]] DriveMode drive_mode() const;
  [[nodiscard]] const std::string& reason() const { return reason_; }
  /// True for one update after the state changed (HAL_STATUS goes out on every change).
  [[nodiscard]] bool changed() const { return changed_; }
  void clear_changed() { changed_ = false; }
  /// True while the drives must be switched into motor mode (the tick of an enable).
  [[nodiscard]] bool entering() const { return entering_; }
  void entered() { entering_ = false; }
  [[nodiscard]] const SafetyConfig& config() const { return config_; }

 private:
  void go(SafetyState s, double now, const std::string& reason);
  SafetyConfig config_;
  SafetyState state_ = SafetyState::kOff;
  bool torque_off_ = false, changed_ = true, entering_ = false;
  double since_ = 0.0;
  std::int64_t stop_issued_us_ = std::numeric_limits<std::int64_t>::min();
  std::string reason_ = "waiting for an operator enable";
};

}  // namespace hpr::hal
