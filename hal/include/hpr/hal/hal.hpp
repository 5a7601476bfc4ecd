#pragma once
/// \file
/// The hardware abstraction without LCM: joint commands in, CAN frames out, replies and sensor
/// frames in, one SensorSample and a status out, with the safety state machine in between.
///
/// One tick: begin_tick (safety update, a frame per drive, SYNC on the sensor bus, flush) →
/// receive until replies_complete or the reply window closes → end_tick (missed replies, faults).
/// Joint and drive units: q = sign · p + offset, τ = sign · t (kp and kd are the same on both sides).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/common/robot_io.hpp"
#include "hpr/hal/can.hpp"
#include "hpr/hal/cia402.hpp"
#include "hpr/hal/mit_codec.hpp"
#include "hpr/hal/safety.hpp"
#include "hpr/model/robot.hpp"

namespace hpr::hal {

/// The protocol a drive speaks (docs/CAN.md): "MIT mode" impedance frames, or CANopen CiA 402 in
/// cyclic synchronous torque.
enum class DriveProtocol { kMit, kCia402 };

struct BusConfig {
  std::string name;
  DriveProtocol protocol = DriveProtocol::kMit;  ///< its drives' default
  std::string transport;  ///< "socketcan" or "udp"
  std::string interface;  ///< socketcan
  bool fd = false;        ///< CAN FD frames
  double bitrate = 1e6;       ///< [bit/s] (arbitration phase for CAN FD)
  double data_bitrate = 5e6;  ///< [bit/s] CAN FD data phase
  std::string local, remote;  ///< udp "host:port" (hal side; the emulator swaps them)
};

/// A drive of the hal: its joint and units (drive::JointDrive), and where and how it is reached.
struct DriveConfig : drive::JointDrive {
  int bus = -1;
  int id = 0;
  DriveProtocol protocol = DriveProtocol::kMit;
  Cia402Scaling cia402;   ///< CiA 402: units (from hal.canopen, the drive's EDS, its `cia402` block)
  std::string eds;        ///< CiA 402: the drive's EDS/DCF file, if one is given
};

struct HalConfig {
  std::string file;                 ///< the configuration file (messages)
  double period = 0.001;            ///< [s]
  double reply_window = 0.0007;     ///< [s] after the tick start to wait for replies
  /// Clock `lockstep` (simulation only, with a drive emulator): hal time is tick × period; a tick
  /// ends when every bus has delivered the emulator's clock frame (kLockstepTickId), the next starts
  /// when the controllers have answered, each wait bounded by `lockstep_timeout` of wall time.
  /// `realtime` (the robot): an absolute 1 kHz clock and the reply window.
  bool lockstep = false;
  double lockstep_timeout = 0.5;    ///< [s, wall]
  std::vector<BusConfig> buses;
  /// One per model joint, in model order, then one per held joint (model.held_joint_name order).
  std::vector<DriveConfig> drives;
  int controlled = 0;               ///< drives of model joints: the first `controlled` of `drives`
  double held_kp = 50.0;            ///< [Nm/rad] joint impedance holding the held joints (capped per drive)
  double held_kd = 1.0;             ///< [Nm s/rad]
  int sensor_bus = -1;              ///< bus of the IMU and F/T sensors (-1: none)
  SafetyConfig safety;
  CanOpenTiming canopen;            ///< CiA 402 drives: start-up and supervision times
  double damping_kd = 10.0;         ///< [Nm s/rad] damping mode, capped at each drive's kd_max
  double soft_limit_margin = 0.05;  ///< [rad] inside the hard limits where damping is added
  double soft_limit_kd = 20.0;      ///< [Nm s/rad] added at the hard limit, ramping from 0 at the margin
  /// Reads and validates the `hal` section against the robot (every joint, held ones included,
  /// mapped to a drive once; ids unique per bus).
  static HalConfig load(const Config& hal_section, const model::RobotSpec& robot);
};

/// The command check the hal shares with the simulator (hpr/drive/drive.hpp).
using drive::check_command;

/// Opens the transports of the configured buses. `emulator_side` swaps local and remote for udp.
std::vector<std::unique_ptr<CanTransport>> open_buses(const HalConfig& c, bool emulator_side);

/// Drive states as HAL_STATUS reports them (hal_status_t::DRIVE_*).
enum DriveState : std::int8_t { kDriveOff = 0, kDriveRun = 1, kDriveDamp = 2, kDriveFault = 3, kDriveNoReply = 4 };
/// OPERATOR commands the hal acts on (operator_t::COMMAND_*).
enum OperatorCommand : int { kOperatorEnable = 1, kOperatorDamp = 2, kOperatorStop = 3 };

struct DriveStatus {
  std::int8_t state = 0;  ///< DriveState
  double temperature = 0;
  int fault = 0;
  std::int64_t missed = 0;
  int missed_run = 0;
  bool replied = false;   ///< this tick
  /// Replies beyond the first of a tick (never taken: the first one stands), in all and in a row
  /// of ticks; `safety.missed_replies_fault` ticks in a row is a fault.
  std::int64_t extra = 0;
  int extra_run = 0;
  bool extra_this_tick = false;
  /// Replies refused for a position the drive cannot have reached since its last reply at its
  /// largest speed (counted as missed too).
  std::int64_t implausible = 0;
  bool have_position = false;
  double position = 0.0;    ///< [drive units] of the last reply taken
  double reply_time = 0.0;  ///< [s, hal time] of the last reply taken
};

class Hal {
 public:
  Hal(HalConfig config, std::vector<std::unique_ptr<CanTransport>> buses, std::unique_ptr<DriveCodec> codec);

