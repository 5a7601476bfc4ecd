#pragma once
/// \file
/// A CiA 402 drive on the bus, both ends: `Cia402Master` is the hal's side of one drive (start-up,
/// cyclic synchronous torque, supervision), `Cia402Device` is a drive (the emulator's, and the
/// tests'). Frames only: nothing here owns a bus or a clock; time is the caller's [s].
///
/// Start-up (master): NMT reset communication → the boot-up message → SDO reads of what the drive
/// is (0x1000 device type: profile 402; 0x6502: cyclic synchronous torque supported; 0x6076: its
/// rated torque, which scales every torque) → the SDO writes of `cst_configuration` (PDO mapping,
/// mode 10, heartbeat producer) one at a time → NMT start → the first heartbeat saying operational. Cyclic, each tick: RPDO1 (controlword, target torque) then
/// SYNC on the bus; the drive answers TPDO1 (statusword, torque, position) and TPDO2 (velocity),
/// sampled at the SYNC. Supervision: an EMCY latches its error code as the drive's fault; the
/// heartbeat is consumed (silence for `heartbeat_timeout`, a boot-up or a state other than
/// operational is a fault); a drive that leaves Operation enabled unasked, or does not reach it
/// within `enable_timeout`, is a fault. A fault is reset only on request (the operator's enable).
///
/// Units on the hal's side are the joint's output (rad, rad/s, N m, before the joint's sign and
/// offset); on the drive's side CiA 402's: position increments (0x6064), velocity in increments/s
/// or motor rpm (0x606C), torque in thousandths of the motor's rated torque (0x6071, 0x6077; the
/// rated torque 0x6076 in mN m).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hpr/hal/can.hpp"
#include "hpr/hal/canopen.hpp"
#include "hpr/hal/canopen_sdo.hpp"
#include "hpr/hal/eds.hpp"

namespace hpr::hal {

/// How a drive's CiA 402 units map to its joint's output side.
struct Cia402Scaling {
  double counts_per_revolution = 131072;  ///< position increments per motor revolution
  double gear_ratio = 100.0;               ///< motor revolutions per joint revolution
  bool velocity_rpm = false;               ///< 0x606C in motor rpm (else increments/s)
  double rated_torque = 0.5;               ///< [N m] the motor's rated torque (0x6076)
  /// The configuration (or the drive's EDS) gives the rated torque: the drive's own 0x6076 must
  /// agree (within 1 %); otherwise the drive's value is taken at start-up.
  bool rated_torque_given = false;

  [[nodiscard]] double rad_per_count() const;
  [[nodiscard]] double rad_s_per_unit() const;
  /// [N m at the joint] per thousandth of the rated torque.
  [[nodiscard]] double nm_per_permille() const;
  /// A joint torque [N m] as a target torque (0x6071), rounded and saturated to int16.
  [[nodiscard]] std::int16_t torque_to_drive(double tau) const;
};

/// The CANopen master's timing (`hal.canopen`).
struct CanOpenTiming {
  int heartbeat_ms = 20;            ///< the drives' heartbeat producer time (0x1017)
  double heartbeat_timeout = 0.1;   ///< [s] without a heartbeat: a fault
  double sdo_timeout = 0.1;         ///< [s] for each SDO answer
  double boot_timeout = 2.0;        ///< [s] for the boot-up message and for the first operational heartbeat
  double enable_timeout = 0.1;      ///< [s] from an enable to Operation enabled
};

/// The hal's side of one CiA 402 drive.
class Cia402Master {
 public:
  enum class Phase { kReset, kBooting, kIdentifying, kConfiguring, kStarting, kCyclic, kFailed };
  static const char* to_string(Phase p);

  Cia402Master(int node, Cia402Scaling scaling, CanOpenTiming timing);

