#include "hpr/hal/cia402.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hpr::hal {

using namespace canopen;

// ---------------------------------------------------------------------------------------------
// Scaling
// ---------------------------------------------------------------------------------------------

double Cia402Scaling::rad_per_count() const { return 2.0 * std::numbers::pi / (counts_per_revolution * gear_ratio); }

double Cia402Scaling::rad_s_per_unit() const {
  return velocity_rpm ? 2.0 * std::numbers::pi / 60.0 / gear_ratio : rad_per_count();
}

double Cia402Scaling::nm_per_permille() const { return rated_torque * gear_ratio / 1000.0; }

std::int16_t Cia402Scaling::torque_to_drive(double tau) const {
  if (!std::isfinite(tau)) return 0;
  return static_cast<std::int16_t>(std::clamp(std::round(tau / nm_per_permille()), -32767.0, 32767.0));
}

// ---------------------------------------------------------------------------------------------
// Master
// ---------------------------------------------------------------------------------------------

const char* Cia402Master::to_string(Phase p) {
  switch (p) {
    case Phase::kReset: return "resetting";
    case Phase::kBooting: return "waiting for its boot-up message";
    case Phase::kIdentifying: return "reading its identity";
    case Phase::kConfiguring: return "configuring";
    case Phase::kStarting: return "starting (waiting for an operational heartbeat)";
    case Phase::kCyclic: return "cyclic";
    case Phase::kFailed: return "failed to start";
  }
  return "?";
}

Cia402Master::Cia402Master(int node, Cia402Scaling scaling, CanOpenTiming timing) : node_(node), scaling_(scaling), timing_(timing) {}

std::string Cia402Master::not_ready() const {
  if (phase_ == Phase::kCyclic) return {};
  if (phase_ == Phase::kConfiguring && sdo_) {
    return fmt::format("node {} {} (SDO {} of {})", node_, to_string(phase_), sdo_->confirmed() + 1,
                       cst_configuration(node_, timing_.heartbeat_ms).size());
  }
  return fmt::format("node {} {}", node_, to_string(phase_));
}

bool Cia402Master::takes(int code) const {
  // The first fault stays; an EMCY explains (and replaces) a state change the master saw first.
  const bool replace_own = fault_code_ == kFaultDriveState || fault_code_ == kFaultEnable;
  return fault_code_ == 0 || (replace_own && code < 0xFF00);
}

void Cia402Master::latch(int code, std::string text) {
  if (!takes(code)) return;
  fault_code_ = code;
  fault_text_ = std::move(text);
}

void Cia402Master::fail(std::string text) {
  latch(kFaultStartUp, std::move(text));
  phase_ = Phase::kFailed;
}

namespace {

struct Read {
  std::uint16_t index;
  const char* what;
};
constexpr Read kReads[] = {{kDeviceType, "device type"}, {kSupportedModes, "supported drive modes"}, {kRatedTorque, "motor rated torque"}};

}  // namespace

void Cia402Master::identify(double now, std::vector<CanFrame>& out) {
  if (read_ >= std::size(kReads)) {
    sdo_.emplace(node_, cst_configuration(node_, timing_.heartbeat_ms), timing_.sdo_timeout);
    phase_ = Phase::kConfiguring;
    if (const auto f = sdo_->poll(now)) out.push_back(*f);
    return;
  }
  if (read_sent_) {
    if (now - *read_sent_ > timing_.sdo_timeout) {
      fail(fmt::format("node {}: SDO read 0x{:04X}:00 ({}): no answer within {:.3f} s", node_, kReads[read_].index, kReads[read_].what,
                       timing_.sdo_timeout));
    }
    return;
  }
  read_sent_ = now;
  out.push_back(sdo_upload(node_, SdoAddress{kReads[read_].index, 0}));
}

