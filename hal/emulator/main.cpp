// drive_emulator: answers the drive protocol of every joint (and the IMU and F/T sensor frames)
// over the hal's transports, backed by the Bullet simulation. With hal it forms the
// hardware-in-the-loop stand-in: the real codec, transport and safety path against a simulated robot.
#include <poll.h>

#include <humanoid/push_t.hpp>
#include <humanoid/sim_truth_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/hal/drive_emulator.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/sim/sim_io.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace {

using namespace hpr;

int run(const node::CommandLine& cl, const Config& cfg) {
  const Config robot_cfg = cfg.section("robot");
  const auto robot = model::RobotSpec::load(robot_cfg);
  const hal::HalConfig config = hal::HalConfig::load(cfg.section("hal"), robot);
  const auto options = cfg.has("emulator") ? hal::EmulatorOptions::load(cfg.section("emulator")) : hal::EmulatorOptions{};
  const Config sim_cfg = cfg.section("sim");
  const sim::SimConfig sim_config = sim::SimConfig::load(sim_cfg);
  sim_cfg.known(sim::kSimProcessKeys);
  const double duration = cfg.has("emulator") ? cfg.section("emulator").real_or("duration", 0.0, 0.0, 1e7) : 0.0;
  node::Runtime rt(cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, sim_config.dt));
  sim::Simulator simulator(robot, sim_config);
  auto buses = hal::open_buses(config, true);
  hal::DriveEmulator emu(config, simulator, std::make_unique<hal::MitCodec>(), options);

  rt.subscribe<humanoid::push_t>("PUSH", {}, [&](const humanoid::push_t& p) {
    std::string why;
    const auto push = sim::from_message(p, robot.model, &why);
    if (!push) {
      log::warn("PUSH {} refused: {}", p.id, why);
      return;
    }
    log::info("push {} on '{}': {:.1f} N peak for {:.3f} s", p.id, push->link, push->force_W.norm(), push->duration);
    simulator.add_push(*push);
  });
  auto truth_out = rt.advertise<humanoid::sim_truth_t>("SIM_TRUTH");
  humanoid::sim_truth_t truth_msg;
  const std::array<std::string, 2> feet{"right", "left"};

  std::vector<pollfd> fds;
  for (const auto& b : buses) fds.push_back({b->fd(), POLLIN, 0});
  fds.push_back({rt.lcm().getFileno(), POLLIN, 0});
  std::vector<hal::CanFrame> rx;
  rx.reserve(256);
  // Every request answered at once from the present state, and LCM (PUSH) when it has input.
  auto serve = [&](double now) {
    for (std::size_t b = 0; b < buses.size(); ++b) {
      rx.clear();
      buses[b]->receive(rx);
      for (const auto& f : rx) emu.handle(static_cast<int>(b), f, now, *buses[b]);
      buses[b]->flush();
    }
    if (fds.back().revents != 0) rt.spin_once(0.0);
  };
  bool fallen_reported = false, released_reported = false;
  // After each physics step: bus state, SIM_TRUTH, the drives' own timeout, what changed.
  auto after_step = [&](double now, double t0, bool close_tick, std::int64_t tick) {
    for (std::size_t b = 0; b < buses.size(); ++b) {
      emu.report_bus_state(static_cast<int>(b), *buses[b]);
      if (close_tick) hal::DriveEmulator::report_tick(tick, *buses[b]);
      buses[b]->flush();
    }
    rt.record_step(simulator.tick(), monotonic_s() - t0);
    rt.spin_once(0.0);  // timers (HEALTH) run every period, with or without LCM traffic
    // The drives' own timeout, reported in HEALTH (the hal stopped talking to them).
    int timed_out = 0;
    for (std::size_t i = 0; i < config.drives.size(); ++i) timed_out += emu.motor_mode(i) && emu.timed_out(i, now) ? 1 : 0;
    if (timed_out > 0) {
      if (!rt.has_fault("drive_timeout")) log::warn("{} drives without commands for {} ms: damping by themselves", timed_out, options.drive_timeout * 1e3);
      rt.set_fault("drive_timeout", std::to_string(timed_out) + " drives timed out: damping");
    } else {
      rt.clear_fault("drive_timeout");
    }
    if (emu.released() && !released_reported) {
      released_reported = true;
      log::info("drives in motor mode: released from the gantry at tick {}", simulator.tick());
    }
    if (emu.released()) {
      msg::to_message(simulator.truth(), feet, truth_msg);
      truth_out.publish(truth_msg);
    }
    if (simulator.truth().fallen && !fallen_reported) {
      fallen_reported = true;
      log::warn("the robot fell at t = {:.3f} s", simulator.time());
    }
  };
  std::int64_t late = 0;
  log::info("drive emulator: {} drives on {} buses, {}, {} clock (on its gantry until the first enable)", config.drives.size(),
            config.buses.size(), robot.name, config.lockstep ? "lockstep" : "realtime");
  if (config.lockstep) {
    // The simulated clock: a period ends when the hal has sent its tick (a frame for every drive and
    // SYNC), then the physics steps and every bus gets the clock frame. While the hal is silent
    // (not started, killed) the emulator runs on at one period per period of wall time, so the
    // drives' own timeout still acts; a tick that has begun may take up to `lockstep_timeout`.
    std::int64_t tick = 0;
    bool flowing = false;
    while (!rt.stop_requested()) {
      if (duration > 0 && simulator.time() >= duration) break;
      const double now = static_cast<double>(tick) * sim_config.dt;
      const double start = monotonic_s();
      while (!rt.stop_requested()) {
        serve(now);
        if (emu.tick_requested()) break;
        const double wait = flowing || emu.any_requested() ? config.lockstep_timeout : sim_config.dt;
        const double left = start + wait - monotonic_s();
        if (left <= 0) break;
        poll_for(fds, left);
      }
      flowing = emu.tick_requested();
      const double t0 = monotonic_s();
      emu.step(now);
      after_step(now, t0, flowing, tick);
      ++tick;
    }
  } else {
    PeriodicClock clock(sim_config.dt);
    while (!rt.stop_requested()) {
      if (duration > 0 && simulator.time() >= duration) break;
      // Frames until the period ends.
      while (!rt.stop_requested()) {
        serve(monotonic_s());
        const double left = clock.left();
        if (left <= 0) break;
        poll_for(fds, left);
      }
      if (clock.next() > 0.5 * sim_config.dt) ++late;
      const double t0 = monotonic_s();
      emu.step(t0);
      after_step(t0, t0, false, 0);
    }
  }
  log::info("drive emulator stopped at t = {:.3f} s; late periods {}, frames ignored {}", simulator.time(), late, emu.frames_ignored());
  return node::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return hpr::node::run_main(argc, argv, "drive_emulator", "joint drives and sensors on CAN, backed by the Bullet simulation", run);
}
