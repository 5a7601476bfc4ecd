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
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "hpr/common/args.hpp"
#include "hpr/common/text.hpp"
#include "hpr/common/time.hpp"
#include "hpr/common/auth.hpp"
#include "hpr/msg/channels.hpp"
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

/// What the command line asks for: the message, where, and (set, params) the nodes addressed.
struct Request {
  humanoid::operator_t m{};
  std::string verb, url;
  double wait_s = 1.0;
  std::set<std::string> nodes;
};

/// set's NODE.KEY=VALUE pairs or params' node names from argv[i] on, up to the first option.
std::optional<int> read_parameters(int argc, char** argv, int& i, Request& r) {
  const bool set = r.verb == "set";
  r.m.command = set ? humanoid::operator_t::COMMAND_SET_PARAMS : humanoid::operator_t::COMMAND_GET_PARAMS;
  for (; i < argc && std::string(argv[i]).rfind("--", 0) != 0; ++i) {
    const std::string arg = argv[i];
    if (!set) {
      r.m.param_name.push_back(arg);
      r.m.param_value.push_back(0.0);
      r.nodes.insert(arg);
      continue;
    }
    const auto eq = arg.find('=');
    const auto dot = arg.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot + 1 >= eq) {
      return usage("'" + arg + "' is not NODE.KEY=NUMBER");
    }
    r.m.param_name.push_back(arg.substr(0, eq));
    r.m.param_value.push_back(hpr::parse_number(arg.substr(eq + 1), arg.substr(0, eq)));
    r.nodes.insert(arg.substr(0, dot));
  }
  r.m.num_params = static_cast<std::int32_t>(r.m.param_name.size());
  if (set && r.m.num_params == 0) return usage("set needs NODE.KEY=VALUE");
  return std::nullopt;
}

/// The options after the command's own arguments.
std::optional<int> read_options(int argc, char** argv, int i, Request& r) {
  for (; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--reason" && i + 1 < argc) {
      r.m.reason = argv[++i];
    } else if (a == "--lcm-url" && i + 1 < argc) {
      r.url = argv[++i];
    } else if (a == "--source" && i + 1 < argc) {
      r.m.source = argv[++i];
    } else if (a == "--wait" && i + 1 < argc) {
      r.wait_s = hpr::parse_number(argv[++i], "--wait");
      if (r.wait_s <= 0) return usage("--wait must be positive");
    } else if (!a.empty() && a[0] == '-') {
      const std::string name = a.substr(0, a.find('='));
      return usage("unknown option " + a + hpr::did_you_mean(name, {"--reason", "--lcm-url", "--source", "--wait"}));
    } else {
      return usage("unexpected argument '" + a + "'");
    }
  }
  return std::nullopt;
}

/// The request, or the exit status when the command line is refused or asked for help.
std::optional<int> read_request(int argc, char** argv, Request& r) {
  if (argc < 2) return usage("");
  r.m.utime = hpr::wall_us();
  r.m.source = "operator";
  r.m.num_params = 0;
  r.verb = argv[1];
  int i = 2;
  static const std::map<std::string, std::int8_t> kCommands = {{"enable", std::int8_t{humanoid::operator_t::COMMAND_ENABLE}},
                                                               {"damp", std::int8_t{humanoid::operator_t::COMMAND_DAMP}},
                                                               {"stop", std::int8_t{humanoid::operator_t::COMMAND_STOP}}};
  static const std::map<std::string, std::int8_t> kSupports = {{"double", std::int8_t{humanoid::balance_status_t::SUPPORT_DOUBLE}},
                                                               {"left", std::int8_t{humanoid::balance_status_t::SUPPORT_LEFT}},
                                                               {"right", std::int8_t{humanoid::balance_status_t::SUPPORT_RIGHT}}};
  try {
    if (const auto c = kCommands.find(r.verb); c != kCommands.end()) {
      r.m.command = c->second;
    } else if (r.verb == "support") {
      if (argc < 3) return usage("support needs double, left or right");
      const auto s = kSupports.find(argv[2]);
      if (s == kSupports.end()) return usage("unknown support '" + std::string(argv[2]) + "'");
      r.m.command = humanoid::operator_t::COMMAND_SET_SUPPORT;
      r.m.support = s->second;
      i = 3;
    } else if (r.verb == "set" || r.verb == "params") {
      if (const auto refused = read_parameters(argc, argv, i, r)) return refused;
    } else if (r.verb == "-h" || r.verb == "--help") {
      std::printf("%s", kUsage);
      return 0;
    } else {
      return usage("unknown command '" + r.verb + "'" +
                   hpr::did_you_mean(r.verb, {"enable", "damp", "stop", "support", "set", "params", "--help"}));
    }
    return read_options(argc, argv, i, r);
  } catch (const hpr::UsageError& e) {
    return usage(e.what());
  }
}

