#include "hpr/hal/canopen.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace hpr::hal::canopen {

namespace {

CanFrame frame(std::uint32_t id, std::uint8_t len) {
  CanFrame f;
  f.id = id;
  f.len = len;
  return f;
}

bool valid_node(int node) { return node >= 1 && node <= kMaxNode; }

/// An SDO frame: command byte, index, subindex, 4 data bytes (little-endian).
CanFrame sdo(std::uint32_t base, int node, std::uint8_t command, SdoAddress a, std::uint32_t value) {
  CanFrame f = frame(base + static_cast<std::uint32_t>(node), 8);
  f.data[0] = command;
  put_le(f, 1, a.index, 2);
  f.data[3] = a.subindex;
  for (int k = 0; k < 4; ++k) f.data[static_cast<size_t>(4 + k)] = static_cast<std::uint8_t>((value >> (8 * k)) & 0xFF);
  return f;
}

/// `value` cut to `size` bytes.
std::uint32_t masked(std::uint32_t value, int size) { return size >= 4 ? value : value & ((1U << (8 * size)) - 1U); }

}  // namespace

std::uint64_t get_le(const CanFrame& f, int at, int bytes) {
  std::uint64_t v = 0;
  for (int k = bytes - 1; k >= 0; --k) v = (v << 8) | f.data[static_cast<std::size_t>(at + k)];
  return v;
}

void put_le(CanFrame& f, int at, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) f.data[static_cast<std::size_t>(at + k)] = static_cast<std::uint8_t>((v >> (8 * k)) & 0xFF);
}

Cob classify(const CanFrame& f) {
  Cob c;
  if ((f.id & (kCanEffFlag | kCanRtrFlag | kCanErrFlag)) != 0) return c;
  const std::uint32_t id = f.id & kCanSffMask;
  if (id == kNmtId) {
    c.function = Function::kNmt;
    return c;
  }
  if (id == kSyncId) {
    c.function = Function::kSync;
    return c;
  }
  const std::uint32_t fn = id & 0x780;
  c.node = static_cast<int>(id & 0x7F);
  if (c.node == 0) return Cob{};
  switch (fn) {
    case kEmcyBase: c.function = Function::kEmcy; break;
    case kTpdo1: case kTpdo2: case kTpdo3: case kTpdo4:
      c.function = Function::kTpdo;
      c.pdo = static_cast<int>((fn - kTpdo1) / 0x100) + 1;
      break;
    case kRpdo1: case kRpdo2: case kRpdo3: case kRpdo4:
      c.function = Function::kRpdo;
      c.pdo = static_cast<int>((fn - kRpdo1) / 0x100) + 1;
      break;
    case kSdoTxBase: c.function = Function::kSdoTx; break;
    case kSdoRxBase: c.function = Function::kSdoRx; break;
    case kHeartbeatBase: c.function = Function::kHeartbeat; break;
    default: return Cob{};
  }
  return c;
}

CanFrame nmt(NmtCommand c, int node) {
  CanFrame f = frame(kNmtId, 2);
  f.data[0] = static_cast<std::uint8_t>(c);
  f.data[1] = static_cast<std::uint8_t>(node);
  return f;
}

CanFrame sync_frame() { return frame(kSyncId, 0); }

CanFrame heartbeat(int node, NmtState s) {
  CanFrame f = frame(kHeartbeatBase + static_cast<std::uint32_t>(node), 1);
  f.data[0] = static_cast<std::uint8_t>(s);
  return f;
}

std::optional<NmtState> decode_heartbeat(const CanFrame& f, int node) {
  if (!valid_node(node) || f.id != kHeartbeatBase + static_cast<std::uint32_t>(node) || f.len != 1) return std::nullopt;
  switch (f.data[0] & 0x7F) {  // bit 7: the node-guarding toggle bit
    case 0x00: return NmtState::kBootUp;
    case 0x04: return NmtState::kStopped;
    case 0x05: return NmtState::kOperational;
    case 0x7F: return NmtState::kPreOperational;
    default: return std::nullopt;
  }
}

const char* to_string(NmtState s) {
  switch (s) {
    case NmtState::kBootUp: return "boot-up";
    case NmtState::kStopped: return "stopped";
    case NmtState::kOperational: return "operational";
    case NmtState::kPreOperational: return "pre-operational";
  }
  return "?";
}

CanFrame sdo_download(int node, SdoAddress a, std::uint32_t value, int size) {
  // ccs 1, n = 4 - size unused bytes, e (expedited), s (size indicated).
  const int n = 4 - std::clamp(size, 1, 4);
  return sdo(kSdoRxBase, node, static_cast<std::uint8_t>(0x20 | (n << 2) | 0x03), a, masked(value, 4 - n));
}

