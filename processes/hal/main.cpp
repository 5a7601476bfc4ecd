// hal: the hardware abstraction. JOINT_COMMAND and OPERATOR in, MIT-mode frames to the joint drives
// over SocketCAN (or cannelloni UDP), ROBOT_SENSORS and HAL_STATUS out, safety at the motors.
#include <poll.h>

#include <humanoid/hal_status_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/common/time.hpp"
#include "hpr/hal/bus_load.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/hal/ports.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace {

using namespace hpr;

// The hal library's codes are the message constants.
static_assert(hal::kDriveRun == humanoid::hal_status_t::DRIVE_RUN && hal::kDriveNoReply == humanoid::hal_status_t::DRIVE_NO_REPLY &&
              hal::kDriveFault == humanoid::hal_status_t::DRIVE_FAULT && hal::kDriveDamp == humanoid::hal_status_t::DRIVE_DAMP);
static_assert(int{SensorSample::kDriveEnabled} == int{humanoid::robot_sensors_t::DRIVE_ENABLED} && int{SensorSample::kDriveDamping} == int{humanoid::robot_sensors_t::DRIVE_DAMPING} &&
              int{SensorSample::kDriveFault} == int{humanoid::robot_sensors_t::DRIVE_FAULT} && int{SensorSample::kDriveStale} == int{humanoid::robot_sensors_t::DRIVE_STALE});
static_assert(hal::kOperatorEnable == humanoid::operator_t::COMMAND_ENABLE && hal::kOperatorDamp == humanoid::operator_t::COMMAND_DAMP &&
              hal::kOperatorStop == humanoid::operator_t::COMMAND_STOP);
static_assert(static_cast<int>(hal::SafetyState::kFault) == humanoid::hal_status_t::STATE_FAULT &&
              static_cast<int>(hal::SafetyState::kTorqueOff) == humanoid::hal_status_t::STATE_TORQUE_OFF);

/// `commands_rejected`: every JOINT_COMMAND refused, whatever refused it (decoder, joint names, the
/// hal's limits, a tick outside the window); the runtime's input counts them all.
void fill_status(const hal::Hal& h, std::int64_t tick, humanoid::hal_status_t& m, const std::vector<double>& tx_fps,
                 const std::vector<double>& rx_fps, std::int64_t commands_rejected) {
  const auto& c = h.config();
  m.tick = tick;
  m.utime = wall_us();
  m.state = static_cast<std::int8_t>(h.safety().state());
  m.state_reason = h.safety().reason();
  m.num_drives = static_cast<std::int32_t>(c.drives.size());
  m.drive_joint.resize(c.drives.size());
  m.drive_id.resize(c.drives.size());
  m.drive_state.resize(c.drives.size());
  m.drive_temperature.resize(c.drives.size());
  m.drive_fault.resize(c.drives.size());
  m.drive_missed.resize(c.drives.size());
  m.drive_missed_run.resize(c.drives.size());
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const auto& d = h.drives()[i];
    m.drive_joint[i] = c.drives[i].joint;
    m.drive_id[i] = c.drives[i].id;
    m.drive_state[i] = d.state;
    m.drive_temperature[i] = d.temperature;
    m.drive_fault[i] = d.fault;
    m.drive_missed[i] = d.missed;
    m.drive_missed_run[i] = d.missed_run;
  }
  m.num_buses = static_cast<std::int32_t>(c.buses.size());
  m.bus_name.resize(c.buses.size());
  m.bus_tx_fps = tx_fps;
  m.bus_rx_fps = rx_fps;
  m.bus_errors.resize(c.buses.size());
  m.bus_off.resize(c.buses.size());
  for (std::size_t b = 0; b < c.buses.size(); ++b) {
    m.bus_name[b] = c.buses[b].name;
    m.bus_errors[b] = h.buses()[b]->counters().errors;
    m.bus_off[b] = h.buses()[b]->counters().bus_off;
  }
  m.commands_rejected = commands_rejected;
  m.commands_stale = h.commands_stale();
  m.frames_malformed = h.frames_malformed();
}

