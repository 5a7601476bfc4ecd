// drive_emulator: answers the drive protocol of every joint (and the IMU and F/T sensor frames)
// over the hal's transports, backed by the Bullet simulation. With hal it forms the
// hardware-in-the-loop stand-in: the real codec, transport and safety path against a simulated robot.
#include <poll.h>

#include <array>

#include <humanoid/push_t.hpp>
#include <humanoid/sim_truth_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/common/time.hpp"
#include "hpr/sim/drive_emulator.hpp"
#include "hpr/hal/ports.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/sim/engines.hpp"
#include "hpr/sim/sim_io.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace {

using namespace hpr;

/// The emulator's loop: every request answered at once from the simulation's present state, the
/// physics stepped once per period (lockstep: once per tick of the hal), SIM_TRUTH after each step.
class EmulatorLoop {
 public:
  EmulatorLoop(node::Runtime& rt, const hal::HalConfig& config, const hal::EmulatorOptions& options, sim::Simulator& simulator,
               std::vector<std::unique_ptr<hal::CanTransport>>& buses, hal::DriveEmulator& emu)
      : rt_(rt), config_(config), options_(options), simulator_(simulator), buses_(buses), emu_(emu),
        truth_out_(rt.advertise(msg::channels::kSimTruth)) {
    for (const auto& b : buses_) fds_.push_back({b->fd(), POLLIN, 0});
    fds_.push_back({rt.receive_fd(), POLLIN, 0});
    rx_.reserve(256);
  }

  /// The simulated clock: a period ends when the hal has sent its tick (a frame for every drive and
  /// SYNC), then the physics steps and every bus gets the clock frame. While the hal is silent (not
  /// started, killed) the emulator runs on at one period per period of wall time, so the drives'
  /// own timeout still acts; a tick that has begun may take up to `lockstep_timeout`.
  void run_lockstep(double dt, double duration) {
    std::int64_t tick = 0;
    bool flowing = false;
    while (!rt_.stop_requested()) {
      if (duration > 0 && simulator_.time() >= duration) break;
      const double now = static_cast<double>(tick) * dt;
      const double start = monotonic_s();
      while (!rt_.stop_requested()) {
        serve(now);
        if (emu_.tick_requested()) break;
        const double wait = flowing || emu_.any_requested() ? config_.lockstep_timeout : dt;
        const double left = start + wait - monotonic_s();
        if (left <= 0) break;
        poll_for(fds_, left);
      }
      flowing = emu_.tick_requested();
      const double t0 = monotonic_s();
      emu_.step(now);
      after_step(now, t0, flowing, tick);
      ++tick;
    }
  }

  /// Real time: frames until the period ends, then a step. The periods that started late.
  std::int64_t run_realtime(double dt, double duration) {
    std::int64_t late = 0;
    PeriodicClock clock(dt);
    while (!rt_.stop_requested()) {
      if (duration > 0 && simulator_.time() >= duration) break;
      while (!rt_.stop_requested()) {
        serve(monotonic_s());
        const double left = clock.left();
        if (left <= 0) break;
        poll_for(fds_, left);
      }
      if (clock.next() > 0.5 * dt) ++late;
      const double t0 = monotonic_s();
      emu_.step(t0);
      after_step(t0, t0, false, 0);
    }
    return late;
  }

 private:
  /// Every request answered at once from the present state, and LCM (PUSH) when it has input.
  void serve(double now) {
    for (std::size_t b = 0; b < buses_.size(); ++b) {
      rx_.clear();
      buses_[b]->receive(rx_);
      for (const auto& f : rx_) emu_.handle(static_cast<int>(b), f, now, *buses_[b]);
      buses_[b]->flush();
    }
    if (fds_.back().revents != 0) rt_.spin_once(0.0);
  }