CanFrame sdo_upload(int node, SdoAddress a) { return sdo(kSdoRxBase, node, 0x40, a, 0); }

CanFrame sdo_download_done(int node, SdoAddress a) { return sdo(kSdoTxBase, node, 0x60, a, 0); }

CanFrame sdo_upload_data(int node, SdoAddress a, std::uint32_t value, int size) {
  const int n = 4 - std::clamp(size, 1, 4);
  return sdo(kSdoTxBase, node, static_cast<std::uint8_t>(0x40 | (n << 2) | 0x03), a, masked(value, 4 - n));
}

CanFrame sdo_abort(int node, SdoAddress a, std::uint32_t code, bool from_server) {
  return sdo(from_server ? kSdoTxBase : kSdoRxBase, node, 0x80, a, code);
}

std::optional<SdoMessage> decode_sdo(const CanFrame& f, int node) {
  if (!valid_node(node) || f.len != 8) return std::nullopt;
  const bool to_server = f.id == kSdoRxBase + static_cast<std::uint32_t>(node);
  const bool to_client = f.id == kSdoTxBase + static_cast<std::uint32_t>(node);
  if (!to_server && !to_client) return std::nullopt;
  SdoMessage m;
  const std::uint8_t cmd = f.data[0];
  m.address = {static_cast<std::uint16_t>(get_le(f, 1, 2)), f.data[3]};
  const auto data = static_cast<std::uint32_t>(get_le(f, 4, 4));
  const bool expedited = (cmd & 0x02) != 0, size_indicated = (cmd & 0x01) != 0;
  const int size = size_indicated ? 4 - ((cmd >> 2) & 0x03) : 0;
  switch (cmd >> 5) {
    case 4:  // abort, either way
      if (cmd != 0x80) return std::nullopt;
      m.kind = SdoMessage::Kind::kAbort;
      m.value = data;
      return m;
    case 1:  // client: initiate download
      if (!to_server || !expedited) return std::nullopt;
      m.kind = SdoMessage::Kind::kDownloadRequest;
      m.size = size;
      m.value = size > 0 ? masked(data, size) : data;
      return m;
    case 2:  // client: initiate upload; server: initiate upload response
      if (to_server) {
        if (cmd != 0x40) return std::nullopt;
        m.kind = SdoMessage::Kind::kUploadRequest;
        return m;
      }
      if (!expedited) return std::nullopt;  // segmented upload: not used here
      m.kind = SdoMessage::Kind::kUploadData;
      m.size = size;
      m.value = size > 0 ? masked(data, size) : data;
      return m;
    case 3:  // server: initiate download response
      if (!to_client || cmd != 0x60) return std::nullopt;
      m.kind = SdoMessage::Kind::kDownloadDone;
      return m;
    default: return std::nullopt;
  }
}

const char* sdo_abort_meaning(std::uint32_t code) {
  switch (code) {
    case 0x05030000: return "toggle bit not alternated";
    case 0x05040000: return "SDO protocol timed out";
    case 0x05040001: return "client/server command specifier not valid or unknown";
    case 0x05040002: return "invalid block size";
    case 0x05040003: return "invalid sequence number";
    case 0x05040004: return "CRC error";
    case 0x05040005: return "out of memory";
    case 0x06010000: return "unsupported access to an object";
    case 0x06010001: return "attempt to read a write-only object";
    case 0x06010002: return "attempt to write a read-only object";
    case 0x06020000: return "object does not exist in the object dictionary";
    case 0x06040041: return "object cannot be mapped to the PDO";
    case 0x06040042: return "the number and length of the objects to be mapped would exceed the PDO length";
    case 0x06040043: return "general parameter incompatibility";
    case 0x06040047: return "general internal incompatibility in the device";
    case 0x06060000: return "access failed due to a hardware error";
    case 0x06070010: return "data type does not match, length of service parameter does not match";
    case 0x06070012: return "data type does not match, length of service parameter too high";
    case 0x06070013: return "data type does not match, length of service parameter too low";
    case 0x06090011: return "sub-index does not exist";
    case 0x06090030: return "invalid value for parameter (download only)";
    case 0x06090031: return "value of parameter written too high (download only)";
    case 0x06090032: return "value of parameter written too low (download only)";
    case 0x06090036: return "maximum value is less than minimum value";
    case 0x060A0023: return "resource not available: SDO connection";
    case 0x08000000: return "general error";
    case 0x08000020: return "data cannot be transferred or stored to the application";
    case 0x08000021: return "data cannot be transferred or stored to the application because of local control";
    case 0x08000022: return "data cannot be transferred or stored to the application because of the present device state";
    case 0x08000023: return "object dictionary dynamic generation fails or no object dictionary is present";
    case 0x08000024: return "no data available";
    default: return "unknown abort code";
  }
}

