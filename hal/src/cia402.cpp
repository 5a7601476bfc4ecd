#include "hpr/hal/cia402.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hpr::hal {

using namespace canopen;

namespace {

std::uint16_t u16(const CanFrame& f, int at) {
  return static_cast<std::uint16_t>(f.data[static_cast<std::size_t>(at)] | (f.data[static_cast<std::size_t>(at + 1)] << 8));
}

std::uint32_t u32(const CanFrame& f, int at) {
  std::uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | f.data[static_cast<std::size_t>(at + k)];
  return v;
}

void put(CanFrame& f, int at, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) f.data[static_cast<std::size_t>(at + k)] = static_cast<std::uint8_t>((v >> (8 * k)) & 0xFF);
}

constexpr std::uint32_t kCobDisabled = 0x80000000U;

}  // namespace

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

void Cia402Master::latch(int code, std::string text) {
  const bool replace_own = fault_code_ == kFaultDriveState || fault_code_ == kFaultEnable;
  if (fault_code_ != 0 && !(replace_own && code < 0xFF00)) return;  // the first fault stays (an EMCY explains a state change)
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
        latch(kFaultStartUp, fmt::format("node {}: no boot-up message within {:.3f} s of NMT reset communication", node_, timing_.boot_timeout));
        phase_ = Phase::kFailed;
      }
      return;
    case Phase::kIdentifying:
      identify(now, out);
      return;
    case Phase::kConfiguring:
      if (const auto f = sdo_->poll(now)) out.push_back(*f);
      if (sdo_->failed()) {
        latch(kFaultStartUp, sdo_->error());
        phase_ = Phase::kFailed;
      } else if (sdo_->done()) {
        out.push_back(nmt(NmtCommand::kStart, node_));
        phase_ = Phase::kStarting;
        phase_since_ = now;
      }
      return;
    case Phase::kStarting:
      if (now - phase_since_ > timing_.boot_timeout) {
        latch(kFaultStartUp, fmt::format("node {}: no operational heartbeat within {:.3f} s of NMT start", node_, timing_.boot_timeout));
        phase_ = Phase::kFailed;
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
  put(f, 0, controlword_, 2);
  put(f, 2, static_cast<std::uint16_t>(target), 2);
  out.push_back(f);
}