  /// After each physics step: bus state, SIM_TRUTH, the drives' own timeout, what changed.
  void after_step(double now, double t0, bool close_tick, std::int64_t tick) {
    for (std::size_t b = 0; b < buses_.size(); ++b) {
      emu_.report_periodic(static_cast<int>(b), now, *buses_[b]);
      if (close_tick) hal::DriveEmulator::report_tick(tick, *buses_[b]);
      buses_[b]->flush();
    }
    rt_.record_step(simulator_.tick(), monotonic_s() - t0);
    rt_.spin_once(0.0);  // timers (HEALTH) run every period, with or without LCM traffic
    // The drives' own timeout, reported in HEALTH (the hal stopped talking to them).
    int timed_out = 0;
    for (std::size_t i = 0; i < config_.drives.size(); ++i) timed_out += emu_.damping_by_itself(i, now) ? 1 : 0;
    if (timed_out > 0) {
      if (!rt_.has_fault("drive_timeout")) {
        log::warn("{} drives without commands for {} ms: damping by themselves", timed_out, options_.drive_timeout * 1e3);
      }
      rt_.set_fault("drive_timeout", std::to_string(timed_out) + " drives timed out: damping");
    } else {
      rt_.clear_fault("drive_timeout");
    }
    if (emu_.released() && !released_reported_) {
      released_reported_ = true;
      log::info("drives in motor mode: released from the gantry at tick {}", simulator_.tick());
    }
    if (emu_.released()) {
      msg::to_message(simulator_.truth(), kFeet, truth_msg_);
      truth_out_.publish(truth_msg_);
    }
    if (simulator_.truth().fallen && !fallen_reported_) {
      fallen_reported_ = true;
      log::warn("the robot fell at t = {:.3f} s", simulator_.time());
    }
  }

  inline static const std::array<std::string, 2> kFeet{"right", "left"};
  node::Runtime& rt_;
  const hal::HalConfig& config_;
  const hal::EmulatorOptions& options_;
  sim::Simulator& simulator_;
  std::vector<std::unique_ptr<hal::CanTransport>>& buses_;
  hal::DriveEmulator& emu_;
  node::Output<humanoid::sim_truth_t> truth_out_;
  humanoid::sim_truth_t truth_msg_;
  std::vector<pollfd> fds_;
  std::vector<hal::CanFrame> rx_;
  bool fallen_reported_ = false, released_reported_ = false;
};

int run(const node::CommandLine& cl, const Config& cfg) {
  const Config robot_cfg = cfg.section("robot");
  const auto robot = model::RobotSpec::load(robot_cfg);
  const hal::HalConfig config = hal::HalConfig::load(cfg.section("hal"), robot);
  const auto options = cfg.has("emulator") ? hal::EmulatorOptions::load(cfg.section("emulator")) : hal::EmulatorOptions{};
  const Config sim_cfg = cfg.section("sim");
  const sim::SimConfig sim_config = sim::SimConfig::load(sim_cfg);
  sim_cfg.known(sim::kSimProcessKeys);
  const double duration = cfg.has("emulator") ? cfg.section("emulator").real_or("duration", 0.0, 0.0, 1e7) : 0.0;
  node::Runtime rt(hal::kEmulatorPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, sim_config.dt));
  sim::Simulator simulator(robot, sim_config, sim::make_engine);
  auto buses = hal::open_buses(config, true);
  hal::DriveEmulator emu(config, simulator, std::make_unique<hal::MitCodec>(), options);

  const bool push_input = sim_cfg.boolean_or("push_input", true);
  rt.subscribe(msg::channels::kPush, {}, [&](const humanoid::push_t& p) {
    if (!push_input) {
      log::warn("PUSH {} refused: sim.push_input is off", p.id);
      return;
    }
    std::string why;
    const auto push = sim::from_message(p, robot.model, &why);
    if (!push) {
      log::warn("PUSH {} refused: {}", p.id, why);
      return;
    }
    log::info("push {} on '{}': {:.1f} N peak for {:.3f} s", p.id, push->link, push->force_W.norm(), push->duration);
    simulator.add_push(*push);
  });
  EmulatorLoop loop(rt, config, options, simulator, buses, emu);
  log::info("drive emulator: {} drives on {} buses, {}, {} clock (on its gantry until the first enable)", config.drives.size(),
            config.buses.size(), robot.name, config.lockstep ? "lockstep" : "realtime");
  std::int64_t late = 0;
  if (config.lockstep) {
    loop.run_lockstep(sim_config.dt, duration);
  } else {
    late = loop.run_realtime(sim_config.dt, duration);
  }
  log::info("drive emulator stopped at t = {:.3f} s; late periods {}, frames ignored {}", simulator.time(), late, emu.frames_ignored());
  return node::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return hpr::node::run_main(argc, argv, "drive_emulator", "joint drives and sensors on CAN, backed by the Bullet simulation", run);
}
