// wbc: the passivity-based whole-body controller process.
#include "hpr/node/command_line.hpp"
#include "wbc_node.hpp"

int main(int argc, char** argv) {
  return hpr::node::run_main(argc, argv, "wbc", "passivity-based whole-body controller",
                             [](const hpr::node::CommandLine& cl, const hpr::Config& cfg) {
                               const auto robot = hpr::model::RobotSpec::load(cfg.section("robot"));
                               const hpr::Config wc = cfg.section("wbc");
                               hpr::wbc::WholeBodyController wbc(robot, hpr::wbc::WbcConfig::load(wc, robot));
                               hpr::balance::PostureReference reference(
                                   robot, hpr::balance::PostureReferenceConfig::load(cfg.section("balance")));
                               hpr::node::Runtime rt(cl.name, hpr::node::lcm_url(cl, cfg), hpr::node::runtime_options(cfg, 1e-3));
                               hpr::wbc::WbcNode node(rt, robot, wbc, reference, hpr::wbc::WbcNodeOptions::load(wc));
                               return rt.run();
                             });
}
