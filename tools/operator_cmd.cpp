// hpr_operator: sends one OPERATOR message (enable, damp, stop, support, set, params) to every node.
//
//   hpr_operator enable|damp|stop [--reason TEXT]
//   hpr_operator support double|left|right
//   hpr_operator set NODE.KEY=VALUE [...]     waits for each addressed node's answer on PARAMS
//   hpr_operator params [NODE ...]            lists the live parameters of the running nodes
#include <humanoid/balance_status_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "hpr/common/args.hpp"
#include "hpr/common/text.hpp"
#include "hpr/common/time.hpp"
#include "hpr/common/auth.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"

namespace {

constexpr const char* kUsage =
    "usage: hpr_operator enable|damp|stop [--reason TEXT]\n"
    "       hpr_operator support double|left|right\n"
    "       hpr_operator set NODE.KEY=VALUE [...]\n"
    "       hpr_operator params [NODE ...]\n"
    "options: --lcm-url URL (else $LCM_DEFAULT_URL), --source NAME (default: operator),\n"
    "         --wait S: how long set and params wait for the nodes' answers (default 1)\n"
    "set applies each node's keys all or nothing and exits 0 when every node named applied them,\n"
    "1 when one refused, 4 when one did not answer. Keys are those of the node's configuration\n"
    "section (wbc.com.stiffness.z, reference_gen.x.alpha); `params` lists them.\n"
    "Every OPERATOR is signed with the deployment's key, $HPR_LCM_KEY_FILE (default\n"
    "~/.config/hpr/lcm.key, created by `supervisor up`); exit 2 when it cannot be read.\n";

int usage(const std::string& why) {
  std::fprintf(stderr, "%s%s%s", why.c_str(), why.empty() ? "" : "\n", kUsage);
  return 2;
}

/// Collects the PARAMS answers to one request.
struct Answers {
  std::int64_t request_utime = 0;
  std::map<std::string, humanoid::params_t> by_node;
  void on(const lcm::ReceiveBuffer* /*rbuf*/, const std::string& /*channel*/, const humanoid::params_t* m) {
    if (m->request_utime == request_utime) by_node[m->node] = *m;
  }
};

std::string table(const humanoid::params_t& p) {
  std::size_t width = 4;
  for (const auto& n : p.name) width = std::max(width, n.size());
  std::string s = fmt::format("{} (sets applied: {})\n", p.node, p.version);
  for (int i = 0; i < p.num_params; ++i) {
    const auto k = static_cast<std::size_t>(i);
    s += fmt::format("  {:<{}}  {:>10g}  [{:g}, {:g}] {}\n", p.name[k], width, p.value[k], p.min_value[k], p.max_value[k], p.unit[k]);
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage("");
  humanoid::operator_t m{};
  m.utime = hpr::wall_us();
  m.source = "operator";
  m.num_params = 0;
  std::string url;
  double wait_s = 1.0;
  const std::string verb = argv[1];
  int i = 2;
  std::set<std::string> nodes;  // addressed by set or params
  try {
    static const std::map<std::string, std::int8_t> kCommands = {{"enable", std::int8_t{humanoid::operator_t::COMMAND_ENABLE}},
                                                                 {"damp", std::int8_t{humanoid::operator_t::COMMAND_DAMP}},
                                                                 {"stop", std::int8_t{humanoid::operator_t::COMMAND_STOP}}};
    static const std::map<std::string, std::int8_t> kSupports = {{"double", std::int8_t{humanoid::balance_status_t::SUPPORT_DOUBLE}},
                                                                 {"left", std::int8_t{humanoid::balance_status_t::SUPPORT_LEFT}},
                                                                 {"right", std::int8_t{humanoid::balance_status_t::SUPPORT_RIGHT}}};
    if (const auto c = kCommands.find(verb); c != kCommands.end()) {
      m.command = c->second;
    } else if (verb == "support") {
      if (argc < 3) return usage("support needs double, left or right");
      const auto s = kSupports.find(argv[2]);
      if (s == kSupports.end()) return usage("unknown support '" + std::string(argv[2]) + "'");
      m.command = humanoid::operator_t::COMMAND_SET_SUPPORT;
      m.support = s->second;
      i = 3;
    } else if (verb == "set" || verb == "params") {
      const bool set = verb == "set";
      m.command = set ? humanoid::operator_t::COMMAND_SET_PARAMS : humanoid::operator_t::COMMAND_GET_PARAMS;
      for (; i < argc && std::string(argv[i]).rfind("--", 0) != 0; ++i) {
        const std::string arg = argv[i];
        if (!set) {
          m.param_name.push_back(arg);
          m.param_value.push_back(0.0);
          nodes.insert(arg);
          continue;
        }
        const auto eq = arg.find('=');
        const auto dot = arg.find('.');
        if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq) {
          return usage("'" + arg + "' is not NODE.KEY=NUMBER");
        }
        m.param_name.push_back(arg.substr(0, eq));
        m.param_value.push_back(hpr::parse_number(arg.substr(eq + 1), arg.substr(0, eq)));
        nodes.insert(arg.substr(0, dot));
      }
      m.num_params = static_cast<std::int32_t>(m.param_name.size());
      if (set && m.num_params == 0) return usage("set needs NODE.KEY=VALUE");
    } else if (verb == "-h" || verb == "--help") {
      std::printf("%s", kUsage);
      return 0;
    } else {
      return usage("unknown command '" + verb + "'" +
                   hpr::did_you_mean(verb, {"enable", "damp", "stop", "support", "set", "params", "--help"}));
    }
    for (; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--reason" && i + 1 < argc) {
        m.reason = argv[++i];
      } else if (a == "--lcm-url" && i + 1 < argc) {
        url = argv[++i];
      } else if (a == "--source" && i + 1 < argc) {
        m.source = argv[++i];
      } else if (a == "--wait" && i + 1 < argc) {
        wait_s = hpr::parse_number(argv[++i], "--wait");
        if (wait_s <= 0) return usage("--wait must be positive");
      } else if (!a.empty() && a[0] == '-') {
        const std::string name = a.substr(0, a.find('='));
        return usage("unknown option " + a + hpr::did_you_mean(name, {"--reason", "--lcm-url", "--source", "--wait"}));
      } else {
        return usage("unexpected argument '" + a + "'");
      }
    }
  } catch (const hpr::UsageError& e) {
    return usage(e.what());
  }

