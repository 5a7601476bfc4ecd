// hpr_operator: sends one OPERATOR message (enable, damp, stop, support, set) to every node.
//
//   hpr_operator enable|damp|stop [--reason TEXT] [--lcm-url URL] [--source NAME]
//   hpr_operator support double|left|right
//   hpr_operator set NODE.KEY=VALUE [...]
#include <humanoid/balance_status_t.hpp>
#include <humanoid/operator_t.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>

namespace {

int usage(const char* why) {
  std::fprintf(stderr,
               "%s%susage: hpr_operator enable|damp|stop [--reason TEXT]\n"
               "       hpr_operator support double|left|right\n"
               "       hpr_operator set NODE.KEY=VALUE [...]\n"
               "options: --lcm-url URL (else $LCM_DEFAULT_URL), --source NAME (default: operator)\n",
               why, *why ? "\n" : "");
  return 2;
}

std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage("");
  humanoid::operator_t m{};
  m.utime = wall_us();
  m.source = "operator";
  m.num_params = 0;
  std::string url;
  const std::string verb = argv[1];
  int i = 2;
  if (verb == "enable") {
    m.command = humanoid::operator_t::COMMAND_ENABLE;
  } else if (verb == "damp") {
    m.command = humanoid::operator_t::COMMAND_DAMP;
  } else if (verb == "stop") {
    m.command = humanoid::operator_t::COMMAND_STOP;
  } else if (verb == "support") {
    if (argc < 3) return usage("support needs double, left or right");
    const std::string s = argv[2];
    m.command = humanoid::operator_t::COMMAND_SET_SUPPORT;
    if (s == "double") {
      m.support = humanoid::balance_status_t::SUPPORT_DOUBLE;
    } else if (s == "left") {
      m.support = humanoid::balance_status_t::SUPPORT_LEFT;
    } else if (s == "right") {
      m.support = humanoid::balance_status_t::SUPPORT_RIGHT;
    } else {
      return usage(("unknown support '" + s + "'").c_str());
    }
    i = 3;
  } else if (verb == "set") {
    m.command = humanoid::operator_t::COMMAND_SET_PARAMS;
    for (; i < argc && std::string(argv[i]).rfind("--", 0) != 0; ++i) {
      const std::string kv = argv[i];
      const auto eq = kv.find('=');
      char* end = nullptr;
      const double v = eq == std::string::npos ? 0.0 : std::strtod(kv.c_str() + eq + 1, &end);
      if (eq == std::string::npos || end == kv.c_str() + eq + 1 || *end != '\0') return usage(("'" + kv + "' is not NODE.KEY=NUMBER").c_str());
      m.param_name.push_back(kv.substr(0, eq));
      m.param_value.push_back(v);
    }
    m.num_params = static_cast<std::int32_t>(m.param_name.size());
    if (m.num_params == 0) return usage("set needs NODE.KEY=VALUE");
  } else if (verb == "-h" || verb == "--help") {
    usage("");
    return 0;
  } else {
    return usage(("unknown command '" + verb + "'").c_str());
  }
  for (; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--reason" && i + 1 < argc) {
      m.reason = argv[++i];
    } else if (a == "--lcm-url" && i + 1 < argc) {
      url = argv[++i];
    } else if (a == "--source" && i + 1 < argc) {
      m.source = argv[++i];
    } else {
      return usage(("unexpected argument '" + a + "'").c_str());
    }
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "hpr_operator: cannot open LCM '%s' (is loopback multicast set up? sudo tools/install-deps)\n", url.c_str());
    return 3;
  }
  // Three copies 5 ms apart: UDP multicast may drop one; every receiver acts idempotently.
  for (int k = 0; k < 3; ++k) {
    m.tick = k;
    lcm.publish("OPERATOR", &m);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::printf("OPERATOR %s sent\n", verb.c_str());
  return 0;
}
