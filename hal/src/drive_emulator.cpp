#include "hpr/hal/drive_emulator.hpp"

#include <cmath>

namespace hpr::hal {

EmulatorOptions EmulatorOptions::load(const Config& c) {
  c.reject_unknown({"drive_timeout", "drive_damping_kd", "drop_reply_probability", "corrupt_probability", "fault_joint", "fault_code",
                    "fault_at", "bus_off_bus", "bus_off_at", "seed", "duration"});
  EmulatorOptions o;
  o.drive_timeout = c.real_or("drive_timeout", o.drive_timeout, 1e-3, 10.0);
  o.drive_damping_kd = c.real_or("drive_damping_kd", o.drive_damping_kd, 0.0, 1e4);
  o.drop_reply_probability = c.real_or("drop_reply_probability", 0.0, 0.0, 1.0);
  o.corrupt_probability = c.real_or("corrupt_probability", 0.0, 0.0, 1.0);
  o.fault_joint = c.string_or("fault_joint", "");
  o.fault_code = static_cast<int>(c.integer_or("fault_code", 0, 0, 255));
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

void DriveEmulator::reply(std::size_t i, CanTransport& out) {
  const DriveConfig& d = config_.drives[i];
  // Injected losses act on running drives only, one draw per reply from the seed: a lockstep run
  // drops the same replies every time, however long the hal took to enable.
  const bool inject = drives_[i].motor_mode;
  if (inject && options_.drop_reply_probability > 0 && uniform_(rng_) < options_.drop_reply_probability) return;
  const auto j = static_cast<Eigen::Index>(i);
  const SensorSample& s = sim_.sensors();
  DriveReply r;
  r.drive_id = d.id;
  if (d.held) {
    const auto k = j - config_.controlled;
    const sim::TruthData& t = sim_.truth();
    r.p = d.sign * (t.q_held(k) - d.offset);
    r.v = d.sign * t.v_held(k);
    r.t = d.sign * t.tau_held(k);
  } else {
    r.p = d.sign * (s.q(j) - d.offset);
    r.v = d.sign * s.qd(j);
    r.t = d.sign * s.tau(j);
  }
  r.temperature = 35.0;
  if (static_cast<int>(i) == fault_drive_ && options_.fault_at >= 0 && sim_.time() >= options_.fault_at) {
    r.fault = static_cast<std::uint8_t>(options_.fault_code);
  }
  CanFrame f = codec_->encode_reply(r, d.limits);
  if (inject && options_.corrupt_probability > 0 && uniform_(rng_) < options_.corrupt_probability) f.len = 6;
  out.send(f);
}

void DriveEmulator::handle(int bus, const CanFrame& f, double now, CanTransport& out) {
  if (bus_off(bus)) return;  // a bus-off controller neither hears nor answers
  const std::uint32_t id = f.id & kCanSffMask;
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
  if (id > static_cast<std::uint32_t>(MitCodec::kMaxDriveId)) {
    ++ignored_;
    return;
  }
  const int i = drive_by_id_[static_cast<std::size_t>(bus)][id];
  if (i < 0) {
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

void DriveEmulator::report_bus_state(int bus, CanTransport& out) {
  if (!bus_off(bus)) return;
  CanFrame e;
  e.id = kCanErrFlag | kCanErrBusOff;
  e.len = 8;
  out.send(e);
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
    for (const Drive& d : drives_) released_ = released_ || d.motor_mode;
    if (!released_) return;
  }
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    const DriveConfig& dc = config_.drives[i];
    const Drive& d = drives_[i];
    const auto j = static_cast<Eigen::Index>(i);
    double kp = 0, kd = 0, q_des = 0, qd_des = 0, tau = 0;
    const bool faulted = static_cast<int>(i) == fault_drive_ && options_.fault_at >= 0 && sim_.time() >= options_.fault_at;
    if (d.motor_mode && !faulted) {
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
