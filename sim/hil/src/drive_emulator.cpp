#include "hpr/sim/drive_emulator.hpp"

#include <algorithm>
#include <cmath>

namespace hpr::hal {

EmulatorOptions EmulatorOptions::load(const Config& c) {
  c.reject_unknown({"drive_timeout", "drive_damping_kd", "position_kp", "position_kd", "drop_reply_probability", "corrupt_probability", "fault_joint", "fault_code",
                    "fault_at", "bus_off_bus", "bus_off_at", "seed", "duration"});
  EmulatorOptions o;
  o.drive_timeout = c.real_or("drive_timeout", o.drive_timeout, 1e-3, 10.0);
  o.drive_damping_kd = c.real_or("drive_damping_kd", o.drive_damping_kd, 0.0, 1e4);
  o.position_kp = c.real_or("position_kp", o.position_kp, 0.0, 1e5);
  o.position_kd = c.real_or("position_kd", o.position_kd, 0.0, 1e4);
  o.drop_reply_probability = c.real_or("drop_reply_probability", 0.0, 0.0, 1.0);
  o.corrupt_probability = c.real_or("corrupt_probability", 0.0, 0.0, 1.0);
  o.fault_joint = c.string_or("fault_joint", "");
  o.fault_code = static_cast<int>(c.integer_or("fault_code", 0, 0, 0xFFFF));
  o.fault_at = c.real_or("fault_at", -1.0);
  o.bus_off_bus = c.string_or("bus_off_bus", "");
  o.bus_off_at = c.real_or("bus_off_at", -1.0);
  o.seed = static_cast<unsigned>(c.integer_or("seed", 1, 0, 1L << 31));
  return o;
}

DriveEmulator::DriveEmulator(const HalConfig& config, sim::Simulator& sim, std::unique_ptr<DriveCodec> codec, EmulatorOptions options)
    : config_(config), sim_(sim), codec_(std::move(codec)), options_(std::move(options)), rng_(options_.seed) {
  drives_.assign(config_.drives.size(), Drive{});
  requested_.assign(config_.drives.size(), 0);
  drive_by_id_.assign(config_.buses.size(), std::vector<int>(MitCodec::kMaxDriveId + 1, -1));
  for (std::size_t i = 0; i < config_.drives.size(); ++i) {
    const auto& d = config_.drives[i];
    drive_by_id_[static_cast<std::size_t>(d.bus)][static_cast<std::size_t>(d.id)] = static_cast<int>(i);
    if (d.joint == options_.fault_joint) fault_drive_ = static_cast<int>(i);
  }
  for (std::size_t b = 0; b < config_.buses.size(); ++b) {
    if (config_.buses[b].name == options_.bus_off_bus) bus_off_bus_ = static_cast<int>(b);
  }
  dictionaries_.resize(config_.drives.size());
  devices_.resize(config_.drives.size());
  for (std::size_t i = 0; i < config_.drives.size(); ++i) {
    const auto& d = config_.drives[i];
    if (d.protocol != DriveProtocol::kCia402) continue;
    // The drive's own data sheet when the configuration names one, else the emulated drive's.
    dictionaries_[i] = d.eds.empty()
                           ? canopen::ObjectDictionary::parse(Cia402Device::default_eds(static_cast<std::uint32_t>(std::lround(d.cia402.rated_torque * 1e3))),
                                                              "emulated drive of " + d.joint)
                           : canopen::ObjectDictionary::load(d.eds);
    devices_[i] = std::make_unique<Cia402Device>(d.id, dictionaries_[i]);
  }
  powered_.assign(config_.buses.size(), 0);
  applied_.resize(config_.controlled);
  applied_.mode = JointCommand::Mode::kRun;
  applied_held_.resize(static_cast<int>(config_.drives.size()) - config_.controlled);
  applied_held_.mode = JointCommand::Mode::kRun;
}

bool DriveEmulator::bus_off(int bus) const {
  return bus == bus_off_bus_ && options_.bus_off_at >= 0 && sim_.time() >= options_.bus_off_at;
}

bool DriveEmulator::timed_out(std::size_t drive, double now) const {
  return now - drives_[drive].command_time > options_.drive_timeout;
}

bool DriveEmulator::motor_mode(std::size_t drive) const {
  return devices_[drive] ? devices_[drive]->drive().enabled() : drives_[drive].motor_mode;
}

bool DriveEmulator::faulted(std::size_t i) const {
  return static_cast<int>(i) == fault_drive_ && options_.fault_at >= 0 && sim_.time() >= options_.fault_at;
}

bool DriveEmulator::handle_canopen(int bus, const CanFrame& f, double now, CanTransport& out) {
  const canopen::Cob cob = canopen::classify(f);
  bool taken = false;
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    if (!devices_[i] || config_.drives[i].bus != bus) continue;
    Cia402Device& dev = *devices_[i];
    const bool mine = cob.function == canopen::Function::kNmt || cob.function == canopen::Function::kSync || cob.node == dev.node();
    if (!mine) continue;
    taken = true;
    tx_.clear();
    if (cob.function == canopen::Function::kSync) {
      requested_[i] = 1;
      ++requests_;
      if (faulted(i)) dev.fault(static_cast<std::uint16_t>(options_.fault_code), tx_);
      const DriveReply m = measured(i);
      const Cia402Scaling& sc = config_.drives[i].cia402;
      dev.set_actual(static_cast<std::int32_t>(std::lround(m.p / sc.rad_per_count())), static_cast<std::int32_t>(std::lround(m.v / sc.rad_s_per_unit())),
                     sc.torque_to_drive(m.t));
    } else if (cob.function == canopen::Function::kRpdo) {
      drives_[i].command_time = now;
    }
    const std::size_t before = tx_.size();
    dev.on_frame(f, now, tx_);
    // Injected losses act on a running drive's TPDOs, one draw per SYNC.
    const bool inject = cob.function == canopen::Function::kSync && dev.drive().enabled() && tx_.size() > before;
    if (inject && options_.drop_reply_probability > 0 && uniform_(rng_) < options_.drop_reply_probability) tx_.resize(before);
    if (inject && tx_.size() > before && options_.corrupt_probability > 0 && uniform_(rng_) < options_.corrupt_probability) tx_[before].len = 6;
    for (const CanFrame& o : tx_) out.send(o);
  }
  return taken;
}

