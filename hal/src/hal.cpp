#include "hpr/hal/hal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace hpr::hal {

Hal::Hal(HalConfig config, std::vector<std::unique_ptr<CanTransport>> buses, std::unique_ptr<DriveCodec> codec)
    : config_(std::move(config)), buses_(std::move(buses)), codec_(std::move(codec)), safety_(config_.safety) {
  const int n = static_cast<int>(config_.drives.size());
  sensors_.resize(config_.controlled);
  for (auto& w : sensors_.ft_wrench_S) w.setZero();
  command_.resize(config_.controlled);
  held_q_ = Eigen::VectorXd::Zero(n - config_.controlled);
  drive_status_.assign(static_cast<std::size_t>(n), DriveStatus{});
  sent_.assign(static_cast<std::size_t>(n), DriveCommand{});
  drive_by_id_.assign(buses_.size(), std::vector<int>(MitCodec::kMaxDriveId + 1, -1));
  for (int i = 0; i < n; ++i) {
    const auto& d = config_.drives[static_cast<std::size_t>(i)];
    drive_by_id_[static_cast<std::size_t>(d.bus)][static_cast<std::size_t>(d.id)] = i;
  }
  sensor_frames_expected_ = config_.sensor_bus >= 0 ? 3 + 2 * 2 : 0;
  tick_closed_.assign(buses_.size(), 0);
  sync_bus_.assign(buses_.size(), 0);
  if (config_.sensor_bus >= 0) sync_bus_[static_cast<std::size_t>(config_.sensor_bus)] = 1;
  for (const DriveConfig& d : config_.drives) {
    if (d.protocol == DriveProtocol::kCia402) {
      cia402_.push_back(std::make_unique<Cia402Master>(d.id, d.cia402, config_.canopen));
      sync_bus_[static_cast<std::size_t>(d.bus)] = 1;
    } else {
      cia402_.push_back(nullptr);
    }
  }
  rx_.reserve(256);
}

std::string Hal::set_command(const JointCommand& c, double now) {
  const std::string why = check_command(c, config_.drives, config_.controlled);
  if (!why.empty()) {
    ++rejected_;
    return why;
  }
  // Only a newer tick renews the command: a JOINT_COMMAND sent again (a hung controller's last one
  // replayed) does not keep the watchdog from damping.
  if (have_command_ && c.tick <= command_.tick) {
    ++repeated_;
    return fmt::format("tick {} is not newer than the command taken at tick {}: a repeat does not renew it", c.tick, command_.tick);
  }
  command_ = c;
  have_command_ = true;
  command_time_ = now;
  return {};
}

std::string Hal::fault_conditions() const {
  std::string s;
  for (std::size_t b = 0; b < buses_.size(); ++b) {
    if (buses_[b]->counters().bus_off) s += (s.empty() ? "" : "; ") + std::string("bus-off on ") + config_.buses[b].name;
  }
  for (std::size_t i = 0; i < drive_status_.size(); ++i) {
    const auto& ds = drive_status_[i];
    if (cia402_[i] && cia402_[i]->fault_code() != 0) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + ": " + cia402_[i]->fault_text();
    } else if (ds.fault != 0) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + " fault code " + std::to_string(ds.fault);
    }
    if (ds.missed_run >= config_.safety.missed_replies_fault) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + " missed " + std::to_string(ds.missed_run) + " replies";
    }
    if (ds.extra_run >= config_.safety.missed_replies_fault) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + " answered more than once in " + std::to_string(ds.extra_run) +
           " ticks in a row";
    }
  }
  return s;
}

std::string Hal::operator_command(int command, double now, const std::string& source, std::int64_t issued_us) {
  switch (command) {
    case kOperatorEnable: {
      if (issued_us <= safety_.stop_issued_us()) return safety_.enable(now, issued_us, false, {});
      // CiA 402 faults are reset on the operator's request: this enable asks for the reset, the
      // next one enables once the drives report no fault.
      std::string resetting;
      for (std::size_t i = 0; i < cia402_.size(); ++i) {
        if (!cia402_[i] || cia402_[i]->fault_code() == 0) continue;
        resetting += (resetting.empty() ? "" : "; ") + config_.drives[i].joint + ": " + cia402_[i]->fault_text();
        cia402_[i]->reset_fault();
      }
      if (!resetting.empty()) return "enable refused: fault reset requested (" + resetting + "); enable again once the drives have cleared";
      const std::string starting = starting_drives();
      if (!starting.empty()) return "enable refused: drives starting up: " + starting;
      const std::string faults = fault_conditions();
      if (faults.empty()) {
        for (auto& b : buses_) b->clear_bus_off();
      }
      const std::string why = safety_.enable(now, issued_us, !faults.empty(), faults);
      return why.empty() ? "enabled by " + source : why;
    }
    case kOperatorDamp:
    case kOperatorStop:
      safety_.stop(now, issued_us, std::string(command == kOperatorStop ? "stop" : "damp") + " from " + source);
      return "damping (" + source + ")";
    default: return {};
  }
}

