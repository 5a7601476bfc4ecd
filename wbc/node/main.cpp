// wbc: the passivity-based whole-body controller process.
#include "hpr/node/command_line.hpp"
#include "hpr/wbc/node.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(argc, argv, "wbc", "passivity-based whole-body controller",
                        [](const node::CommandLine& cl, const Config& cfg) {
                          const auto robot = model::RobotSpec::load(cfg.section("robot"));
                          const Config wc = cfg.section("wbc");
                          const auto options = wbc::WbcNodeOptions::load(wc);
                          wbc::WbcComponent wbc(robot, wbc::WbcConfig::load(wc, robot), options.bad_state_ticks);
                          node::Runtime rt(wbc::WbcComponent::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
                          wbc::WbcNode node(rt, robot, wbc, options);
                          return rt.run();
                        });
}