/// The nodes' answers on stdout (refusals on stderr), and the exit status: 1 when one refused, 4
/// when one addressed did not answer (or, params with no node named, none did).
int report(const Request& r, const Answers& answers) {
  int status = 0;
  for (const auto& [name, p] : answers.by_node) {
    if (r.m.command == humanoid::operator_t::COMMAND_GET_PARAMS) {
      std::printf("%s", table(p).c_str());
    } else if (p.accepted) {
      std::printf("%s: %s\n", name.c_str(), p.result.c_str());
    } else {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), p.result.c_str());
      status = std::max(status, 1);
    }
  }
  for (const auto& n : r.nodes) {
    if (answers.by_node.count(n) == 0) {
      std::fprintf(stderr, "%s: no answer within %g s (is it running on this LCM URL? `hpr_operator params` lists the nodes that answer)\n",
                   n.c_str(), r.wait_s);
      status = 4;
    }
  }
  if (r.nodes.empty() && answers.by_node.empty()) {
    std::fprintf(stderr, "no node answered within %g s\n", r.wait_s);
    status = 4;
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Request r;
  if (const auto status = read_request(argc, argv, r)) return *status;
  std::unique_ptr<lcm::LCM> lcm;
  hpr::auth::Key key;
  try {
    // Signed with the deployment's key: the stack refuses an OPERATOR without its code.
    key = hpr::auth::load_key(hpr::auth::key_path());
    lcm = hpr::node::open_lcm(hpr::node::resolve_lcm_url(r.url, ""));
  } catch (const hpr::auth::AuthError& e) {
    std::fprintf(stderr, "hpr_operator: %s\n", e.what());
    return 2;
  } catch (const hpr::node::LcmError& e) {
    std::fprintf(stderr, "hpr_operator: %s\n", e.what());
    return 3;
  }
  humanoid::operator_t& m = r.m;
  const bool asks = m.command == humanoid::operator_t::COMMAND_SET_PARAMS || m.command == humanoid::operator_t::COMMAND_GET_PARAMS;
  Answers answers;
  answers.request_utime = m.utime;
  if (asks) lcm->subscribe(hpr::msg::channels::kParams.name, &Answers::on, &answers);

  // Three copies 5 ms apart: UDP multicast may drop one; every receiver acts on one request once.
  for (int k = 0; k < 3; ++k) {
    m.tick = k;
    hpr::node::publish_signed(*lcm, hpr::msg::channels::kOperator.name, m, key);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!asks) {
    std::printf("OPERATOR %s sent\n", r.verb.c_str());
    return 0;
  }

  // Wait for the answers: every addressed node, or (params with no node named) whoever answers.
  const double end = hpr::monotonic_s() + r.wait_s;
  auto all_in = [&] {
    return !r.nodes.empty() &&
           std::all_of(r.nodes.begin(), r.nodes.end(), [&](const std::string& n) { return answers.by_node.count(n) != 0; });
  };
  while (!all_in()) {
    const double left = end - hpr::monotonic_s();
    if (left <= 0) break;
    lcm->handleTimeout(std::max(1, static_cast<int>(left * 1e3)));
  }
  return report(r, answers);
}
