#pragma once
/// \file The simulation process (sim_bullet, sim_mujoco): the Simulator behind LCM.
///
/// Lockstep: publish ROBOT_SENSORS and SIM_TRUTH for tick k, wait (bounded) for the JOINT_COMMAND of
/// tick k, step. Realtime: step on a 1 kHz absolute-time clock with the latest command, counting late
/// steps. PUSH messages and a scenario file schedule pushes.

#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/push_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/sim_truth_t.hpp>

#include "hpr/drive/drive.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::sim {

struct SimNodeOptions {
  bool lockstep = true;
  double lockstep_timeout = 1.0;  ///< [s] wall time to wait for the command of a tick
  double startup_timeout = 10.0;  ///< [s] wall time to wait for the first command (processes starting)
  double duration = 0.0;          ///< [s] simulated time to run, 0 = until stopped
  bool publish_truth = true;
  std::string scenario;           ///< push scenario file
  /// `sim.push_input`: whether PUSH messages are applied (a test input; off: refused and logged).
  bool push_input = true;
  static SimNodeOptions load(const Config& sim_section);
};

/// The simulation process of `engine` (its main): loads the configuration, builds the simulator
/// and runs its node. The engine is the process's whatever `sim.engine` says.
int run_sim_process(int argc, char** argv, EngineKind engine);

class SimNode {
 public:
  /// `drives`: the hal's drive ranges (drive::load_joint_drives of the hal section, or
  /// drive::default_drives where the configuration maps none): a JOINT_COMMAND the hal would refuse
  /// is refused here by the same check.
  SimNode(node::Runtime& rt, Simulator& sim, SimNodeOptions options, std::vector<drive::JointDrive> drives);
  /// Runs until the duration is reached or a signal arrives. Returns the exit code.
  int run();

 private:
  void publish();
  /// Logs the first fall (once), in every mode, and shows it in HEALTH.
  void report_fall();
  int run_lockstep();
  int run_realtime();

  node::Runtime& rt_;
  Simulator& sim_;
  SimNodeOptions options_;
  std::vector<drive::JointDrive> drives_;
  std::int64_t refused_ = 0;  ///< commands refused (as the hal counts them)
  msg::RobotNames names_;
  node::Input<humanoid::joint_command_t>* command_in_ = nullptr;
  node::Output<humanoid::robot_sensors_t> sensors_out_;
  node::Output<humanoid::sim_truth_t> truth_out_;
  humanoid::robot_sensors_t sensors_msg_;
  humanoid::sim_truth_t truth_msg_;
  JointCommand command_;
  std::int64_t missed_ = 0, late_ = 0;
  bool fallen_reported_ = false;
};

}  // namespace hpr::sim
