#pragma once
/// \file
/// A drive emulator: answers the drive protocol for every joint over the same transports as the
/// real drives, backed by the simulation (in namespace hal: it is the drives' side of the hal's
/// protocols). The drives keep their last command and fall back
/// to their own damping when commands stop (drive timeout); faults can be injected. A drive
/// configured for CiA 402 is a `Cia402Device` (NMT, SDO, PDOs at each SYNC, heartbeat, EMCY) whose
/// target torque drives its joint; its fault reaction is a dynamic brake (the drive's damping).
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "hpr/hal/hal.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::hal {

struct EmulatorOptions {
  double drive_timeout = 0.02;       ///< [s] without a command frame: the drive damps by itself
  double drive_damping_kd = 10.0;    ///< [Nm s/rad]
  /// A CiA 402 drive's own position loop in cyclic synchronous position (mode 8), at the joint.
  double position_kp = 1000.0;       ///< [Nm/rad]
  double position_kd = 20.0;         ///< [Nm s/rad]
  double drop_reply_probability = 0; ///< per reply of a drive in motor mode (seeded: reproducible)
  double corrupt_probability = 0;    ///< per reply of a drive in motor mode: sent with a wrong length
  std::string fault_joint;           ///< this drive reports `fault_code` from `fault_at` [s sim time]
  int fault_code = 0;                ///< MIT mode: the reply's fault byte (1-255); CiA 402: the EMCY error code
  double fault_at = -1;
  std::string bus_off_bus;           ///< this bus goes bus-off at `bus_off_at` [s sim time]
  double bus_off_at = -1;
  unsigned seed = 1;
  static EmulatorOptions load(const Config& emulator_section);
};

class DriveEmulator {
 public:
  DriveEmulator(const HalConfig& config, sim::Simulator& sim, std::unique_ptr<DriveCodec> codec, EmulatorOptions options);

  /// Handles a frame received on `bus` at `now` [s, monotonic]; replies are queued on `out`.
  void handle(int bus, const CanFrame& f, double now, CanTransport& out);
  /// Advances the physics one period with what each drive is doing at `now`.
  void step(double now);
  /// Queues what a bus's devices send by themselves on it: an error frame while the bus is off,
  /// CiA 402 boot-up and heartbeat messages and EMCY. Call once per period per bus.
  void report_periodic(int bus, double now, CanTransport& out);

  /// Lockstep: every drive on a bus that is not bus-off, and the sensors' SYNC, has had its frame
  /// since the last step (the hal's tick is complete), or at least one has (`any_requested`).
  [[nodiscard]] bool tick_requested() const;
  [[nodiscard]] bool any_requested() const { return requests_ > 0; }
  /// Lockstep: queues the simulated clock's frame for `tick` on `out` (after the tick's replies).
  static void report_tick(std::int64_t tick, CanTransport& out);

  /// The drive applies torque (MIT: motor mode; CiA 402: Operation enabled).
  [[nodiscard]] bool motor_mode(std::size_t drive) const;
  /// The CiA 402 device of a drive (nullptr for MIT mode).
  [[nodiscard]] const Cia402Device* cia402(std::size_t drive) const { return devices_[drive].get(); }
  [[nodiscard]] bool timed_out(std::size_t drive, double now) const;
  /// The drive damps by itself because the hal stopped talking to it (MIT: motor mode and timed
  /// out; CiA 402: its fault reaction to an RPDO timeout).
  [[nodiscard]] bool damping_by_itself(std::size_t drive, double now) const;
  [[nodiscard]] std::int64_t frames_ignored() const { return ignored_; }
  [[nodiscard]] const JointCommand& applied() const { return applied_; }
  /// False until a drive first enters motor mode: the robot hangs on its gantry (physics frozen).
  [[nodiscard]] bool released() const { return released_; }

 private:
  struct Drive {
    bool motor_mode = false;
    DriveCommand command;
    double command_time = -1e9;
  };
  void reply(std::size_t i, CanTransport& out);
  /// What drive i measures now, in drive units (sign and offset applied): p, v, t.
  [[nodiscard]] DriveReply measured(std::size_t i) const;
  bool bus_off(int bus) const;
  [[nodiscard]] bool faulted(std::size_t i) const;
  /// A CANopen frame for the CiA 402 devices on `bus`; false when none of them takes it.
  bool handle_canopen(int bus, const CanFrame& f, double now, CanTransport& out);

  const HalConfig& config_;
  sim::Simulator& sim_;
  std::unique_ptr<DriveCodec> codec_;
  EmulatorOptions options_;
  std::vector<Drive> drives_;
  std::vector<std::vector<int>> drive_by_id_;
  int fault_drive_ = -1, bus_off_bus_ = -1;
  JointCommand applied_;       ///< to the simulator: the controlled joints
  JointCommand applied_held_;  ///< the held joints
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  std::int64_t ignored_ = 0;
  bool released_ = false;
  std::vector<char> requested_;  ///< per drive, since the last step
  std::vector<canopen::ObjectDictionary> dictionaries_;   ///< per drive (empty for MIT mode)
  std::vector<std::unique_ptr<Cia402Device>> devices_;    ///< per drive (null for MIT mode)
  std::vector<char> powered_;    ///< per bus: the CiA 402 devices sent their boot-up
  std::vector<CanFrame> tx_;
  bool sync_requested_ = false;
  int requests_ = 0;
};

}  // namespace hpr::hal