  std::unique_ptr<lcm::LCM> lcm;
  hpr::auth::Key key;
  try {
    // Signed with the deployment's key: the stack refuses an OPERATOR without its code.
    key = hpr::auth::load_key(hpr::auth::key_path());
    lcm = hpr::node::open_lcm(hpr::node::resolve_lcm_url(url, ""));
  } catch (const hpr::auth::AuthError& e) {
    std::fprintf(stderr, "hpr_operator: %s\n", e.what());
    return 2;
  } catch (const hpr::node::LcmError& e) {
    std::fprintf(stderr, "hpr_operator: %s\n", e.what());
    return 3;
  }
  const bool asks = m.command == humanoid::operator_t::COMMAND_SET_PARAMS || m.command == humanoid::operator_t::COMMAND_GET_PARAMS;
  Answers answers;
  answers.request_utime = m.utime;
  if (asks) lcm->subscribe("PARAMS", &Answers::on, &answers);

  // Three copies 5 ms apart: UDP multicast may drop one; every receiver acts on one request once.
  for (int k = 0; k < 3; ++k) {
    m.tick = k;
    hpr::node::publish_signed(*lcm, "OPERATOR", m, key);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!asks) {
    std::printf("OPERATOR %s sent\n", verb.c_str());
    return 0;
  }

  // Wait for the answers: every addressed node, or (params with no node named) whoever answers.
  const double end = hpr::monotonic_s() + wait_s;
  auto all_in = [&] {
    return !nodes.empty() && std::all_of(nodes.begin(), nodes.end(), [&](const std::string& n) { return answers.by_node.count(n) != 0; });
  };
  while (!all_in()) {
    const double left = end - hpr::monotonic_s();
    if (left <= 0) break;
    lcm->handleTimeout(std::max(1, static_cast<int>(left * 1e3)));
  }

  int status = 0;
  for (const auto& [name, p] : answers.by_node) {
    if (m.command == humanoid::operator_t::COMMAND_GET_PARAMS) {
      std::printf("%s", table(p).c_str());
    } else if (p.accepted) {
      std::printf("%s: %s\n", name.c_str(), p.result.c_str());
    } else {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), p.result.c_str());
      status = std::max(status, 1);
    }
  }
  for (const auto& n : nodes) {
    if (answers.by_node.count(n) == 0) {
      std::fprintf(stderr, "%s: no answer within %g s (is it running on this LCM URL? `hpr_operator params` lists the nodes that answer)\n",
                   n.c_str(), wait_s);
      status = 4;
    }
  }
  if (nodes.empty() && answers.by_node.empty()) {
    std::fprintf(stderr, "no node answered within %g s\n", wait_s);
    status = 4;
  }
  return status;
}
