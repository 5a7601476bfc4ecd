#include "hpr/hal/hal.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "hpr/hal/cannelloni.hpp"
#include "hpr/hal/socketcan.hpp"

namespace hpr::hal {

namespace {

std::pair<double, double> range(const Config& c, const std::string& key, double lo, double hi) {
  if (!c.has(key)) return {lo, hi};
  const auto v = c.reals(key, 2);
  if (!(v[0] < v[1])) throw ConfigError(c.file() + ": " + c.full_key(key) + ": [" + std::to_string(v[0]) + ", " +
                                        std::to_string(v[1]) + "] is not an interval with min < max");
  return {v[0], v[1]};
}

/// The buses (`buses`), with the top level's transport defaults: `transport`, and for udp the
/// hosts and a base port (bus b: hal at base + 2b, the drives' side at base + 2b + 1) unless a bus
/// gives `local` and `remote`. Each bus's index by name.
std::map<std::string, int> load_buses(const Config& c, std::vector<BusConfig>& buses) {
  std::map<std::string, int> bus_index;
  const std::string transport = c.choice_or("transport", "udp", {"socketcan", "udp"});
  const std::string hal_host = c.string_or("udp_hal_host", "127.0.0.1");
  const std::string drive_host = c.string_or("udp_drive_host", "127.0.0.1");
  const long base_port = c.integer_or("udp_base_port", 21000, 1024, 65000);
  for (const Config& b : c.items("buses")) {
    BusConfig bc;
    bc.name = b.string("name");
    bc.transport = b.choice_or("transport", transport, {"socketcan", "udp"});
    bc.fd = b.boolean_or("fd", false);
    if (bc.transport == "socketcan") {
      bc.interface = b.string_or("interface", bc.name);
    } else {
      const long port = base_port + 2 * static_cast<long>(buses.size());
      bc.local = b.string_or("local", hal_host + ":" + std::to_string(port));
      bc.remote = b.string_or("remote", drive_host + ":" + std::to_string(port + 1));
      for (const auto* e : {&bc.local, &bc.remote}) {
        try {
          (void)UdpEndpoint::parse(*e);
        } catch (const std::exception& ex) {
          throw ConfigError(b.file() + ": " + b.full_key(e == &bc.local ? "local" : "remote") + ": " + ex.what());
        }
      }
    }
    if (!bus_index.emplace(bc.name, static_cast<int>(buses.size())).second) {
      throw ConfigError(b.file() + ": " + b.full_key("name") + ": bus '" + bc.name + "' is defined twice");
    }
    buses.push_back(bc);
  }
  if (buses.empty()) throw ConfigError(c.file() + ": " + c.full_key("buses") + ": no bus configured");
  return bus_index;
}

/// The index of the bus named by `where`'s `key`.
int bus_of(const Config& where, const std::string& key, const std::map<std::string, int>& bus_index) {
  const std::string name = where.string(key);
  const auto it = bus_index.find(name);
  if (it == bus_index.end()) throw ConfigError(where.file() + ": " + where.full_key(key) + ": unknown bus '" + name + "'");
  return it->second;
}

/// The joint an entry of `drives` names: a controlled joint's index, or nj + k for the k-th held one.
int drive_joint(const Config& d, const model::Model& m) {
  const std::string joint = d.string("joint");
  for (std::size_t k = 0; k < m.held_joint_name.size(); ++k) {
    if (m.held_joint_name[k] == joint) return m.nj + static_cast<int>(k);
  }
  try {
    return m.joint_index(joint);
  } catch (const std::exception&) {
    throw ConfigError(d.file() + ": " + d.full_key("joint") + ": '" + joint + "' is not a joint of " + m.source);
  }
}

/// An entry of `drives` into `dc` (joint `j`): its id, sign, offset, and limits in drive units
/// (from the joint's limits, the model's or for a held joint the URDF's; a `limits` block overrides).
void load_drive(const Config& d, int j, const model::RobotSpec& robot, const DriveDefaults& defaults, DriveConfig& dc) {
  const model::Model& m = robot.model;
  dc.joint = d.string("joint");
  dc.joint_index = j;
  dc.id = static_cast<int>(d.integer("id", 1, MitCodec::kMaxDriveId));
  const double sign = d.real_or("sign", 1.0);
  if (sign != 1.0 && sign != -1.0) throw ConfigError(d.file() + ": " + d.full_key("sign") + ": " + std::to_string(sign) + " is not 1 or -1");
  dc.sign = sign;
  dc.offset = d.real_or("offset", 0.0, -10.0, 10.0);
  double q_lower = -1e9, q_upper = 1e9, v_max = 0.0, tau_max = 0.0;
  if (j < m.nj) {
    const auto ju = static_cast<std::size_t>(j);
    q_lower = m.q_lower[ju], q_upper = m.q_upper[ju], v_max = m.v_max[ju], tau_max = m.tau_max[ju];
  } else {
    const model::JointDesc& jd = *robot.description.find_joint(dc.joint);
    dc.held = true;
    dc.held_q = m.held_q[static_cast<std::size_t>(j - m.nj)];
    if (jd.has_limits && jd.type != model::JointType::kContinuous) q_lower = jd.lower, q_upper = jd.upper;
    if (jd.has_limits) v_max = jd.velocity, tau_max = jd.effort;
  }
  dc.q_lower = q_lower;
  dc.q_upper = q_upper;
  dc.limits = default_limits(defaults, dc, v_max, tau_max);
  DriveLimits& l = dc.limits;
  if (d.has("limits")) {
    const Config lc = d.section("limits");
    std::tie(l.p_min, l.p_max) = range(lc, "position", l.p_min, l.p_max);
    std::tie(l.v_min, l.v_max) = range(lc, "velocity", l.v_min, l.v_max);
    std::tie(l.kp_min, l.kp_max) = range(lc, "kp", l.kp_min, l.kp_max);
    std::tie(l.kd_min, l.kd_max) = range(lc, "kd", l.kd_min, l.kd_max);
    std::tie(l.t_min, l.t_max) = range(lc, "torque", l.t_min, l.t_max);
    if (l.kp_min != 0.0 || l.kd_min != 0.0) throw ConfigError(lc.file() + ": " + lc.full_key("kp") + ": gain ranges must start at 0");
  }
}

}  // namespace

HalConfig HalConfig::load(const Config& c, const model::RobotSpec& robot) {
  const model::Model& m = robot.model;
  c.reject_unknown({"period", "reply_window", "transport", "udp_hal_host", "udp_drive_host", "udp_base_port", "enable_on_start",
                    "duration", "damping_kd", "soft_limit_margin", "soft_limit_kd", "safety", "drive_defaults", "sensors", "buses",
                    "drives", "clock", "lockstep_timeout", "held_joints"});
  HalConfig h;
  h.file = c.file();
  h.period = c.real_or("period", h.period, 1e-4, 0.1);
  h.reply_window = c.real_or("reply_window", h.reply_window, 0.0, h.period);
  h.lockstep = c.choice_or("clock", "realtime", {"realtime", "lockstep"}) == "lockstep";
  h.lockstep_timeout = c.real_or("lockstep_timeout", h.lockstep_timeout, 1e-3, 60.0);
  h.damping_kd = c.real_or("damping_kd", h.damping_kd, 0.0, 1e4);
  h.soft_limit_margin = c.real_or("soft_limit_margin", h.soft_limit_margin, 0.0, 1.0);
  h.soft_limit_kd = c.real_or("soft_limit_kd", h.soft_limit_kd, 0.0, 1e4);
  if (c.has("held_joints")) {
    const Config hj = c.section("held_joints");
    hj.reject_unknown({"kp", "kd"});
    h.held_kp = hj.real_or("kp", h.held_kp, 0.0, 1e5);
    h.held_kd = hj.real_or("kd", h.held_kd, 0.0, 1e4);
  }
  if (c.has("safety")) {
    const Config s = c.section("safety");
    s.reject_unknown({"command_max_age", "torque_off_after", "missed_replies_fault"});
    h.safety.command_max_age = s.real_or("command_max_age", h.safety.command_max_age, 1e-4, 1.0);
    h.safety.torque_off_after = s.real_or("torque_off_after", h.safety.torque_off_after, 0.0, 60.0);
    h.safety.missed_replies_fault = static_cast<int>(s.integer_or("missed_replies_fault", h.safety.missed_replies_fault, 1, 1000));
  }
  const std::map<std::string, int> bus_index = load_buses(c, h.buses);
  if (c.has("sensors")) h.sensor_bus = bus_of(c.section("sensors"), "bus", bus_index);

  const DriveDefaults defaults = DriveDefaults::load(c.has("drive_defaults") ? c.section("drive_defaults") : c);
  h.controlled = m.nj;
  h.drives.assign(static_cast<std::size_t>(m.nj) + m.held_joint_name.size(), DriveConfig{});
  std::set<std::pair<int, int>> ids;
  for (const Config& d : c.items("drives")) {
    const int j = drive_joint(d, m);
    DriveConfig& dc = h.drives[static_cast<std::size_t>(j)];
    if (dc.joint_index >= 0) {
      throw ConfigError(d.file() + ": " + d.full_key("joint") + ": joint '" + d.string("joint") + "' is mapped twice");
    }
    dc.bus = bus_of(d, "bus", bus_index);
    load_drive(d, j, robot, defaults, dc);
    if (!ids.emplace(dc.bus, dc.id).second) {
      throw ConfigError(d.file() + ": " + d.full_key("id") + ": drive id " + std::to_string(dc.id) + " is used twice on bus '" +
                        h.buses[static_cast<std::size_t>(dc.bus)].name + "'");
    }
  }
  for (std::size_t j = 0; j < h.drives.size(); ++j) {
    if (h.drives[j].joint_index < 0) {
      const std::string name = j < static_cast<std::size_t>(m.nj) ? m.joint_name[j] : m.held_joint_name[j - static_cast<std::size_t>(m.nj)];
      throw ConfigError(c.file() + ": " + c.full_key("drives") + ": joint '" + name + "' has no drive" +
                        (j < static_cast<std::size_t>(m.nj) ? "" : " (a held joint: the hal holds it)"));
    }
  }
  return h;
}

std::vector<std::unique_ptr<CanTransport>> open_buses(const HalConfig& c, bool emulator_side) {
  std::vector<std::unique_ptr<CanTransport>> out;
  for (std::size_t b = 0; b < c.buses.size(); ++b) {
    const BusConfig& bc = c.buses[b];
    if (bc.transport == "udp") {
      const auto local = UdpEndpoint::parse(emulator_side ? bc.remote : bc.local);
      const auto remote = UdpEndpoint::parse(emulator_side ? bc.local : bc.remote);
      out.push_back(std::make_unique<UdpCannelloniTransport>(bc.name, local, remote));
      continue;
    }
    // Receive filters: the hal hears replies and sensor frames, a drive emulator hears commands and SYNC.
    std::vector<SocketCanFilter> filters;
    for (const auto& d : c.drives) {
      if (d.bus != static_cast<int>(b)) continue;
      filters.push_back({emulator_side ? static_cast<std::uint32_t>(d.id) : MitCodec::kReplyBase + static_cast<std::uint32_t>(d.id), kCanSffMask});
    }
    if (c.sensor_bus == static_cast<int>(b)) {
      if (emulator_side) {
        filters.push_back({kSyncId, kCanSffMask});
      } else {
        filters.push_back({0x180, 0x7F0});  // IMU 0x180-0x18F
        filters.push_back({0x190, 0x7F0});  // F/T 0x190-0x19F
      }
    }
    if (c.lockstep && !emulator_side) filters.push_back({kLockstepTickId, kCanSffMask});
    out.push_back(std::make_unique<SocketCanTransport>(bc.interface, bc.fd, filters));
  }
  return out;
}

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
  rx_.reserve(256);
}