  /// This tick's frames on `out` (before the bus's SYNC). `enable`: towards Operation enabled (else
  /// towards Switch on disabled, torque off); `torque` [N m, output side] is sent once the drive
  /// reports Operation enabled, else 0.
  void tick(double now, bool enable, double torque, std::vector<CanFrame>& out);
  /// A frame of this node (TPDO, EMCY, heartbeat, SDO answer); false when it is malformed.
  bool on_frame(const CanFrame& f, double now);
  /// Supervision after the tick's frames: heartbeat, the enable deadline, an unasked state change.
  void supervise(double now);
  /// Asks for a fault reset (the controlword's bit 7 rising) and clears what is no longer present.
  void reset_fault();

  [[nodiscard]] int node() const { return node_; }
  [[nodiscard]] Phase phase() const { return phase_; }
  /// In the cyclic phase: the drive is expected to answer each SYNC.
  [[nodiscard]] bool cyclic() const { return phase_ == Phase::kCyclic; }
  /// Both TPDOs arrived since the last tick.
  [[nodiscard]] bool replied() const { return (rx_ & 3) == 3; }
  /// The last sample, output side [rad, rad/s, N m].
  [[nodiscard]] double position() const { return p_; }
  [[nodiscard]] double velocity() const { return v_; }
  [[nodiscard]] double torque() const { return t_; }
  /// The units in use (the rated torque as the drive reported it, when the configuration gave none).
  [[nodiscard]] const Cia402Scaling& scaling() const { return scaling_; }
  [[nodiscard]] std::optional<canopen::DriveState> state() const { return state_; }
  [[nodiscard]] std::uint16_t statusword() const { return statusword_; }
  [[nodiscard]] bool enabled() const { return state_ == canopen::DriveState::kOperationEnabled; }
  /// The latched fault's code (the EMCY error code, or 0xFF00 + a cause of the master's own), 0 if none.
  [[nodiscard]] int fault_code() const { return fault_code_; }
  /// The latched fault in words (empty if none), e.g. "EMCY 0x2310 (current, device output side)".
  [[nodiscard]] const std::string& fault_text() const { return fault_text_; }
  /// Why the drive cannot be enabled yet (empty once cyclic), e.g. "configuring (SDO 7 of 20)".
  [[nodiscard]] std::string not_ready() const;
  /// The last controlword sent.
  [[nodiscard]] std::uint16_t controlword() const { return controlword_; }

  /// The master's own fault codes (beside EMCY codes).
  static constexpr int kFaultStartUp = 0xFF01, kFaultHeartbeat = 0xFF02, kFaultRestarted = 0xFF03, kFaultNmtState = 0xFF04,
                       kFaultDriveState = 0xFF05, kFaultEnable = 0xFF06;

 private:
  /// Whether a fault of `code` would be latched now (nothing is formatted for one that would not).
  [[nodiscard]] bool takes(int code) const;
  void latch(int code, std::string text);
  /// The start-up failed: latched, and the drive waits for a reset request.
  void fail(std::string text);
  /// The identification reads: the next one to send, or an answer to judge.
  void identify(double now, std::vector<CanFrame>& out);
  void judge(const canopen::SdoMessage& m);
  int node_;
  std::size_t read_ = 0;                  ///< identification read in progress
  std::optional<double> read_sent_;
  Cia402Scaling scaling_;
  CanOpenTiming timing_;
  Phase phase_ = Phase::kReset;
  double phase_since_ = 0.0;
  std::optional<canopen::SdoSequence> sdo_;
  std::optional<canopen::DriveState> state_;
  std::uint16_t statusword_ = 0, controlword_ = 0;
  double p_ = 0, v_ = 0, t_ = 0;
  int rx_ = 0;  ///< bit 0: TPDO1, bit 1: TPDO2 since the last tick
  double last_heartbeat_ = 0.0;
  std::optional<canopen::NmtState> nmt_;
  bool enable_ = false, reset_requested_ = false;
  double enable_since_ = 0.0;
  bool was_enabled_ = false;
  int fault_code_ = 0;
  std::string fault_text_;
};

/// A CiA 402 drive: NMT, an SDO server over its object dictionary, PDOs as its mapping objects say
/// (1400/1600 RPDO1, 1800/1A00 TPDO1, 1801/1A01 TPDO2), the drive state machine, heartbeat and EMCY.
class Cia402Device {
 public:
  /// The data sheet of the drive this device emulates (the objects `cst_configuration` uses and the
  /// identity ones), with 0x6076 = `rated_torque_mnm`; a CiA 306 EDS the hal and tools can read.
  static std::string default_eds(std::uint32_t rated_torque_mnm);