  /// Takes a JOINT_COMMAND received at `now` [s, monotonic]. A non-finite or out-of-limit command is
  /// rejected whole and counted (the previous one keeps ageing); so is one whose tick is not newer
  /// than the command taken (commands_repeated()). Returns why, or empty.
  std::string set_command(const JointCommand& command, double now);
  /// OPERATOR: enable, damp, stop, issued by `source` at `issued_us` [us, its wall clock]. A damp
  /// or stop holds until an enable issued after it. Returns a message for the log.
  std::string operator_command(int command, double now, const std::string& source, std::int64_t issued_us);

  void begin_tick(std::int64_t tick, double now);
  /// Drains every bus; returns the frames handled.
  int receive();
  [[nodiscard]] bool replies_complete() const;
  /// Lockstep: every bus has delivered the emulator's clock frame since begin_tick.
  [[nodiscard]] bool tick_closed() const;
  void end_tick(double now);

  [[nodiscard]] const SensorSample& sensors() const { return sensors_; }
  /// Positions the held joints' drives last reported [rad] (HalConfig::drives order after `controlled`).
  [[nodiscard]] const Eigen::VectorXd& held_positions() const { return held_q_; }
  [[nodiscard]] const SafetyMachine& safety() const { return safety_; }
  /// Acknowledges a state change (after HAL_STATUS went out for it).
  void clear_changed() { safety_.clear_changed(); }
  [[nodiscard]] const std::vector<DriveStatus>& drives() const { return drive_status_; }
  [[nodiscard]] const HalConfig& config() const { return config_; }
  [[nodiscard]] const std::vector<std::unique_ptr<CanTransport>>& buses() const { return buses_; }
  [[nodiscard]] std::int64_t commands_rejected() const { return rejected_; }
  [[nodiscard]] std::int64_t commands_stale() const { return stale_; }
  /// JOINT_COMMANDs dropped because their tick was not newer than the command taken.
  [[nodiscard]] std::int64_t commands_repeated() const { return repeated_; }
  [[nodiscard]] std::int64_t frames_malformed() const { return malformed_; }
  /// The frame each drive was sent this tick (drive units as decoded by a drive; tests).
  [[nodiscard]] const std::vector<DriveCommand>& sent() const { return sent_; }
  /// A short description of the active fault conditions (empty if none).
  [[nodiscard]] std::string fault_conditions() const;
  /// The drives still starting up (CiA 402: boot-up, SDO configuration, NMT start), empty once
  /// every drive runs cyclically; an enable is refused until then.
  [[nodiscard]] std::string starting_drives() const;
  /// The CiA 402 side of drive `i` (nullptr for an MIT-mode drive).
  [[nodiscard]] const Cia402Master* cia402(std::size_t i) const { return cia402_[i].get(); }

 private:
  void handle_frame(int bus, const CanFrame& f);
  /// A CiA 402 node's frame; false when it is no frame of a CiA 402 drive on that bus.
  bool handle_canopen(int bus, const CanFrame& f);
  /// Drive i's sample (drive units) into the sensors or the held positions, unless its position
  /// jumped further than the drive's speed allows since its last reply (then refused, counted).
  void take_reply(std::size_t i, double p, double v, double t);
  DriveCommand damping_command(std::size_t i) const;
  /// A CiA 402 drive's frames of this tick (start-up, or RPDO1 with `torque`) onto its bus.
  void send_cia402(Cia402Master& m, CanTransport& bus, double now, bool enable, double torque);
  /// The joint torque a CiA 402 drive is sent for impedance command `c` [drive units, N m].
  double cia402_torque(std::size_t i, const DriveCommand& c) const;
  [[nodiscard]] bool expects_reply(std::size_t i) const { return !cia402_[i] || cia402_[i]->cyclic(); }

  HalConfig config_;
  std::vector<std::unique_ptr<CanTransport>> buses_;
  std::unique_ptr<DriveCodec> codec_;
  SafetyMachine safety_;
  JointCommand command_;
  bool have_command_ = false;
  double command_time_ = -1e9;
  std::int64_t rejected_ = 0, stale_ = 0, malformed_ = 0, repeated_ = 0;
  SensorSample sensors_;
  std::vector<DriveStatus> drive_status_;
  std::vector<DriveCommand> sent_;
  Eigen::VectorXd held_q_;
  std::vector<std::vector<int>> drive_by_id_;  ///< per bus: drive id → drive index (-1)
  std::vector<CanFrame> rx_;
  int sensor_frames_ = 0, sensor_frames_expected_ = 0;
  std::vector<char> tick_closed_;  ///< lockstep: per bus, the clock frame arrived this tick
  std::vector<std::unique_ptr<Cia402Master>> cia402_;  ///< per drive (null: MIT mode)
  std::vector<char> sync_bus_;     ///< per bus: SYNC every tick (sensors or CiA 402 drives on it)
  std::vector<CanFrame> tx_;
  double now_ = 0.0;               ///< the tick's start [s]
};

}  // namespace hpr::hal
