// A node built on the runtime that echoes every message type: "<CHANNEL>" -> "<CHANNEL>_ECHO".
// Used by the transport tests (round trip between processes, garbage input, SIGTERM).
#include "all_types.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"

namespace {
struct Echo {
  hpr::node::Runtime& rt;
  template <class Msg>
  void operator()(const std::string& channel) {
    auto out = std::make_shared<hpr::node::Output<Msg>>(rt.advertise<Msg>(channel + "_ECHO"));
    rt.subscribe<Msg>(channel, {}, [out](const Msg& m) { out->publish(m); });
  }
};
}  // namespace

int main(int argc, char** argv) {
  const auto cl = hpr::node::CommandLine::parse(argc, argv, "lcm_echo_node", "echoes every LCM type", false);
  hpr::log::init_from_env(cl.name);
  try {
    hpr::node::Runtime rt(cl.name, hpr::node::resolve_lcm_url(cl.lcm_url, ""));
    hpr::test::for_each_type(Echo{rt});
    return rt.run();
  } catch (const hpr::node::LcmError& e) {
    hpr::log::error("{}", e.what());
    return hpr::node::kExitLcm;
  }
}
