#pragma once
/// \file
/// CANopen (CiA 301) frames and the CiA 402 drive state machine, as pure functions on CanFrame:
/// the identifiers of the predefined connection set, NMT, heartbeat, expedited SDO transfers and
/// their abort codes, EMCY, and the power drive system's states read from the statusword (0x6041)
/// and driven by the controlword (0x6040). Both ends are here: the master (the hal) reads states
/// and chooses the next controlword; the device (the drive emulator) applies a controlword and
/// reports its statusword. Nothing here keeps time or talks to a bus.
#include <cstdint>
#include <optional>
#include <string>

#include "hpr/hal/can.hpp"

namespace hpr::hal::canopen {

// Predefined connection set (CiA 301 §7.3.3): function code + node id (1..127).
inline constexpr std::uint32_t kNmtId = 0x000, kSyncId = 0x080, kEmcyBase = 0x080, kTpdo1 = 0x180, kRpdo1 = 0x200,
                               kTpdo2 = 0x280, kRpdo2 = 0x300, kTpdo3 = 0x380, kRpdo3 = 0x400, kTpdo4 = 0x480,
                               kRpdo4 = 0x500, kSdoTxBase = 0x580, kSdoRxBase = 0x600, kHeartbeatBase = 0x700;
inline constexpr int kMaxNode = 127;

/// Little-endian fields of a payload (CANopen's byte order), `bytes` of 1..8 from byte `at`.
std::uint64_t get_le(const CanFrame& f, int at, int bytes);
void put_le(CanFrame& f, int at, std::uint64_t v, int bytes);

/// What a standard identifier carries, from the predefined connection set.
enum class Function { kNmt, kSync, kEmcy, kTpdo, kRpdo, kSdoTx, kSdoRx, kHeartbeat, kOther };
struct Cob {
  Function function = Function::kOther;
  int node = 0;  ///< 1..127 (0 for NMT and SYNC)
  int pdo = 0;   ///< 1..4 for a PDO
};
/// The function and node of a frame's identifier (extended or RTR frames are kOther).
Cob classify(const CanFrame& f);

// NMT (CiA 301 §7.2.8.3.1): [command specifier, node id (0: every node)].
enum class NmtCommand : std::uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82
};
CanFrame nmt(NmtCommand c, int node);
CanFrame sync_frame();

/// The NMT state a heartbeat (or boot-up) message reports (CiA 301 §7.2.8.3.2.1).
enum class NmtState : std::uint8_t { kBootUp = 0x00, kStopped = 0x04, kOperational = 0x05, kPreOperational = 0x7F };
CanFrame heartbeat(int node, NmtState s);
/// The state of a heartbeat frame; nullopt when the frame is not one (length, identifier, value).
std::optional<NmtState> decode_heartbeat(const CanFrame& f, int node);
const char* to_string(NmtState s);

// SDO, expedited transfers of up to 4 bytes (CiA 301 §7.2.4.3).
struct SdoAddress {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
};
/// Client → server: write `size` (1..4) bytes of `value` (little-endian) to the object.
CanFrame sdo_download(int node, SdoAddress a, std::uint32_t value, int size);
/// Client → server: read the object.
CanFrame sdo_upload(int node, SdoAddress a);
/// What a server's answer (or a client's request, on the device side) says.
struct SdoMessage {
  enum class Kind { kDownloadRequest, kDownloadDone, kUploadRequest, kUploadData, kAbort } kind = Kind::kAbort;
  SdoAddress address;
  std::uint32_t value = 0;  ///< the data, or the abort code
  int size = 0;             ///< bytes of data (expedited), 0 when not indicated
};
/// Decodes an SDO frame (either direction) of `node`; nullopt when the frame is not an 8-byte SDO of
/// that node or uses a segmented or block transfer (not supported: every object used is ≤ 4 bytes).
std::optional<SdoMessage> decode_sdo(const CanFrame& f, int node);
/// Server → client answers.
CanFrame sdo_download_done(int node, SdoAddress a);
CanFrame sdo_upload_data(int node, SdoAddress a, std::uint32_t value, int size);
CanFrame sdo_abort(int node, SdoAddress a, std::uint32_t code, bool from_server = true);
/// The meaning of an SDO abort code (CiA 301 table 22), or "unknown abort code".
const char* sdo_abort_meaning(std::uint32_t code);
/// Abort codes a server sends.
inline constexpr std::uint32_t kAbortUnsupportedAccess = 0x06010000, kAbortWriteOnly = 0x06010001,
                               kAbortReadOnly = 0x06010002, kAbortNoObject = 0x06020000,
                               kAbortLengthMismatch = 0x06070010, kAbortNoSubindex = 0x06090011,
                               kAbortInvalidValue = 0x06090030, kAbortDeviceState = 0x08000022,
                               kAbortCommandSpecifier = 0x05040001;