DriveCommand Hal::damping_command(std::size_t i) const {
  DriveCommand c;
  c.kd = std::min(config_.damping_kd, config_.drives[i].limits.kd_max);
  c.p_des = std::clamp(0.0, config_.drives[i].limits.p_min, config_.drives[i].limits.p_max);
  return c;
}

std::string Hal::starting_drives() const {
  std::string s;
  for (std::size_t i = 0; i < cia402_.size(); ++i) {
    if (cia402_[i] && !cia402_[i]->cyclic() && cia402_[i]->phase() != Cia402Master::Phase::kFailed) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + ": " + cia402_[i]->not_ready();
    }
  }
  return s;
}

double Hal::cia402_torque(std::size_t i, const DriveCommand& c) const {
  // Cyclic synchronous torque: the impedance closes here, on the last sample the drive sent.
  const Cia402Master& m = *cia402_[i];
  const DriveLimits& l = config_.drives[i].limits;
  const double t = c.t_ff + c.kp * (c.p_des - m.position()) + c.kd * (c.v_des - m.velocity());
  return std::isfinite(t) ? std::clamp(t, l.t_min, l.t_max) : 0.0;
}

void Hal::send_cia402(Cia402Master& m, CanTransport& bus, double now, bool enable, double torque) {
  tx_.clear();
  m.tick(now, enable, torque, tx_);
  for (const CanFrame& f : tx_) bus.send(f);
}

void Hal::begin_tick(std::int64_t tick, double now) {
  now_ = now;
  const double age = have_command_ ? now - command_time_ : 1e9;
  if (safety_.state() == SafetyState::kEnabled && age > config_.safety.command_max_age) ++stale_;
  safety_.update(now, age);
  const DriveMode mode = safety_.drive_mode();
  const bool entering = safety_.entering();
  sensors_.tick = tick;
  sensors_.time = now;
  for (std::size_t i = 0; i < config_.drives.size(); ++i) {
    const DriveConfig& d = config_.drives[i];
    drive_status_[i].replied = false;
    CanTransport& bus = *buses_[static_cast<std::size_t>(d.bus)];
    Cia402Master* co = cia402_[i].get();
    if (mode == DriveMode::kOff) {
      sent_[i] = DriveCommand{};
      if (co != nullptr) {
        send_cia402(*co, bus, now, false, 0.0);
      } else {
        bus.send(codec_->encode_special(d.id, SpecialCommand::kExitMotorMode));
      }
      continue;
    }
    if (entering && co == nullptr) {
      sent_[i] = DriveCommand{};
      bus.send(codec_->encode_special(d.id, SpecialCommand::kEnterMotorMode));
      continue;
    }
    DriveCommand c = damping_command(i);
    const auto j = static_cast<Eigen::Index>(i);
    if (d.held) {
      // A held joint: the hal's own joint impedance at its held position while running; damping
      // and torque off as every drive.
      if (mode == DriveMode::kRun && command_.mode == JointCommand::Mode::kRun) {
        c = DriveCommand{};
        c.p_des = std::clamp(d.sign * (d.held_q - d.offset), d.limits.p_min, d.limits.p_max);
        c.kp = std::min(config_.held_kp, d.limits.kp_max);
        c.kd = std::min(config_.held_kd, d.limits.kd_max);
      } else if (mode == DriveMode::kRun && command_.mode == JointCommand::Mode::kOff) {
        c = DriveCommand{};
      }
    } else if (mode == DriveMode::kRun && command_.mode == JointCommand::Mode::kRun) {
      c.p_des = d.sign * (command_.q_des(j) - d.offset);
      c.v_des = d.sign * command_.qd_des(j);
      c.kp = command_.kp(j);
      c.kd = command_.kd(j);
      c.t_ff = d.sign * command_.tau_ff(j);
      // Soft limits: damping towards rest, ramping in over the last margin before a hard limit. The
      // drive evaluates one kd (v_des − v), so kd (v_des − v) − kd_s v is sent as
      // (kd + kd_s) (v_des kd / (kd + kd_s) − v): the commanded velocity keeps its own damping and
      // the extra damping never pushes towards v_des (a stance knee asked to straighten fast).
      const double q = sensors_.q(j);
      const double dist = std::min(q - d.q_lower, d.q_upper - q);
      if (config_.soft_limit_margin > 0 && dist < config_.soft_limit_margin) {
        const double r = std::clamp((config_.soft_limit_margin - dist) / config_.soft_limit_margin, 0.0, 1.0);
        const double kd = std::min(c.kd + r * config_.soft_limit_kd, d.limits.kd_max);
        if (kd > 0) c.v_des *= c.kd / kd;
        c.kd = kd;
      }
    } else if (mode == DriveMode::kRun && command_.mode == JointCommand::Mode::kOff) {
      c = DriveCommand{};
    }
    // Never a non-finite number on the wire (rejected on input already; this is the last guard).
    if (!std::isfinite(c.p_des) || !std::isfinite(c.v_des) || !std::isfinite(c.kp) || !std::isfinite(c.kd) || !std::isfinite(c.t_ff)) {
      c = damping_command(i);
    }
    sent_[i] = c;
    if (co != nullptr) {
      send_cia402(*co, bus, now, true, cia402_torque(i, c));
    } else {
      bus.send(codec_->encode_command(d.id, c, d.limits));
    }
  }
  if (entering) safety_.entered();
  // One SYNC per bus after its drives' frames: the sensors sample, CiA 402 drives apply their RPDO
  // and answer with their TPDOs.
  for (std::size_t b = 0; b < buses_.size(); ++b) {
    if (sync_bus_[b] != 0) buses_[b]->send(canopen::sync_frame());
  }
  sensor_frames_ = 0;
  std::fill(tick_closed_.begin(), tick_closed_.end(), 0);
  for (auto& b : buses_) b->flush();
}