/// Frames per second on each bus, over the last 0.1 s or more.
struct BusRates {
  BusRates(std::size_t buses, double start) : tx_prev(buses, 0), rx_prev(buses, 0), tx_fps(buses, 0.0), rx_fps(buses, 0.0), last(start) {}
  void update(const hal::Hal& h, double now) {
    if (now - last < 0.1) return;
    for (std::size_t b = 0; b < tx_fps.size(); ++b) {
      const auto& cnt = h.buses()[b]->counters();
      tx_fps[b] = static_cast<double>(cnt.tx_frames - tx_prev[b]) / (now - last);
      rx_fps[b] = static_cast<double>(cnt.rx_frames - rx_prev[b]) / (now - last);
      tx_prev[b] = cnt.tx_frames;
      rx_prev[b] = cnt.rx_frames;
    }
    last = now;
  }
  std::vector<std::int64_t> tx_prev, rx_prev;
  std::vector<double> tx_fps, rx_fps;
  double last;
};

/// Lockstep: the next tick starts when the controllers have answered this one; while they are
/// silent (starting, killed) the hal runs on at one tick per period of wall time, so commands age
/// and the safety rules act as on the robot. Controllers that answer, only later than a period (a
/// loaded machine), are waited for: a lockstep run must not depend on timing.
class LockstepPacer {
 public:
  template <class Input>
  void wait(node::Runtime& rt, const Input& command_in, std::int64_t answered, double w0, const hal::HalConfig& config) {
    if (flowing_) {
      flowing_ = rt.spin_until([&] { return command_in.tick() >= answered; }, config.lockstep_timeout);
    } else {
      const double until = w0 + config.period;
      while (!rt.stop_requested() && command_in.tick() < answered) {
        const double left = until - monotonic_s();
        if (left <= 0) break;
        rt.spin_once(left);
      }
      if (command_in.tick() < answered && command_in.count() > heard_) {
        rt.spin_until([&] { return command_in.tick() >= answered; }, config.lockstep_timeout);
      }
      flowing_ = command_in.tick() >= answered;
    }
    heard_ = command_in.count();
  }

 private:
  bool flowing_ = false;    ///< the controllers answered the last tick
  std::int64_t heard_ = 0;  ///< JOINT_COMMANDs received when the last tick closed
};

/// The drives' replies of the tick: within the reply window (lockstep: until every bus has the
/// emulator's clock frame), one poll per wait.
void receive_replies(hal::Hal& h, std::vector<pollfd>& fds, const hal::HalConfig& config, double t0, double w0) {
  const double reply_deadline = config.lockstep ? w0 + config.lockstep_timeout : t0 + config.reply_window;
  while (true) {
    h.receive();
    if (config.lockstep ? h.tick_closed() : h.replies_complete()) break;
    const double left = reply_deadline - monotonic_s();
    if (left <= 0) break;
    poll_for(fds, left);
  }
}

/// Whether the safety state changed this tick (said in the log).
bool note_state_change(hal::Hal& h, hal::SafetyState& last_state) {
  const bool changed = h.safety().state() != last_state || h.safety().changed();
  if (changed) {
    log::info("state {}: {}", hal::to_string(h.safety().state()), h.safety().reason());
    last_state = h.safety().state();
    h.clear_changed();
  }
  return changed;
}

/// The lifecycle: drives off until enabled (starting), enabled (running), else damping.
void report_lifecycle(node::Runtime& rt, const hal::Hal& h) {
  switch (h.safety().state()) {
    case hal::SafetyState::kOff: rt.report(node::StepOutcome::kNotReady); break;
    case hal::SafetyState::kEnabled: rt.report(node::StepOutcome::kRunning); break;
    default: rt.report(node::StepOutcome::kDamping); break;
  }
}