std::string Hal::set_command(const JointCommand& c, double now) {
  const std::string why = check_command(c, config_.drives, config_.controlled);
  if (!why.empty()) {
    ++rejected_;
    return why;
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
    if (ds.fault != 0) s += (s.empty() ? "" : "; ") + config_.drives[i].joint + " fault code " + std::to_string(ds.fault);
    if (ds.missed_run >= config_.safety.missed_replies_fault) {
      s += (s.empty() ? "" : "; ") + config_.drives[i].joint + " missed " + std::to_string(ds.missed_run) + " replies";
    }
  }
  return s;
}

std::string Hal::operator_command(int command, double now, const std::string& source) {
  switch (command) {
    case kOperatorEnable: {
      const std::string faults = fault_conditions();
      if (faults.empty()) {
        for (auto& b : buses_) b->clear_bus_off();
      }
      const std::string why = safety_.enable(now, !faults.empty(), faults);
      return why.empty() ? "enabled by " + source : why;
    }
    case kOperatorDamp:
    case kOperatorStop:
      safety_.damp(now, std::string(command == kOperatorStop ? "stop" : "damp") + " from " + source);
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

void Hal::begin_tick(std::int64_t tick, double now) {
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
    if (mode == DriveMode::kOff) {
      sent_[i] = DriveCommand{};
      bus.send(codec_->encode_special(d.id, SpecialCommand::kExitMotorMode));
      continue;
    }
    if (entering) {
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
    bus.send(codec_->encode_command(d.id, c, d.limits));
  }
  if (entering) safety_.entered();
  if (config_.sensor_bus >= 0) {
    CanFrame sync;
    sync.id = kSyncId;
    sync.len = 0;
    buses_[static_cast<std::size_t>(config_.sensor_bus)]->send(sync);
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
  if (bus == config_.sensor_bus && id >= kImuQuatId && id <= kFtTorqueId + 2) {
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
  if (i < 0) {
    ++malformed_;  // unknown id
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
  ds.replied = true;
  ds.missed_run = 0;
  ds.fault = r->fault;
  ds.temperature = r->temperature;
  if (d.held) {
    held_q_(i - config_.controlled) = d.sign * r->p + d.offset;
    return;
  }
  sensors_.q(i) = d.sign * r->p + d.offset;
  sensors_.qd(i) = d.sign * r->v;
  sensors_.tau(i) = d.sign * r->t;
}

bool Hal::replies_complete() const {
  if (sensor_frames_ < sensor_frames_expected_) return false;
  return std::all_of(drive_status_.begin(), drive_status_.end(), [](const DriveStatus& d) { return d.replied; });
}

bool Hal::tick_closed() const {
  return std::all_of(tick_closed_.begin(), tick_closed_.end(), [](char c) { return c != 0; });
}

void Hal::end_tick(double now) {
  const DriveMode mode = safety_.drive_mode();
  for (std::size_t i = 0; i < drive_status_.size(); ++i) {
    DriveStatus& ds = drive_status_[i];
    if (!ds.replied) {
      ++ds.missed;
      ++ds.missed_run;
    }
    std::int32_t bits = 0;
    if (ds.fault != 0) {
      ds.state = kDriveFault;
      bits |= SensorSample::kDriveFault;
    } else if (ds.missed_run > 0) {
      ds.state = kDriveNoReply;
      bits |= SensorSample::kDriveStale;
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
