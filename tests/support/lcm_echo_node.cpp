// A node built on the runtime that echoes every message type: "<CHANNEL>" -> "<CHANNEL>_ECHO".
// Used by the transport tests (round trip between processes, garbage input, SIGTERM).
#include <string>
#include <string_view>
#include <vector>

#include "all_types.hpp"
#include "hpr/common/log.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"

namespace {

/// The echo's ports: it reads every type's channel and writes its "_ECHO".
struct EchoPorts {
  std::vector<std::string> echoes;
  std::vector<hpr::Read> reads;
  std::vector<std::string_view> writes;
  EchoPorts() {
    hpr::test::for_each_type([&]<class Msg>(const char* channel) {
      reads.push_back(hpr::Read{channel, 0, false, false, "echoed"});
      echoes.push_back(std::string(channel) + "_ECHO");
    });
    writes.assign(echoes.begin(), echoes.end());  // once every name is in place
  }
  [[nodiscard]] hpr::Ports ports() const { return {.name = "lcm_echo_node", .reads = reads, .writes = writes}; }
};

/// Visits the types in EchoPorts' order: the k-th type echoes on the k-th name.
struct Echo {
  hpr::node::Runtime& rt;
  const EchoPorts& ports;
  std::size_t k = 0;
  template <class Msg>
  void operator()(const char* channel) {
    auto out = std::make_shared<hpr::node::Output<Msg>>(rt.advertise(hpr::Channel<Msg>{ports.echoes[k++].c_str()}));
    rt.subscribe(hpr::Channel<Msg>{channel}, {}, [out](const Msg& m) { out->publish(m); });
  }
};

}  // namespace

int main(int argc, char** argv) {
  const auto cl = hpr::node::CommandLine::parse(argc, argv, "lcm_echo_node", "echoes every LCM type", false);
  hpr::log::init_from_env(cl.name);
  try {
    const EchoPorts ports;
    hpr::node::Runtime rt(ports.ports(), cl.name, hpr::node::resolve_lcm_url(cl.lcm_url, ""));
    hpr::test::for_each_type(Echo{rt, ports});
    return rt.run();
  } catch (const hpr::node::LcmError& e) {
    hpr::log::error("{}", e.what());
    return hpr::node::kExitLcm;
  }
}
