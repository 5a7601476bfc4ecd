#pragma once

#include <functional>
/// \file
/// The hal and the drive emulator in one process over in-memory buses, stepped in lockstep on a
/// simulated clock (the hal's tests, MIT mode and CiA 402).
#include <memory>
#include <string>
#include <vector>

#include "hpr/common/config.hpp"
#include "hpr/sim/drive_emulator.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/hal/memory_transport.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/sim/engines.hpp"
#include "hpr/sim/simulator.hpp"
#include "process_group.hpp"

namespace hpr::test {

/// The time of the next operator command [us, as OPERATOR's utime]: each one after the one before
/// (a damp or stop holds until an enable issued after it).
inline std::int64_t issued() {
  static std::int64_t t = 1'000'000;
  return ++t;
}

/// hal and emulator joined by memory buses, stepped tick by tick on a simulated clock.
struct Rig {
  Config cfg;
  model::RobotSpec robot;
  hal::HalConfig config;
  sim::Simulator sim;
  std::vector<hal::MemoryTransport*> hal_side, drive_side;
  std::vector<std::unique_ptr<hal::CanTransport>> drive_buses;
  std::unique_ptr<hal::Hal> h;
  std::unique_ptr<hal::DriveEmulator> emu;
  double now = 0.0;
  std::int64_t tick = 0;
  bool drives_answer = true;
  mutable std::int64_t command_tick = -1;  ///< the tick of the last command hold() made
  /// Called once a tick after the drives answered, before the hal reads the buses (a forger's frames).
  std::function<void(Rig&)> after_replies;

  explicit Rig(const std::vector<std::string>& overrides = {})
      : cfg(Config::load(test::source_dir() + "/config/toro.yaml", overrides)),
        robot(model::RobotSpec::load(cfg.section("robot"))),
        config(hal::HalConfig::load(cfg.section("hal"), robot)),
        sim(robot, sim::SimConfig::load(cfg.section("sim")), sim::make_engine) {
    std::vector<std::unique_ptr<hal::CanTransport>> hal_buses;
    for (std::size_t b = 0; b < config.buses.size(); ++b) {
      auto [a, d] = hal::MemoryTransport::pair();
      hal_side.push_back(a.get());
      drive_side.push_back(d.get());
      hal_buses.push_back(std::move(a));
      drive_buses.push_back(std::move(d));
    }
    h = std::make_unique<hal::Hal>(config, std::move(hal_buses), std::make_unique<hal::MitCodec>());
    emu = std::make_unique<hal::DriveEmulator>(config, sim, std::make_unique<hal::MitCodec>(),
                                               hal::EmulatorOptions::load(cfg.section("emulator")));
  }
  /// One period: hal sends, drives answer (unless told not to), hal reads, physics steps.
  void tick_once(bool hal_runs = true) {
    now += 1e-3;
    if (hal_runs) h->begin_tick(tick++, now);
    std::vector<hal::CanFrame> rx;
    for (std::size_t b = 0; b < drive_buses.size(); ++b) {
      rx.clear();
      drive_buses[b]->receive(rx);
      if (drives_answer) {
        for (const auto& f : rx) emu->handle(static_cast<int>(b), f, now, *drive_buses[b]);
      }
      emu->report_periodic(static_cast<int>(b), now, *drive_buses[b]);
      drive_buses[b]->flush();
    }
    if (after_replies) after_replies(*this);
    if (hal_runs) {
      h->receive();
      h->end_tick(now);
    }
    emu->step(now);
  }
  /// Sends the hold command and ticks, `ticks` times.
  void hold_for(int ticks) {
    for (int k = 0; k < ticks; ++k) {
      (void)h->set_command(hold(), now);
      tick_once();
    }
  }
  /// An operator's enable, then hold_for(ticks).
  void enable_and_hold(int ticks) {
    (void)h->operator_command(hal::kOperatorEnable, now, "test", issued());
    hold_for(ticks);
  }
  /// A command holding the standing posture, each one of a newer tick than the one before.
  JointCommand hold() const {
    JointCommand c;
    c.tick = ++command_tick;
    c.resize(robot.model.nj);
    c.mode = JointCommand::Mode::kRun;
    c.q_des = robot.q_joints_stand;
    // Gains an explicitly evaluated joint impedance holds stably at 1 kHz, also on the light wrists.
    sim::hold_gains(robot, robot.standing_configuration(), 300.0, 10.0, 1e-3, c.kp, c.kd);
    return c;
  }
};

}  // namespace hpr::test
