/// \file
/// The CiA 402 device: a drive as the emulator presents it (and the tests' drive).
#include "hpr/hal/cia402.hpp"

#include <fmt/format.h>

namespace hpr::hal {

using namespace canopen;

namespace {

constexpr std::uint32_t kCobDisabled = 0x80000000U;  ///< COB-ID bit 31: the PDO does not exist

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
      "; A CiA 402 servo drive as the drive emulator presents it: cyclic synchronous position and torque\n"
      "; (0x6502), three PDOs with dynamic mapping, heartbeat producer.\n"
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
       var("6077", "Torque actual value", "0x0003", "ro", "0", true) + var("607A", "Target position", "0x0004", "rww", "0", true) +
       var("6502", "Supported drive modes", "0x0007", "ro", "0x00000280");
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
  applied_position_ = 0;
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
    put_le(f, at, sdo_.value(static_cast<std::uint16_t>(m >> 16), static_cast<std::uint8_t>((m >> 8) & 0xFF)).value_or(0), bytes);
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
        applied_position_ = static_cast<std::int32_t>(static_cast<std::uint32_t>(sdo_.value(kTargetPosition, 0).value_or(0)));
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

std::optional<std::int32_t> Cia402Device::target_position() const {
  const bool csp = static_cast<std::int8_t>(sdo_.value(kModesOfOperation, 0).value_or(0)) == kModeCyclicSyncPosition;
  if (!sm_.enabled() || !csp) return std::nullopt;
  return applied_position_;
}

bool Cia402Device::fault_reaction() const {
  return sm_.state() == DriveState::kFaultReactionActive || sm_.state() == DriveState::kFault;
}

}  // namespace hpr::hal