bool Cia402Master::on_frame(const CanFrame& f, double now) {
  const Cob c = classify(f);
  if (c.node != node_) return false;
  switch (c.function) {
    case Function::kTpdo: {
      if (c.pdo == 1) {
        if (f.len != 8) return false;
        const auto s = decode_statusword(u16(f, 0));
        if (!s) return false;
        statusword_ = u16(f, 0);
        state_ = s;
        t_ = static_cast<std::int16_t>(u16(f, 2)) * scaling_.nm_per_permille();
        p_ = static_cast<std::int32_t>(u32(f, 4)) * scaling_.rad_per_count();
        rx_ |= 1;
        return true;
      }
      if (c.pdo == 2) {
        if (f.len != 4) return false;
        v_ = static_cast<std::int32_t>(u32(f, 0)) * scaling_.rad_s_per_unit();
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
        latch(kFaultNmtState, fmt::format("node {}: heartbeat says {}, not operational", node_, canopen::to_string(*s)));
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
    latch(kFaultHeartbeat, fmt::format("node {}: no heartbeat for {:.3f} s (producer time {} ms)", node_, now - last_heartbeat_,
                                       timing_.heartbeat_ms));
  }
  if (phase_ != Phase::kCyclic || !state_) return;
  const DriveState s = *state_;
  if ((s == DriveState::kFault || s == DriveState::kFaultReactionActive) && !reset_requested_) {
    latch(kFaultDriveState, fmt::format("node {}: statusword 0x{:04X} reports {}", node_, statusword_, canopen::to_string(s)));
  }
  if (enable_ && was_enabled_ && !enabled()) {
    latch(kFaultDriveState, fmt::format("node {}: left Operation enabled unasked, now {} (statusword 0x{:04X})", node_, canopen::to_string(s),
                                        statusword_));
  }
  if (enable_ && !enabled() && !was_enabled_ && now - enable_since_ > timing_.enable_timeout) {
    latch(kFaultEnable, fmt::format("node {}: not in Operation enabled {:.3f} s after the enable: {} (statusword 0x{:04X}, controlword 0x{:04X})",
                                    node_, now - enable_since_, canopen::to_string(s), statusword_, controlword_));
  }
  was_enabled_ = enable_ && enabled();
}

// ---------------------------------------------------------------------------------------------
// Device
// ---------------------------------------------------------------------------------------------

namespace {

std::string var(const std::string& section, const std::string& name, const char* type, const char* access, const std::string& value,
                bool mappable = false) {
  return fmt::format("[{}]\nParameterName={}\nObjectType=0x7\nDataType={}\nAccessType={}\nDefaultValue={}\nPDOMapping={}\n\n", section, name,
                     type, access, value, mappable ? 1 : 0);
}

std::string record(const std::string& index, const std::string& name, int subs) {
  return fmt::format("[{}]\nParameterName={}\nObjectType=0x9\nSubNumber={}\n\n", index, name, subs);
}

}  // namespace

std::string Cia402Device::default_eds(std::uint32_t rated_torque_mnm) {
  std::string e =
      "; A CiA 402 servo drive as the drive emulator presents it: cyclic synchronous position, velocity\n"
      "; and torque (0x6502), three PDOs with dynamic mapping, heartbeat producer.\n"
      "[FileInfo]\nFileName=hpr_emulated_drive.eds\nFileVersion=1\nDescription=hpr drive emulator, CiA 402\n\n"
      "[DeviceInfo]\nVendorName=hpr\nProductName=Emulated CiA 402 drive\n\n";
  e += var("1000", "Device type", "0x0007", "ro", "0x00020192") + var("1001", "Error register", "0x0005", "ro", "0", true) +
       var("1017", "Producer heartbeat time", "0x0006", "rw", "0");
  e += record("1018", "Identity object", 2) + var("1018sub0", "Highest sub-index supported", "0x0005", "const", "1") +
       var("1018sub1", "Vendor-ID", "0x0007", "ro", "0");
  const struct {
    const char *comm, *map, *cob, *name;
  } pdos[] = {{"1400", "1600", "$NODEID+0x200", "RPDO1"}, {"1800", "1A00", "$NODEID+0x180", "TPDO1"}, {"1801", "1A01", "$NODEID+0x280", "TPDO2"}};
  for (const auto& p : pdos) {
    e += record(p.comm, std::string(p.name) + " communication parameter", 3) +
         var(std::string(p.comm) + "sub0", "Highest sub-index supported", "0x0005", "const", "2") +
         var(std::string(p.comm) + "sub1", "COB-ID", "0x0007", "rw", p.cob) +
         var(std::string(p.comm) + "sub2", "Transmission type", "0x0005", "rw", "255");
    e += record(p.map, std::string(p.name) + " mapping parameter", 5) +
         var(std::string(p.map) + "sub0", "Number of mapped objects", "0x0005", "rw", "0");
    for (int k = 1; k <= 4; ++k) e += var(std::string(p.map) + "sub" + std::to_string(k), fmt::format("Mapped object {}", k), "0x0007", "rw", "0");
  }
  e += var("6040", "Controlword", "0x0006", "rww", "0", true) + var("6041", "Statusword", "0x0006", "ro", "0", true) +
       var("6060", "Modes of operation", "0x0002", "rw", "0", true) + var("6061", "Modes of operation display", "0x0002", "ro", "0", true) +
       var("6064", "Position actual value", "0x0004", "ro", "0", true) + var("606C", "Velocity actual value", "0x0004", "ro", "0", true) +
       var("6071", "Target torque", "0x0003", "rww", "0", true) + var("6076", "Motor rated torque", "0x0007", "rw", std::to_string(rated_torque_mnm)) +
       var("6077", "Torque actual value", "0x0003", "ro", "0", true) + var("6502", "Supported drive modes", "0x0007", "ro", "0x00000380");
  return e;
}

Cia402Device::Cia402Device(int node, const ObjectDictionary& od) : node_(node), od_(&od), sdo_(node, od) {}

void Cia402Device::power_on(std::vector<CanFrame>& out) {
  if (booted_) return;
  booted_ = true;
  nmt_ = NmtState::kPreOperational;
  out.push_back(heartbeat(node_, NmtState::kBootUp));
}

void Cia402Device::reset(bool communication_only, std::vector<CanFrame>& out) {
  for (const auto& [address, e] : od_->entries()) {
    if (communication_only && (address.first < 0x1000 || address.first > 0x1FFF)) continue;
    if (const auto v = od_->value(address.first, address.second, node_)) sdo_.set(address.first, address.second, *v);
  }
  if (!communication_only) {
    sm_ = DriveStateMachine{};
    error_ = 0;
  }
  rpdo_pending_ = false;
  applied_torque_ = 0;
  booted_ = false;
  power_on(out);
}

std::optional<std::uint32_t> Cia402Device::cob(std::uint16_t comm) const {
  const auto v = sdo_.value(comm, 1);
  if (!v || (*v & kCobDisabled) != 0) return std::nullopt;
  return static_cast<std::uint32_t>(*v & 0x7FF);
}

void Cia402Device::receive_rpdo(const CanFrame& f, double now, std::vector<CanFrame>& out) {
  const int count = static_cast<int>(sdo_.value(0x1600, 0).value_or(0));
  int at = 0;
  for (int k = 1; k <= count; ++k) at += static_cast<int>(sdo_.value(0x1600, static_cast<std::uint8_t>(k)).value_or(0) & 0xFF) / 8;
  if (at != f.len) {
    Emergency e{0x8210, 0x10};  // PDO not processed due to length error; communication error bit
    out.push_back(emergency(node_, e));
    return;
  }
  at = 0;
  for (int k = 1; k <= count; ++k) {
    const std::uint32_t m = static_cast<std::uint32_t>(sdo_.value(0x1600, static_cast<std::uint8_t>(k)).value_or(0));
    const int bytes = static_cast<int>(m & 0xFF) / 8;
    std::uint64_t v = 0;
    for (int b = bytes - 1; b >= 0; --b) v = (v << 8) | f.data[static_cast<std::size_t>(at + b)];
    sdo_.set(static_cast<std::uint16_t>(m >> 16), static_cast<std::uint8_t>((m >> 8) & 0xFF), v);
    at += bytes;
  }
  rpdo_pending_ = true;
  last_rpdo_ = now;
}

void Cia402Device::send_tpdo(std::uint16_t comm, std::uint16_t map, std::vector<CanFrame>& out) {
  const auto id = cob(comm);
  if (!id) return;
  const auto type = sdo_.value(comm, 2).value_or(255);
  if (type == 0 || type > 240 || syncs_ % static_cast<std::int64_t>(type) != 0) return;
  CanFrame f;
  f.id = *id;
  const int count = static_cast<int>(sdo_.value(map, 0).value_or(0));
  int at = 0;
  for (int k = 1; k <= count; ++k) {
    const std::uint32_t m = static_cast<std::uint32_t>(sdo_.value(map, static_cast<std::uint8_t>(k)).value_or(0));
    const int bytes = static_cast<int>(m & 0xFF) / 8;
    if (at + bytes > 8) break;
    put(f, at, sdo_.value(static_cast<std::uint16_t>(m >> 16), static_cast<std::uint8_t>((m >> 8) & 0xFF)).value_or(0), bytes);
    at += bytes;
  }
  f.len = static_cast<std::uint8_t>(at);
  out.push_back(f);
}

void Cia402Device::on_frame(const CanFrame& f, double now, std::vector<CanFrame>& out) {
  const Cob c = classify(f);
  switch (c.function) {
    case Function::kNmt: {
      if (f.len != 2 || (f.data[1] != 0 && f.data[1] != node_)) return;
      switch (static_cast<NmtCommand>(f.data[0])) {
        case NmtCommand::kStart: nmt_ = NmtState::kOperational; break;
        case NmtCommand::kStop: nmt_ = NmtState::kStopped; break;
        case NmtCommand::kPreOperational: nmt_ = NmtState::kPreOperational; break;
        case NmtCommand::kResetNode: reset(false, out); break;
        case NmtCommand::kResetCommunication: reset(true, out); break;
      }
      return;
    }
    case Function::kSync: {
      if (nmt_ != NmtState::kOperational) return;
      ++syncs_;
      if (rpdo_pending_) {
        if (sm_.apply(static_cast<std::uint16_t>(sdo_.value(kControlword, 0).value_or(0))) == 15) {  // fault reset
          error_ = 0;
          sdo_.set(kErrorRegister, 0, 0);
          out.push_back(emergency(node_, Emergency{0, 0}));
        }
        applied_torque_ = static_cast<std::int16_t>(sdo_.value(kTargetTorque, 0).value_or(0));
        rpdo_pending_ = false;
      }
      sdo_.set(kModesOfOperationDisplay, 0, sdo_.value(kModesOfOperation, 0).value_or(0));
      sdo_.set(kStatusword, 0, sm_.statusword(kStatusRemote | (sm_.state() >= DriveState::kReadyToSwitchOn ? kStatusVoltageEnabled : 0)));
      send_tpdo(0x1800, 0x1A00, out);
      send_tpdo(0x1801, 0x1A01, out);
      return;
    }
    case Function::kRpdo:
      if (nmt_ == NmtState::kOperational && c.node == node_ && cob(0x1400) == (f.id & kCanSffMask)) receive_rpdo(f, now, out);
      return;
    case Function::kSdoRx:
      if (c.node != node_ || nmt_ == NmtState::kStopped) return;
      if (const auto a = sdo_.on_frame(f)) out.push_back(*a);
      return;
    default: return;
  }
}

void Cia402Device::periodic(double now, double rpdo_timeout, std::vector<CanFrame>& out) {
  sm_.tick();
  const auto hb_ms = sdo_.value(0x1017, 0).value_or(0);
  if (hb_ms > 0 && now - last_heartbeat_ >= static_cast<double>(hb_ms) * 1e-3 - 1e-9) {
    out.push_back(heartbeat(node_, nmt_));
    last_heartbeat_ = now;
  }
  if (sm_.enabled() && now - last_rpdo_ > rpdo_timeout) fault(kRpdoTimeout, out);
}

void Cia402Device::fault(std::uint16_t code, std::vector<CanFrame>& out) {
  if (fault_reaction() && error_ == code) return;
  error_ = code;
  sdo_.set(kErrorRegister, 0, 0x01);
  out.push_back(emergency(node_, Emergency{code, 0x01}));
  sm_.fault();
}

void Cia402Device::set_actual(std::int32_t position, std::int32_t velocity, std::int16_t torque) {
  sdo_.set(kPositionActual, 0, static_cast<std::uint32_t>(position));
  sdo_.set(kVelocityActual, 0, static_cast<std::uint32_t>(velocity));
  sdo_.set(kTorqueActual, 0, static_cast<std::uint16_t>(torque));
}

std::int16_t Cia402Device::target_torque() const {
  const bool cst = static_cast<std::int8_t>(sdo_.value(kModesOfOperation, 0).value_or(0)) == kModeCyclicSyncTorque;
  return sm_.enabled() && cst ? applied_torque_ : 0;
}

bool Cia402Device::fault_reaction() const {
  return sm_.state() == DriveState::kFaultReactionActive || sm_.state() == DriveState::kFault;
}

}  // namespace hpr::hal