void Cia402Master::judge(const SdoMessage& m) {
  const Read& r = kReads[read_];
  if (m.address.index != r.index || m.address.subindex != 0) return;  // not the answer awaited
  const bool absent = m.kind == SdoMessage::Kind::kAbort;
  if (!absent && m.kind != SdoMessage::Kind::kUploadData) return;
  read_sent_.reset();
  ++read_;
  const std::uint32_t v = m.value;
  switch (r.index) {
    case kDeviceType:
      if (absent) return fail(fmt::format("node {}: SDO read 0x1000 (device type) refused: abort 0x{:08X} ({})", node_, v, sdo_abort_meaning(v)));
      if ((v & 0xFFFF) != 402) return fail(fmt::format("node {}: device type 0x{:08X} is profile {}, not a CiA 402 drive", node_, v, v & 0xFFFF));
      return;
    case kSupportedModes:
      if (!absent && (v & (1U << 9)) == 0) {
        return fail(fmt::format("node {}: supported drive modes 0x6502 = 0x{:08X}: no cyclic synchronous torque (bit 9)", node_, v));
      }
      return;  // a drive without 0x6502 is judged by its answer to mode 10
    case kRatedTorque: {
      if (absent) {
        if (!scaling_.rated_torque_given) {
          return fail(fmt::format("node {}: the drive has no motor rated torque (0x6076: abort 0x{:08X}, {}) and the configuration gives none "
                                  "(hal.canopen.rated_torque or the drive's cia402.rated_torque)",
                                  node_, v, sdo_abort_meaning(v)));
        }
        return;
      }
      const double drive = 1e-3 * v;
      if (!scaling_.rated_torque_given) {
        if (drive <= 0) return fail(fmt::format("node {}: motor rated torque 0x6076 = {} mN m", node_, v));
        scaling_.rated_torque = drive;
      } else if (std::abs(drive - scaling_.rated_torque) > 0.01 * scaling_.rated_torque) {
        return fail(fmt::format("node {}: the drive's motor rated torque 0x6076 = {} mN m disagrees with the configuration's {} N m: every "
                                "torque would be scaled wrongly",
                                node_, v, scaling_.rated_torque));
      }
      return;
    }
    default: return;
  }
}

void Cia402Master::reset_fault() {
  reset_requested_ = true;
  fault_code_ = 0;
  fault_text_.clear();
  if (phase_ == Phase::kFailed) phase_ = Phase::kReset;
}

void Cia402Master::tick(double now, bool enable, double torque, std::vector<CanFrame>& out) {
  rx_ = 0;
  switch (phase_) {
    case Phase::kReset:
      out.push_back(nmt(NmtCommand::kResetCommunication, node_));
      phase_ = Phase::kBooting;
      phase_since_ = now;
      sdo_.reset();
      read_ = 0;
      read_sent_.reset();
      state_.reset();
      nmt_.reset();
      return;
    case Phase::kBooting:
      if (now - phase_since_ > timing_.boot_timeout) {
        fail(fmt::format("node {}: no boot-up message within {:.3f} s of NMT reset communication", node_, timing_.boot_timeout));
      }
      return;
    case Phase::kIdentifying:
      identify(now, out);
      return;
    case Phase::kConfiguring:
      if (const auto f = sdo_->poll(now)) out.push_back(*f);
      if (sdo_->failed()) {
        fail(sdo_->error());
      } else if (sdo_->done()) {
        out.push_back(nmt(NmtCommand::kStart, node_));
        phase_ = Phase::kStarting;
        phase_since_ = now;
      }
      return;
    case Phase::kStarting:
      if (now - phase_since_ > timing_.boot_timeout) {
        fail(fmt::format("node {}: no operational heartbeat within {:.3f} s of NMT start", node_, timing_.boot_timeout));
      }
      return;
    case Phase::kFailed: return;
    case Phase::kCyclic: break;
  }
  if (enable && !enable_) enable_since_ = now;
  enable_ = enable;
  const DriveState s = state_.value_or(DriveState::kSwitchOnDisabled);
  // The reset request ends once the drive reports no fault (a fault reaction still ends in Fault).
  if (reset_requested_ && s != DriveState::kFault && s != DriveState::kFaultReactionActive && (controlword_ & kCwFaultReset) == 0) {
    reset_requested_ = false;
  }
  controlword_ = next_controlword(s, enable, reset_requested_, controlword_);
  const std::int16_t target = enable && enabled() ? scaling_.torque_to_drive(torque) : 0;
  CanFrame f;
  f.id = kRpdo1 + static_cast<std::uint32_t>(node_);
  f.len = 4;
  put_le(f, 0, controlword_, 2);
  put_le(f, 2, static_cast<std::uint16_t>(target), 2);
  out.push_back(f);
}