// EMCY (CiA 301 §7.2.7): error code (16 bits), error register (0x1001), 5 manufacturer bytes.
struct Emergency {
  std::uint16_t code = 0;
  std::uint8_t error_register = 0;
};
CanFrame emergency(int node, Emergency e);
std::optional<Emergency> decode_emergency(const CanFrame& f, int node);
/// The class of an emergency error code (CiA 301 table 21; CiA 402's drive codes within it), e.g.
/// "current, device output side" for 0x23xx, "no error" for 0x0000 (an error reset).
std::string emergency_meaning(std::uint16_t code);

// CiA 402 (IEC 61800-7-201) power drive system.
inline constexpr std::uint16_t kControlword = 0x6040, kStatusword = 0x6041, kModesOfOperation = 0x6060,
                               kModesOfOperationDisplay = 0x6061, kPositionActual = 0x6064,
                               kVelocityActual = 0x606C, kTargetTorque = 0x6071, kTorqueActual = 0x6077,
                               kRatedTorque = 0x6076, kTargetPosition = 0x607A, kTorqueOffset = 0x60B2,
                               kSupportedModes = 0x6502, kDeviceType = 0x1000, kErrorRegister = 0x1001;
/// Modes of operation (0x6060) the hal uses.
inline constexpr std::int8_t kModeCyclicSyncPosition = 8, kModeCyclicSyncTorque = 10;

enum class DriveState {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};
const char* to_string(DriveState s);
/// The state a statusword reports (its bits 0-3, 5, 6; IEC 61800-7-201 table 30); nullopt for a
/// pattern that is no state (a drive that does not speak CiA 402, or a corrupted word).
std::optional<DriveState> decode_statusword(std::uint16_t statusword);
/// Statusword bits beyond the state.
inline constexpr std::uint16_t kStatusVoltageEnabled = 1U << 4, kStatusWarning = 1U << 7, kStatusRemote = 1U << 9,
                               kStatusTargetReached = 1U << 10, kStatusInternalLimit = 1U << 11;

/// Controlword commands (table 31): the low bits that select a transition.
inline constexpr std::uint16_t kCwShutdown = 0x0006, kCwSwitchOn = 0x0007, kCwEnableOperation = 0x000F,
                               kCwDisableVoltage = 0x0000, kCwQuickStop = 0x0002, kCwDisableOperation = 0x0007,
                               kCwFaultReset = 0x0080;

/// The master's next controlword towards Operation enabled (`enable`) or towards Switch on
/// disabled (not `enable`), from the state the drive reports. A fault is reset only when
/// `fault_reset` is asked for: the controlword then rises on bit 7 (0x0080; a drive resets on the
/// edge, so `previous` says what was sent last). Nothing is asked while the drive is not ready or
/// reacting to a fault (0x0000).
std::uint16_t next_controlword(DriveState s, bool enable, bool fault_reset, std::uint16_t previous);

/// The device's side: the state machine a controlword drives (table 31's transitions 2-16), with
/// the fault reaction, as a CiA 402 drive runs it. `tick` moves the automatic transitions (0 → 1
/// after start-up, 13 → 14 once the fault reaction is done).
class DriveStateMachine {
 public:
  /// Applies a controlword; returns the transition's number (2..16) or 0 when none applies.
  int apply(std::uint16_t controlword);
  /// A fault: transition 13 (fault reaction active) from any state.
  void fault();
  /// The automatic transitions: start-up done (0 → 1), fault reaction done (13 → 14).
  void tick();
  [[nodiscard]] DriveState state() const { return state_; }
  /// The statusword of the state, with `extra` bits (voltage enabled, remote, ...).
  [[nodiscard]] std::uint16_t statusword(std::uint16_t extra = 0) const;
  /// Torque may be applied (Operation enabled).
  [[nodiscard]] bool enabled() const { return state_ == DriveState::kOperationEnabled; }

 private:
  DriveState state_ = DriveState::kNotReadyToSwitchOn;
  bool fault_reset_bit_ = false;  ///< bit 7 of the last controlword (a reset happens on its rising edge)
};

}  // namespace hpr::hal::canopen