DriveReply DriveEmulator::measured(std::size_t i) const {
  const DriveConfig& d = config_.drives[i];
  const auto j = static_cast<Eigen::Index>(i);
  DriveReply r;
  if (d.held) {
    const auto k = j - config_.controlled;
    const sim::TruthData& t = sim_.truth();
    r.p = d.sign * (t.q_held(k) - d.offset);
    r.v = d.sign * t.v_held(k);
    r.t = d.sign * t.tau_held(k);
  } else {
    const SensorSample& s = sim_.sensors();
    r.p = d.sign * (s.q(j) - d.offset);
    r.v = d.sign * s.qd(j);
    r.t = d.sign * s.tau(j);
  }
  return r;
}

void DriveEmulator::reply(std::size_t i, CanTransport& out) {
  const DriveConfig& d = config_.drives[i];
  // Injected losses act on running drives only, one draw per reply from the seed: a lockstep run
  // drops the same replies every time, however long the hal took to enable.
  const bool inject = drives_[i].motor_mode;
  if (inject && options_.drop_reply_probability > 0 && uniform_(rng_) < options_.drop_reply_probability) return;
  DriveReply r = measured(i);
  r.drive_id = d.id;
  r.temperature = 35.0;
  if (faulted(i)) r.fault = static_cast<std::uint8_t>(std::min(options_.fault_code, 255));
  CanFrame f = codec_->encode_reply(r, d.limits);
  if (inject && options_.corrupt_probability > 0 && uniform_(rng_) < options_.corrupt_probability) f.len = 6;
  out.send(f);
}

void DriveEmulator::handle(int bus, const CanFrame& f, double now, CanTransport& out) {
  if (bus_off(bus)) return;  // a bus-off controller neither hears nor answers
  const std::uint32_t id = f.id & kCanSffMask;
  const bool canopen = handle_canopen(bus, f, now, out);
  if (bus == config_.sensor_bus && id == kSyncId) {
    sync_requested_ = true;
    ++requests_;
    const SensorSample& s = sim_.sensors();
    const double q[4] = {s.imu_quat_WB(0), s.imu_quat_WB(1), s.imu_quat_WB(2), s.imu_quat_WB(3)};
    out.send(encode_int16s(kImuQuatId, q, 4, 1.0 / 32767.0));
    out.send(encode_int16s(kImuGyroId, s.imu_gyro_B.data(), 3, kImuGyroScale));
    out.send(encode_int16s(kImuAccelId, s.imu_accel_B.data(), 3, kImuAccelScale));
    for (std::uint32_t k = 0; k < 2; ++k) {
      out.send(encode_int16s(kFtForceId + 2 * k, s.ft_wrench_S[k].data(), 3, kFtForceScale));
      out.send(encode_int16s(kFtTorqueId + 2 * k, s.ft_wrench_S[k].data() + 3, 3, kFtTorqueScale));
    }
    return;
  }
  if (canopen) return;
  if (id > static_cast<std::uint32_t>(MitCodec::kMaxDriveId) || (f.id & (kCanEffFlag | kCanRtrFlag)) != 0) {
    ++ignored_;
    return;
  }
  const int i = drive_by_id_[static_cast<std::size_t>(bus)][id];
  if (i < 0 || devices_[static_cast<std::size_t>(i)]) {
    ++ignored_;
    return;
  }
  const auto iu = static_cast<std::size_t>(i);
  const auto req = codec_->decode_request(f, config_.drives[iu].limits);
  if (!req) {
    ++ignored_;
    return;
  }
  Drive& d = drives_[iu];
  requested_[iu] = 1;
  ++requests_;
  if (req->special) {
    if (*req->special == SpecialCommand::kEnterMotorMode) d.motor_mode = true;
    if (*req->special == SpecialCommand::kExitMotorMode) d.motor_mode = false;
    d.command = DriveCommand{};
    d.command_time = now;
  } else if (req->command) {
    d.command = *req->command;
    d.command_time = now;
  }
  reply(iu, out);
}