CanFrame emergency(int node, Emergency e) {
  CanFrame f = frame(kEmcyBase + static_cast<std::uint32_t>(node), 8);
  put_le(f, 0, e.code, 2);
  f.data[2] = e.error_register;
  return f;
}

std::optional<Emergency> decode_emergency(const CanFrame& f, int node) {
  if (!valid_node(node) || f.id != kEmcyBase + static_cast<std::uint32_t>(node) || f.len != 8) return std::nullopt;
  return Emergency{static_cast<std::uint16_t>(get_le(f, 0, 2)), f.data[2]};
}

std::string emergency_meaning(std::uint16_t code) {
  const auto hi = static_cast<std::uint8_t>(code >> 8);
  const char* what = nullptr;
  switch (hi) {
    case 0x00: return code == 0 ? "no error (error reset)" : fmt::format("error code 0x{:04X}", code);
    case 0x10: what = "generic error"; break;
    case 0x20: what = "current"; break;
    case 0x21: what = "current, device input side"; break;
    case 0x22: what = "current inside the device"; break;
    case 0x23: what = "current, device output side"; break;
    case 0x30: what = "voltage"; break;
    case 0x31: what = "mains voltage"; break;
    case 0x32: what = "voltage inside the device"; break;
    case 0x33: what = "output voltage"; break;
    case 0x40: what = "temperature"; break;
    case 0x41: what = "ambient temperature"; break;
    case 0x42: what = "device temperature"; break;
    case 0x50: what = "device hardware"; break;
    case 0x60: what = "device software"; break;
    case 0x61: what = "internal software"; break;
    case 0x62: what = "user software"; break;
    case 0x63: what = "data set"; break;
    case 0x70: what = "additional modules"; break;
    case 0x80: what = "monitoring"; break;
    case 0x81:
      switch (code) {
        case 0x8110: what = "communication: CAN overrun (objects lost)"; break;
        case 0x8120: what = "communication: CAN in error passive mode"; break;
        case 0x8130: what = "communication: life guard or heartbeat error"; break;
        case 0x8140: what = "communication: recovered from bus off"; break;
        case 0x8150: what = "communication: CAN-ID collision"; break;
        default: what = "communication"; break;
      }
      break;
    case 0x82:
      switch (code) {
        case 0x8210: what = "protocol: PDO not processed due to length error"; break;
        case 0x8220: what = "protocol: PDO length exceeded"; break;
        default: what = "protocol error"; break;
      }
      break;
    case 0x90: what = "external error"; break;
    case 0xF0: what = "additional functions"; break;
    case 0xFF: what = "device specific"; break;
    default: break;
  }
  if (what == nullptr) {
    // The classes with a sub-class in the low nibble of the high byte (0x5xxx, 0x7xxx ...).
    switch (hi >> 4) {
      case 0x5: what = "device hardware"; break;
      case 0x7: what = "additional modules"; break;
      case 0x8: what = "monitoring"; break;
      default: what = "reserved error class"; break;
    }
  }
  return fmt::format("{} (0x{:04X})", what, code);
}

const char* to_string(DriveState s) {
  switch (s) {
    case DriveState::kNotReadyToSwitchOn: return "not ready to switch on";
    case DriveState::kSwitchOnDisabled: return "switch on disabled";
    case DriveState::kReadyToSwitchOn: return "ready to switch on";
    case DriveState::kSwitchedOn: return "switched on";
    case DriveState::kOperationEnabled: return "operation enabled";
    case DriveState::kQuickStopActive: return "quick stop active";
    case DriveState::kFaultReactionActive: return "fault reaction active";
    case DriveState::kFault: return "fault";
  }
  return "?";
}

std::optional<DriveState> decode_statusword(std::uint16_t sw) {
  switch (sw & 0x4F) {
    case 0x00: return DriveState::kNotReadyToSwitchOn;
    case 0x40: return DriveState::kSwitchOnDisabled;
    case 0x0F: return DriveState::kFaultReactionActive;
    case 0x08: return DriveState::kFault;
    default: break;
  }
  switch (sw & 0x6F) {
    case 0x21: return DriveState::kReadyToSwitchOn;
    case 0x23: return DriveState::kSwitchedOn;
    case 0x27: return DriveState::kOperationEnabled;
    case 0x07: return DriveState::kQuickStopActive;
    default: return std::nullopt;
  }
}