  Cia402Device(int node, const canopen::ObjectDictionary& od);
  /// Powers on: the boot-up message, then pre-operational (once: nothing if an NMT reset already booted it).
  void power_on(std::vector<CanFrame>& out);
  /// A frame from the bus at `now`; answers go to `out`. SYNC applies the last RPDO and sends the
  /// TPDOs sampled from the present actual values.
  void on_frame(const CanFrame& f, double now, std::vector<CanFrame>& out);
  /// Once per period: the heartbeat producer, the state machine's automatic transitions, and the
  /// RPDO timeout (`rpdo_timeout` [s] without one in Operation enabled: EMCY 0x8250, fault).
  void periodic(double now, double rpdo_timeout, std::vector<CanFrame>& out);
  /// An error of the drive: EMCY with `code`, then the fault reaction.
  void fault(std::uint16_t code, std::vector<CanFrame>& out);
  /// The actual values the next TPDOs report (drive units).
  void set_actual(std::int32_t position, std::int32_t velocity, std::int16_t torque);

  [[nodiscard]] canopen::NmtState nmt() const { return nmt_; }
  [[nodiscard]] const canopen::DriveStateMachine& drive() const { return sm_; }
  /// The target torque (0x6071) applied at the last SYNC, while Operation enabled in cyclic
  /// synchronous torque (else 0).
  [[nodiscard]] std::int16_t target_torque() const;
  /// The target position (0x607A) applied at the last SYNC, while Operation enabled in cyclic
  /// synchronous position (else none): the drive closes the position loop with its own gains.
  [[nodiscard]] std::optional<std::int32_t> target_position() const;
  /// The drive reacts to a fault (damping, then off).
  [[nodiscard]] bool fault_reaction() const;
  [[nodiscard]] std::optional<std::uint64_t> object(std::uint16_t index, std::uint8_t subindex) const { return sdo_.value(index, subindex); }
  [[nodiscard]] int node() const { return node_; }
  /// The error code of the last EMCY it sent (0 after a reset).
  [[nodiscard]] std::uint16_t error() const { return error_; }
  static constexpr std::uint16_t kRpdoTimeout = 0x8250;  ///< CiA 301: RPDO timeout
  /// SYNCs answered.
  [[nodiscard]] std::int64_t syncs() const { return syncs_; }

 private:
  void send_tpdo(std::uint16_t comm, std::uint16_t map, std::vector<CanFrame>& out);
  void receive_rpdo(const CanFrame& f, double now, std::vector<CanFrame>& out);
  /// NMT reset: the communication objects (0x1000-0x1FFF) or every object back to the data
  /// sheet's values, then the boot-up message.
  void reset(bool communication_only, std::vector<CanFrame>& out);
  [[nodiscard]] std::optional<std::uint32_t> cob(std::uint16_t comm) const;
  int node_;
  const canopen::ObjectDictionary* od_;
  canopen::SdoServer sdo_;
  canopen::NmtState nmt_ = canopen::NmtState::kBootUp;
  canopen::DriveStateMachine sm_;
  std::int16_t applied_torque_ = 0;  ///< 0x6071 as the last SYNC took it
  std::int32_t applied_position_ = 0;  ///< 0x607A as the last SYNC took it
  bool rpdo_pending_ = false;        ///< an RPDO arrived since the last SYNC
  double last_rpdo_ = -1e9, last_heartbeat_ = -1e9;
  std::int64_t syncs_ = 0;
  std::uint16_t error_ = 0;
  bool booted_ = false;
};

}  // namespace hpr::hal