void DriveEmulator::report_periodic(int bus, double now, CanTransport& out) {
  // The CiA 402 devices run their timers whatever the bus does (a drive cut off by a bus-off
  // misses its RPDOs and faults); what they send reaches a bus that is not off.
  tx_.clear();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    if (!devices_[i] || config_.drives[i].bus != bus) continue;
    if (powered_[static_cast<std::size_t>(bus)] == 0) devices_[i]->power_on(tx_);
    devices_[i]->periodic(now, options_.drive_timeout, tx_);
  }
  powered_[static_cast<std::size_t>(bus)] = 1;
  if (bus_off(bus)) {
    CanFrame e;
    e.id = kCanErrFlag | kCanErrBusOff;
    e.len = 8;
    out.send(e);
    return;
  }
  for (const CanFrame& f : tx_) out.send(f);
}

bool DriveEmulator::damping_by_itself(std::size_t i, double now) const {
  if (const Cia402Device* dev = devices_[i].get()) return dev->fault_reaction() && dev->error() == Cia402Device::kRpdoTimeout;
  return drives_[i].motor_mode && timed_out(i, now);
}

bool DriveEmulator::tick_requested() const {
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    if (requested_[i] == 0 && !bus_off(config_.drives[i].bus)) return false;
  }
  return config_.sensor_bus < 0 || sync_requested_ || bus_off(config_.sensor_bus);
}

void DriveEmulator::report_tick(std::int64_t tick, CanTransport& out) { out.send(encode_lockstep_tick(tick)); }

void DriveEmulator::step(double now) {
  std::fill(requested_.begin(), requested_.end(), 0);
  sync_requested_ = false;
  requests_ = 0;
  // On a gantry until the first enable: the robot hangs in its settled posture, physics frozen.
  if (!released_) {
    for (std::size_t i = 0; i < drives_.size(); ++i) released_ = released_ || motor_mode(i);
    if (!released_) return;
  }
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    const DriveConfig& dc = config_.drives[i];
    const Drive& d = drives_[i];
    const auto j = static_cast<Eigen::Index>(i);
    double kp = 0, kd = 0, q_des = 0, qd_des = 0, tau = 0;
    const bool faulted = this->faulted(i);
    if (const Cia402Device* dev = devices_[i].get()) {
      // Cyclic synchronous torque, or position through the drive's own loop; a fault reaction
      // brakes dynamically (the drive's own damping).
      if (dev->fault_reaction()) {
        kd = options_.drive_damping_kd;
      } else if (const auto counts = dev->target_position()) {
        kp = options_.position_kp;
        kd = options_.position_kd;
        q_des = dc.sign * static_cast<double>(*counts) * dc.cia402.rad_per_count() + dc.offset;
      } else {
        tau = dc.sign * dev->target_torque() * dc.cia402.nm_per_permille();
      }
    } else if (d.motor_mode && !faulted) {
      if (timed_out(i, now) || bus_off(dc.bus)) {
        kd = options_.drive_damping_kd;  // the drive's own damping
      } else {
        kp = d.command.kp;
        kd = d.command.kd;
        q_des = dc.sign * d.command.p_des + dc.offset;
        qd_des = dc.sign * d.command.v_des;
        tau = dc.sign * d.command.t_ff;
      }
    } else if (faulted) {
      kd = options_.drive_damping_kd;
    }
    JointCommand& out = dc.held ? applied_held_ : applied_;
    const auto k = dc.held ? j - config_.controlled : j;
    out.kp(k) = kp;
    out.kd(k) = kd;
    out.q_des(k) = q_des;
    out.qd_des(k) = qd_des;
    out.tau_ff(k) = tau;
  }
  applied_.tick = sim_.tick();
  sim_.set_command(applied_);
  if (applied_held_.q_des.size() > 0) sim_.set_held_command(applied_held_);
  sim_.step();
}

}  // namespace hpr::hal
