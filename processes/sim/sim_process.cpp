// The simulation process of either engine (sim_bullet, sim_mujoco): the Simulator behind LCM.
#include "hpr/common/log.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/sim/engines.hpp"
#include "hpr/sim/ports.hpp"
#include "sim_node.hpp"

namespace hpr::sim {

int run_sim_process(int argc, char** argv, EngineKind engine) {
  const bool mujoco = engine == EngineKind::kMujoco;
  return node::run_main(
      argc, argv, mujoco ? "sim_mujoco" : "sim_bullet",
      mujoco ? "MuJoCo simulation of the robot (stands in for hal)" : "Bullet simulation of the robot (stands in for hal)",
      [&](const node::CommandLine& cl, const Config& cfg) {
        const Config robot_cfg = cfg.section("robot");
        const auto robot = model::RobotSpec::load(robot_cfg);
        const Config sim_cfg = cfg.section("sim");
        auto sim_config = SimConfig::load(sim_cfg);
        if (sim_config.engine != engine) {
          log::info("sim.engine is {}; this process is the {} simulation", to_string(sim_config.engine), to_string(engine));
        }
        sim_config.engine = engine;
        const auto options = SimNodeOptions::load(sim_cfg);
        node::Runtime rt(mujoco ? kMujocoPorts : kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, sim_config.dt));
        // The hal's drive ranges: its section's drives when the configuration has one (their joints,
        // units and ranges validated here too; the buses, ids and the rest are the hal's), else
        // the defaults from the URDF limits.
        std::vector<drive::JointDrive> drives;
        if (cfg.has("hal")) {
          const Config hal_cfg = cfg.section("hal");
          std::vector<std::string> others;
          for (const std::string& key : hal_cfg.keys()) {
            if (key != "drives" && key != "drive_defaults") others.push_back(key);
          }
          hal_cfg.known(others);  // the hal process's own
          drives = drive::load_joint_drives(hal_cfg, robot);
        } else {
          drives = drive::default_drives(robot);
        }
        Simulator sim(robot, sim_config, sim::make_engine);
        SimNode node(rt, sim, options, std::move(drives));
        return node.run();
      });
}

}  // namespace hpr::sim