int Hal::receive() {
  int n = 0;
  for (std::size_t b = 0; b < buses_.size(); ++b) {
    rx_.clear();
    buses_[b]->receive(rx_);
    for (const CanFrame& f : rx_) handle_frame(static_cast<int>(b), f);
    n += static_cast<int>(rx_.size());
  }
  return n;
}

void Hal::handle_frame(int bus, const CanFrame& f) {
  const std::uint32_t id = f.id & kCanSffMask;
  if (config_.lockstep && id == kLockstepTickId) {  // a real device never sends it: unknown unless in lockstep
    if (decode_lockstep_tick(f)) {
      tick_closed_[static_cast<std::size_t>(bus)] = 1;
    } else {
      ++malformed_;
    }
    return;
  }
  if (bus == config_.sensor_bus && (id == kImuQuatId || id == kImuGyroId || id == kImuAccelId || (id >= kFtForceId && id <= kFtTorqueId + 2))) {
    double v[4];
    bool ok = false;
    if (id == kImuQuatId && (ok = decode_int16s(f, v, 4, 1.0 / 32767.0))) {
      sensors_.imu_quat_WB = Eigen::Vector4d(v[0], v[1], v[2], v[3]).normalized();
    } else if (id == kImuGyroId && (ok = decode_int16s(f, v, 3, kImuGyroScale))) {
      sensors_.imu_gyro_B = Eigen::Vector3d(v[0], v[1], v[2]);
    } else if (id == kImuAccelId && (ok = decode_int16s(f, v, 3, kImuAccelScale))) {
      sensors_.imu_accel_B = Eigen::Vector3d(v[0], v[1], v[2]);
    } else if (id >= kFtForceId && id <= kFtTorqueId + 2) {
      const auto s = static_cast<std::size_t>((id - kFtForceId) / 2);
      const bool torque = ((id - kFtForceId) % 2) == 1;
      if ((ok = decode_int16s(f, v, 3, torque ? kFtTorqueScale : kFtForceScale))) {
        sensors_.ft_wrench_S[s].segment<3>(torque ? 3 : 0) = Eigen::Vector3d(v[0], v[1], v[2]);
      }
    }
    if (ok) {
      ++sensor_frames_;
    } else {
      ++malformed_;
    }
    return;
  }
  const int drive_id = static_cast<int>(id) - static_cast<int>(MitCodec::kReplyBase);
  const int i = drive_id >= 0 && drive_id <= MitCodec::kMaxDriveId ? drive_by_id_[static_cast<std::size_t>(bus)][static_cast<std::size_t>(drive_id)] : -1;
  if (i < 0 || cia402_[static_cast<std::size_t>(i)]) {
    if (!handle_canopen(bus, f)) ++malformed_;  // unknown id
    return;
  }
  const auto iu = static_cast<std::size_t>(i);
  const DriveConfig& d = config_.drives[iu];
  const auto r = codec_->decode_reply(f, d.limits);
  if (!r || r->drive_id != d.id) {
    ++malformed_;
    return;
  }
  DriveStatus& ds = drive_status_[iu];
  if (ds.replied) {
    // One reply per drive per tick: a second one (a late reply, a forged frame) never overwrites
    // the first, nor its fault flag; counted, and a fault when it goes on.
    ++ds.extra;
    ds.extra_this_tick = true;
    return;
  }
  ds.fault = r->fault;
  ds.temperature = r->temperature;
  take_reply(iu, r->p, r->v, r->t);
}

