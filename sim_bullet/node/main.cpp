// sim_bullet: the Bullet simulation of the robot, speaking the same LCM channels as the hardware.
#include "hpr/node/command_line.hpp"
#include "hpr/sim/ports.hpp"
#include "sim_node.hpp"

int main(int argc, char** argv) {
  return hpr::node::run_main(argc, argv, "sim_bullet", "Bullet simulation of the robot (stands in for hal)",
                             [](const hpr::node::CommandLine& cl, const hpr::Config& cfg) {
                               const hpr::Config robot_cfg = cfg.section("robot");
                               const auto robot = hpr::model::RobotSpec::load(robot_cfg);
                               const hpr::Config sim_cfg = cfg.section("sim");
                               const auto sim_config = hpr::sim::SimConfig::load(sim_cfg);
                               const auto options = hpr::sim::SimNodeOptions::load(sim_cfg);
                               hpr::node::Runtime rt(hpr::sim::kPorts, cl.name, hpr::node::lcm_url(cl, cfg),
                                                     hpr::node::runtime_options(cfg, sim_config.dt));
                               // The hal's drive ranges: its section when the configuration has one
                               // (validated here too), else the defaults from the URDF limits.
                               std::vector<hpr::hal::DriveConfig> drives;
                               if (cfg.has("hal")) {
                                 const hpr::Config hal_cfg = cfg.section("hal");
                                 hal_cfg.known({"enable_on_start", "duration"});  // the hal process's own
                                 drives = hpr::hal::HalConfig::load(hal_cfg, robot).drives;
                               } else {
                                 drives = hpr::hal::default_drives(robot);
                               }
                               hpr::sim::Simulator sim(robot, sim_config);
                               hpr::sim::SimNode node(rt, sim, options, std::move(drives));
                               return node.run();
                             });
}