/// The run's figures, when it stops.
void log_summary(const hal::Hal& h, std::int64_t ticks, const RollingStats& work, const RollingStats& jitter, std::int64_t rejected) {
  std::int64_t missed = 0, extra = 0, implausible = 0, foreign = 0;
  for (const auto& d : h.drives()) {
    missed += d.missed;
    extra += d.extra;
    implausible += d.implausible;
  }
  for (const auto& b : h.buses()) foreign += b->counters().foreign;
  log::info("hal stopped after {} ticks: tick work median {:.1f} us, p99 {:.1f} us; {}; "
            "commands rejected {} (repeated ticks {}), stale ticks {}, malformed frames {}; replies missed {} of {}, "
            "beyond one a tick {}, positions out of reach {}; datagrams from strangers {}",
            ticks, work.median() * 1e6, work.percentile(0.99) * 1e6,
            h.config().lockstep ? std::string("lockstep clock")
                                : fmt::format("period jitter p99 {:.1f} us, max {:.1f} us", jitter.percentile(0.99) * 1e6, jitter.max() * 1e6),
            rejected, h.commands_repeated(), h.commands_stale(), h.frames_malformed(), missed,
            ticks * static_cast<std::int64_t>(h.drives().size()), extra, implausible, foreign);
}

int run(const node::CommandLine& cl, const Config& cfg) {
  const Config robot_cfg = cfg.section("robot");
  const auto robot = model::RobotSpec::load(robot_cfg);
  const Config hal_cfg = cfg.section("hal");
  hal::HalConfig config = hal::HalConfig::load(hal_cfg, robot);
  const bool enable_on_start = hal_cfg.boolean_or("enable_on_start", false);
  const double duration = hal_cfg.real_or("duration", 0.0, 0.0, 1e7);
  const node::RuntimeOptions options = node::runtime_options(cfg, config.period);
  // On a real bus anyone on the LCM group could enable the drives without the key: refused.
  for (const hal::BusConfig& b : config.buses) {
    if (b.transport == "socketcan" && !options.authenticate) {
      throw ConfigError(fmt::format("{}: lcm.authentication = off with bus {} on SocketCAN ({}): a hal on a real bus takes commands "
                                    "signed with the deployment's key only (give it a key file; off is for the UDP emulator)",
                                    cl.config_path, b.name, b.interface));
    }
  }
  node::Runtime rt(hal::kPorts, cl.name, node::lcm_url(cl, cfg), options);
  hal::Hal h(config, hal::open_buses(config, false), std::make_unique<hal::MitCodec>());
  for (std::size_t b = 0; b < config.buses.size(); ++b) {
    log::info("bus {}: {}", config.buses[b].name, h.buses()[b]->describe());
    // The bus behind the transport (a cannelloni gateway's too) must carry one tick within a period.
    const auto bus = static_cast<int>(b);
    if (hal::tick_load(config, bus).busy.worst_case > config.period) {
      log::warn("bus load {}: above the period with worst-case bit stuffing; move a drive to another bus", hal::describe_load(config, bus));
    } else {
      log::info("bus load {}", hal::describe_load(config, bus));
    }
  }

  msg::RobotNames names;
  names.joints = robot.model.joint_name;
  // Hal time [s]: the monotonic clock on the robot; tick × period in lockstep (the emulator's clock).
  const bool lockstep = config.lockstep;
  double t_tick = 0.0;  // the present tick's hal time
  auto hal_now = [&] { return lockstep ? t_tick : monotonic_s(); };
  JointCommand command;
  command.resize(robot.model.nj);
  auto& command_in = rt.subscribe(msg::channels::kJointCommand, [&](const humanoid::joint_command_t& m) {
    std::string why = msg::from_message(m, names, command);
    if (why.empty()) why = h.set_command(command, hal_now());
    return why;  // rejected commands are counted by the runtime and by the hal, never sent
  });
  command_in.follow_ticks();  // a forged or corrupted tick is held back, never applied
  rt.subscribe(msg::channels::kOperator, msg::check_operator, [&](const humanoid::operator_t& m) {
    const std::string what = h.operator_command(m.command, hal_now(), m.source.empty() ? "operator" : m.source, m.utime);
    if (!what.empty()) log::info("OPERATOR {}: {}{}", m.command, what, m.reason.empty() ? "" : " (" + m.reason + ")");
  });
  auto sensors_out = rt.advertise(msg::channels::kRobotSensors);
  auto status_out = rt.advertise(msg::channels::kHalStatus);
  humanoid::robot_sensors_t sensors_msg;
  humanoid::hal_status_t status_msg;

  std::vector<pollfd> fds;
  for (const auto& b : h.buses()) fds.push_back({b->fd(), POLLIN, 0});
  RollingStats work(60000), jitter(60000);
  PeriodicClock clock(config.period);
  const double start = hal_now();
  BusRates rates(config.buses.size(), start);
  LockstepPacer pacer;
  double last_status = -1.0;
  std::int64_t tick = 0;
  hal::SafetyState last_state = h.safety().state();
  // CiA 402 drives start up first (NMT, SDO configuration); an enable waits for them.
  bool enable_pending = enable_on_start;
  bool starting = !h.starting_drives().empty();
  if (starting) log::info("CiA 402 drives starting: {}", h.starting_drives());
  log::info("hal: {} drives on {} buses, period {} ms, {}, command max age {} ms, state {}", config.drives.size(), config.buses.size(),
            config.period * 1e3,
            lockstep ? fmt::format("lockstep clock (waits up to {} s)", config.lockstep_timeout)
                     : fmt::format("reply window {} ms", config.reply_window * 1e3),
            config.safety.command_max_age * 1e3, hal::to_string(h.safety().state()));
  while (!rt.stop_requested()) {
    t_tick = lockstep ? static_cast<double>(tick) * config.period : monotonic_s();
    const double t0 = t_tick, w0 = monotonic_s();
    if (duration > 0 && t0 - start >= duration) break;
    if (!lockstep) jitter.add(t0 - clock.deadline());
    rt.spin_once(0.0);  // the freshest JOINT_COMMAND and OPERATOR before the frames go out
    h.begin_tick(tick, t0);
    receive_replies(h, fds, config, t0, w0);
    h.end_tick(t0);
    if (starting && h.starting_drives().empty()) {
      starting = false;
      log::info("CiA 402 drives started in {:.3f} s{}", t0 - start, h.fault_conditions().empty() ? "" : "; faults: " + h.fault_conditions());
    }
    if (enable_pending && !starting) {
      enable_pending = false;
      log::info("{}", h.operator_command(humanoid::operator_t::COMMAND_ENABLE, t0, "configuration", wall_us()));
    }
    // utime is the hal's clock (h.sensors().time = t0): monotonic in real time, tick × period in
    // lockstep. The estimator integrates over it, so it must advance as the drives' time does (a
    // wall-clock stamp ran ahead of a slow lockstep chain) and never jump (an NTP step would).
    msg::to_message(h.sensors(), names, sensors_msg);
    sensors_out.publish(sensors_msg);
    const double now = lockstep ? t0 : monotonic_s();
    rates.update(h, now);
    const bool changed = note_state_change(h, last_state);
    report_lifecycle(rt, h);
    if (changed || now - last_status >= 0.1) {
      fill_status(h, tick, status_msg, rates.tx_fps, rates.rx_fps, command_in.errors());
      status_out.publish(status_msg);
      last_status = now;
      const std::string faults = h.fault_conditions();
      if (faults.empty()) {
        rt.clear_fault("drives");
      } else {
        rt.set_fault("drives", faults);
      }
    }
    rt.record_step(tick, monotonic_s() - w0);
    work.add(monotonic_s() - w0);
    ++tick;
    if (lockstep) {
      pacer.wait(rt, command_in, tick - 1, w0, config);
      continue;
    }
    clock.next();
    while (!rt.stop_requested()) {
      const double left = clock.left();
      if (left <= 0) break;
      rt.spin_once(left);
    }
  }
  log_summary(h, tick, work, jitter, command_in.errors());
  return node::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return hpr::node::run_main(argc, argv, "hal", "hardware abstraction: joint drives over SocketCAN or cannelloni UDP", run);
}
