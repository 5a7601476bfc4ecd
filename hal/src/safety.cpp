#include "hpr/hal/safety.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace hpr::hal {

const char* to_string(SafetyState s) {
  switch (s) {
    case SafetyState::kOff: return "off";
    case SafetyState::kEnabled: return "enabled";
    case SafetyState::kDamping: return "damping";
    case SafetyState::kTorqueOff: return "torque off";
    case SafetyState::kFault: return "fault";
  }
  return "?";
}

void SafetyMachine::go(SafetyState s, double now, const std::string& reason) {
  if (s != state_) {
    state_ = s;
    since_ = now;
    torque_off_ = s == SafetyState::kTorqueOff || s == SafetyState::kOff;
    changed_ = true;
  }
  if (reason != reason_) changed_ = true;
  reason_ = reason;
}

std::string SafetyMachine::enable(double now, std::int64_t issued_us, bool fault_present, const std::string& fault_text) {
  if (issued_us <= stop_issued_us_) {
    return fmt::format("enable refused: issued {:.6f} s before the stop it would lift (a stop holds until an enable sent after it)",
                       static_cast<double>(stop_issued_us_ - issued_us) * 1e-6);
  }
  if (fault_present) return "enable refused: " + fault_text;
  if (state_ != SafetyState::kEnabled) entering_ = true;
  go(SafetyState::kEnabled, now, "enabled by the operator");
  return {};
}

void SafetyMachine::stop(double now, std::int64_t issued_us, const std::string& reason) {
  stop_issued_us_ = std::max(stop_issued_us_, issued_us);
  damp(now, reason);
}

void SafetyMachine::damp(double now, const std::string& reason) {
  // Off and torque-off stay as they are; a fault keeps its state (and its reason).
  if (state_ == SafetyState::kEnabled) go(SafetyState::kDamping, now, reason);
}

void SafetyMachine::fault(double now, const std::string& reason) {
  if (state_ == SafetyState::kFault) {
    reason_ = reason;
    return;
  }
  const bool was_off = state_ == SafetyState::kOff || state_ == SafetyState::kTorqueOff;
  go(SafetyState::kFault, now, reason);
  torque_off_ = was_off;  // a fault never switches torque on
}

void SafetyMachine::update(double now, double command_age) {
  if (state_ == SafetyState::kEnabled && !(command_age <= config_.command_max_age)) {
    go(SafetyState::kDamping, now, "JOINT_COMMAND stale");
  }
  if ((state_ == SafetyState::kDamping || state_ == SafetyState::kFault) && !torque_off_ &&
      now - since_ >= config_.torque_off_after) {
    if (state_ == SafetyState::kDamping) {
      go(SafetyState::kTorqueOff, now, reason_ + "; torque off after damping");
    } else {
      torque_off_ = true;
      changed_ = true;
    }
  }
}

DriveMode SafetyMachine::drive_mode() const {
  switch (state_) {
    case SafetyState::kEnabled: return DriveMode::kRun;
    case SafetyState::kDamping: return DriveMode::kDamp;
    case SafetyState::kFault: return torque_off_ ? DriveMode::kOff : DriveMode::kDamp;
    default: return DriveMode::kOff;
  }
}

}  // namespace hpr::hal