std::uint16_t next_controlword(DriveState s, bool enable, bool fault_reset, std::uint16_t previous) {
  if (s == DriveState::kFault) {
    if (!fault_reset) return kCwDisableVoltage;
    // The reset is the rising edge of bit 7: drop it first if it was already up.
    return (previous & kCwFaultReset) != 0 ? kCwDisableVoltage : kCwFaultReset;
  }
  if (!enable) return kCwDisableVoltage;
  switch (s) {
    case DriveState::kSwitchOnDisabled: return kCwShutdown;
    case DriveState::kReadyToSwitchOn: return kCwSwitchOn;
    case DriveState::kSwitchedOn:
    case DriveState::kOperationEnabled: return kCwEnableOperation;
    // After a quick stop the drive goes limp and comes back only through switch on disabled.
    case DriveState::kQuickStopActive:
    case DriveState::kNotReadyToSwitchOn:
    case DriveState::kFaultReactionActive:
    case DriveState::kFault: return kCwDisableVoltage;
  }
  return kCwDisableVoltage;
}

namespace {

/// The command a controlword's low bits select (bit 7 apart).
enum class Command { kDisableVoltage, kQuickStop, kShutdown, kSwitchOn, kEnableOperation };

Command command_of(std::uint16_t cw) {
  if ((cw & 0x02) == 0) return Command::kDisableVoltage;  // xx0x
  if ((cw & 0x04) == 0) return Command::kQuickStop;       // x01x
  if ((cw & 0x01) == 0) return Command::kShutdown;        // x110
  return (cw & 0x08) != 0 ? Command::kEnableOperation : Command::kSwitchOn;  // 1111 / 0111
}

}  // namespace

int DriveStateMachine::apply(std::uint16_t cw) {
  const bool reset_bit = (cw & kCwFaultReset) != 0, edge = reset_bit && !fault_reset_bit_;
  fault_reset_bit_ = reset_bit;
  using S = DriveState;
  if (state_ == S::kFault) {
    if (!edge) return 0;
    state_ = S::kSwitchOnDisabled;
    return 15;
  }
  if (reset_bit) return 0;  // bit 7 outside a fault selects no command
  const Command c = command_of(cw);
  switch (state_) {
    case S::kSwitchOnDisabled:
      if (c == Command::kShutdown) { state_ = S::kReadyToSwitchOn; return 2; }
      return 0;
    case S::kReadyToSwitchOn:
      if (c == Command::kSwitchOn || c == Command::kEnableOperation) { state_ = S::kSwitchedOn; return 3; }
      if (c == Command::kDisableVoltage || c == Command::kQuickStop) { state_ = S::kSwitchOnDisabled; return 7; }
      return 0;
    case S::kSwitchedOn:
      if (c == Command::kEnableOperation) { state_ = S::kOperationEnabled; return 4; }
      if (c == Command::kShutdown) { state_ = S::kReadyToSwitchOn; return 6; }
      if (c == Command::kDisableVoltage || c == Command::kQuickStop) { state_ = S::kSwitchOnDisabled; return 10; }
      return 0;
    case S::kOperationEnabled:
      if (c == Command::kSwitchOn) { state_ = S::kSwitchedOn; return 5; }
      if (c == Command::kShutdown) { state_ = S::kReadyToSwitchOn; return 8; }
      if (c == Command::kDisableVoltage) { state_ = S::kSwitchOnDisabled; return 9; }
      if (c == Command::kQuickStop) { state_ = S::kQuickStopActive; return 11; }
      return 0;
    case S::kQuickStopActive:
      if (c == Command::kDisableVoltage) { state_ = S::kSwitchOnDisabled; return 12; }
      if (c == Command::kEnableOperation) { state_ = S::kOperationEnabled; return 16; }
      return 0;
    case S::kNotReadyToSwitchOn:
    case S::kFaultReactionActive:
    case S::kFault: return 0;
  }
  return 0;
}

void DriveStateMachine::fault() {
  if (state_ != DriveState::kFault) state_ = DriveState::kFaultReactionActive;
}

void DriveStateMachine::tick() {
  if (state_ == DriveState::kNotReadyToSwitchOn) state_ = DriveState::kSwitchOnDisabled;
  else if (state_ == DriveState::kFaultReactionActive) state_ = DriveState::kFault;
}

std::uint16_t DriveStateMachine::statusword(std::uint16_t extra) const {
  std::uint16_t sw = 0;
  switch (state_) {
    case DriveState::kNotReadyToSwitchOn: sw = 0x0000; break;
    case DriveState::kSwitchOnDisabled: sw = 0x0040; break;
    case DriveState::kReadyToSwitchOn: sw = 0x0021; break;
    case DriveState::kSwitchedOn: sw = 0x0023; break;
    case DriveState::kOperationEnabled: sw = 0x0027; break;
    case DriveState::kQuickStopActive: sw = 0x0007; break;
    case DriveState::kFaultReactionActive: sw = 0x000F; break;
    case DriveState::kFault: sw = 0x0008; break;
  }
  // The extra bits may not touch the state's own (0-3, 5, 6).
  return static_cast<std::uint16_t>(sw | (extra & ~0x006FU));
}

}  // namespace hpr::hal::canopen