bool Cia402Master::on_frame(const CanFrame& f, double now) {
  const Cob c = classify(f);
  if (c.node != node_) return false;
  switch (c.function) {
    case Function::kTpdo: {
      if (c.pdo == 1) {
        if (f.len != 8) return false;
        const auto s = decode_statusword(static_cast<std::uint16_t>(get_le(f, 0, 2)));
        if (!s) return false;
        statusword_ = static_cast<std::uint16_t>(get_le(f, 0, 2));
        state_ = s;
        t_ = static_cast<std::int16_t>(static_cast<std::uint16_t>(get_le(f, 2, 2))) * scaling_.nm_per_permille();
        p_ = static_cast<std::int32_t>(static_cast<std::uint32_t>(get_le(f, 4, 4))) * scaling_.rad_per_count();
        rx_ |= 1;
        return true;
      }
      if (c.pdo == 2) {
        if (f.len != 4) return false;
        v_ = static_cast<std::int32_t>(static_cast<std::uint32_t>(get_le(f, 0, 4))) * scaling_.rad_s_per_unit();
        rx_ |= 2;
        return true;
      }
      return false;
    }
    case Function::kEmcy: {
      const auto e = decode_emergency(f, node_);
      if (!e) return false;
      if (e->code != 0) {
        latch(e->code, fmt::format("node {}: EMCY 0x{:04X} ({}), error register 0x{:02X}", node_, e->code, emergency_meaning(e->code),
                                   e->error_register));
      }
      return true;
    }
    case Function::kHeartbeat: {
      const auto s = decode_heartbeat(f, node_);
      if (!s) return false;
      last_heartbeat_ = now;
      nmt_ = s;
      if (*s == NmtState::kBootUp) {
        // A boot-up while booting or configuring (a drive powering up as it is reset) starts
        // the configuration over; once started, the drive has lost its configuration.
        if (phase_ == Phase::kBooting || phase_ == Phase::kIdentifying || phase_ == Phase::kConfiguring) {
          sdo_.reset();
          read_ = 0;
          read_sent_.reset();
          phase_ = Phase::kIdentifying;
          phase_since_ = now;
        } else if (phase_ != Phase::kReset && phase_ != Phase::kFailed) {
          latch(kFaultRestarted, fmt::format("node {}: the drive restarted (boot-up message) and lost its configuration", node_));
          phase_ = Phase::kFailed;
        }
      } else if (phase_ == Phase::kStarting && *s == NmtState::kOperational) {
        phase_ = Phase::kCyclic;
        state_.reset();
        controlword_ = 0;
        enable_ = false;
        was_enabled_ = false;
      } else if (phase_ == Phase::kCyclic && *s != NmtState::kOperational) {
        if (takes(kFaultNmtState)) latch(kFaultNmtState, fmt::format("node {}: heartbeat says {}, not operational", node_, canopen::to_string(*s)));
      }
      return true;
    }
    case Function::kSdoTx:
      if (phase_ == Phase::kIdentifying && read_sent_) {
        const auto m = decode_sdo(f, node_);
        if (!m) return false;
        judge(*m);
      } else if (sdo_) {
        sdo_->on_frame(f, now);
      }
      return true;
    default: return false;
  }
}

void Cia402Master::supervise(double now) {
  if (phase_ != Phase::kCyclic && phase_ != Phase::kStarting) return;
  if (timing_.heartbeat_ms > 0 && now - last_heartbeat_ > timing_.heartbeat_timeout) {
    if (takes(kFaultHeartbeat)) latch(kFaultHeartbeat, fmt::format("node {}: no heartbeat for {:.3f} s (producer time {} ms)", node_, now - last_heartbeat_,
                                       timing_.heartbeat_ms));
  }
  if (phase_ != Phase::kCyclic || !state_) return;
  const DriveState s = *state_;
  if ((s == DriveState::kFault || s == DriveState::kFaultReactionActive) && !reset_requested_) {
    if (takes(kFaultDriveState)) latch(kFaultDriveState, fmt::format("node {}: statusword 0x{:04X} reports {}", node_, statusword_, canopen::to_string(s)));
  }
  if (enable_ && was_enabled_ && !enabled()) {
    if (takes(kFaultDriveState)) latch(kFaultDriveState, fmt::format("node {}: left Operation enabled unasked, now {} (statusword 0x{:04X})", node_, canopen::to_string(s),
                                        statusword_));
  }
  if (enable_ && !enabled() && !was_enabled_ && now - enable_since_ > timing_.enable_timeout) {
    if (takes(kFaultEnable)) latch(kFaultEnable, fmt::format("node {}: not in Operation enabled {:.3f} s after the enable: {} (statusword 0x{:04X}, controlword 0x{:04X})",
                                    node_, now - enable_since_, canopen::to_string(s), statusword_, controlword_));
  }
  was_enabled_ = enable_ && enabled();
}

}  // namespace hpr::hal