bool Hal::handle_canopen(int bus, const CanFrame& f) {
  const canopen::Cob cob = canopen::classify(f);
  if (cob.node < 1 || cob.node > canopen::kMaxNode) return false;
  const int i = drive_by_id_[static_cast<std::size_t>(bus)][static_cast<std::size_t>(cob.node)];
  if (i < 0 || !cia402_[static_cast<std::size_t>(i)]) return false;
  const auto iu = static_cast<std::size_t>(i);
  Cia402Master& m = *cia402_[iu];
  if (!m.on_frame(f, now_)) return false;
  if (m.cyclic() && m.replied() && !drive_status_[iu].replied) take_reply(iu, m.position(), m.velocity(), m.torque());
  return true;
}

void Hal::take_reply(std::size_t i, double p, double v, double t) {
  const DriveConfig& d = config_.drives[i];
  DriveStatus& ds = drive_status_[i];
  if (ds.have_position) {
    // Further than the drive can have turned since the reply taken last: kReachFactor times its
    // velocity range, plus two steps of its position field. (The factor leaves room for what a
    // drive's range does not bound: the simulated light wrists, damped, swing at up to 8.3 times
    // their drives' range, measured over the HIL lockstep and HalCia402 tests.)
    constexpr double kReachFactor = 20.0;
    const double v_max = std::max(std::abs(d.limits.v_min), std::abs(d.limits.v_max));
    const double step = (d.limits.p_max - d.limits.p_min) / 65535.0;
    const double reach = kReachFactor * v_max * std::max(now_ - ds.reply_time, 0.0) + 2.0 * step;
    if (!(std::abs(p - ds.position) <= reach)) {
      ++ds.implausible;
      ++malformed_;
      return;  // not taken: the tick counts it as missed
    }
  }
  ds.have_position = true;
  ds.position = p;
  ds.reply_time = now_;
  ds.replied = true;
  ds.missed_run = 0;
  const auto j = static_cast<Eigen::Index>(i);
  if (d.held) {
    held_q_(j - config_.controlled) = d.sign * p + d.offset;
    return;
  }
  sensors_.q(j) = d.sign * p + d.offset;
  sensors_.qd(j) = d.sign * v;
  sensors_.tau(j) = d.sign * t;
}

bool Hal::replies_complete() const {
  if (sensor_frames_ < sensor_frames_expected_) return false;
  for (std::size_t i = 0; i < drive_status_.size(); ++i) {
    if (!drive_status_[i].replied && expects_reply(i)) return false;
  }
  return true;
}

bool Hal::tick_closed() const {
  return std::all_of(tick_closed_.begin(), tick_closed_.end(), [](char c) { return c != 0; });
}

void Hal::end_tick(double now) {
  const DriveMode mode = safety_.drive_mode();
  for (std::size_t i = 0; i < drive_status_.size(); ++i) {
    DriveStatus& ds = drive_status_[i];
    if (cia402_[i]) {
      cia402_[i]->supervise(now);
      ds.fault = cia402_[i]->fault_code();
    }
    if (!ds.replied && expects_reply(i)) {
      ++ds.missed;
      ++ds.missed_run;
    }
    ds.extra_run = ds.extra_this_tick ? ds.extra_run + 1 : 0;
    ds.extra_this_tick = false;
    std::int32_t bits = 0;
    if (ds.fault != 0) {
      ds.state = kDriveFault;
      bits |= SensorSample::kDriveFault;
    } else if (ds.missed_run > 0) {
      ds.state = kDriveNoReply;
      bits |= SensorSample::kDriveStale;
    } else if (!expects_reply(i)) {
      ds.state = kDriveOff;  // a CiA 402 drive starting up
    } else {
      ds.state = mode == DriveMode::kRun ? kDriveRun
               : mode == DriveMode::kDamp ? kDriveDamp
                                          : kDriveOff;
    }
    if (mode == DriveMode::kRun) bits |= SensorSample::kDriveEnabled;
    if (mode == DriveMode::kDamp) bits |= SensorSample::kDriveDamping;
    if (i < static_cast<std::size_t>(config_.controlled)) sensors_.drive_status[i] = bits;
  }
  const std::string faults = fault_conditions();
  if (!faults.empty()) safety_.fault(now, faults);
}

}  // namespace hpr::hal
