// The supervisor's client commands: status, down, restart, logs and groups, talking over LCM to the
// supervisors that run the groups (supervisor_cli.hpp).
#include <humanoid/supervisor_command_t.hpp>

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "hpr/common/time.hpp"
#include "hpr/launch/supervisor.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/node/runtime.hpp"
#include "supervisor_cli.hpp"

namespace hpr::supervisor_cli {

using launch::GroupState;
using launch::ProcessState;

int cmd_status(const Options& o, const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) throw std::runtime_error("cannot open LCM on " + url);
  const auto hosts = collect_status(lcm, o.wait_s, o.group_filter);
  if (o.json) {
    nlohmann::ordered_json j;
    j["lcm_url"] = url;
    j["supervisors"] = nlohmann::ordered_json::array();
    for (const auto& h : hosts) {
      nlohmann::ordered_json s;
      s["host"] = h.host;
      s["group"] = h.group;
      s["state"] = launch::to_string(static_cast<GroupState>(h.state));
      s["pid"] = h.pid;
      s["run_dir"] = h.run_dir;
      s["message"] = h.message;
      s["processes"] = nlohmann::ordered_json::array();
      for (int i = 0; i < h.num_processes; ++i) {
        s["processes"].push_back({{"name", h.name[i]},
                                  {"state", launch::to_string(static_cast<ProcessState>(h.process_state[i]))},
                                  {"pid", h.process_pid[i]},
                                  {"uptime_s", h.uptime_s[i]},
                                  {"restarts", h.restarts[i]},
                                  {"critical", h.critical[i] != 0},
                                  {"health", health_text(h.health_state[i])},
                                  {"lifecycle", h.lifecycle[i] >= 0 ? node::to_string(static_cast<node::Lifecycle>(h.lifecycle[i])) : "-"},
                                  {"rate_hz", h.rate_hz[i]},
                                  {"deadline_misses", h.deadline_misses[i]},
                                  {"detail", h.detail[i]}});
      }
      j["supervisors"].push_back(s);
    }
    std::cout << j.dump(2) << std::endl;
  } else if (hosts.empty()) {
    std::cout << "no supervisor answered on " << url << "\n";
  } else {
    std::cout << render(hosts);
  }
  return hosts.empty() ? 3 : 0;
}

/// Who sends this process's SUPERVISOR_COMMANDs: a supervisor names it in the goodbye that answers a down.
std::string command_source() { return "supervisor-cli@" + machine_host() + ":" + std::to_string(::getpid()); }

void send_command(lcm::LCM& lcm, const Options& o, int8_t command, const std::string& process) {
  static std::int64_t seq = 0;
  humanoid::supervisor_command_t c{};
  c.tick = ++seq;
  c.utime = wall_us();
  c.source = command_source();
  c.host = o.host_given ? o.host : "";
  c.group = o.group_filter;
  c.command = command;
  c.process = process;
  static const auth::Key key = auth::load_key(auth::key_path());
  node::publish_signed(lcm, hpr::msg::channels::kSupervisorCommand.name, c, key);
}

int cmd_down(const Options& o, const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) throw std::runtime_error("cannot open LCM on " + url);
  struct Seen {
    Status last;
    double heard = 0;
    bool stopped = false;
  };
  std::map<std::pair<std::string, std::string>, Seen> seen;
  const std::string me = command_source();
  Subscription sub(lcm, hpr::msg::channels::kSupervisorStatus, [&](const Status& s) {
    if (!o.group_filter.empty() && s.group != o.group_filter) return;
    if (o.host_given && s.host != o.host) return;
    // A goodbye from a supervisor not heard before is an old one (another down's), unless it
    // names this down: a supervisor that stopped before any of its statuses reached us.
    const bool goodbye = s.state == Status::STATE_STOPPED;
    if (goodbye && !seen.contains({s.host, s.group}) && s.message.find(me) == std::string::npos) return;
    auto& e = seen[{s.host, s.group}];
    e.last = s;
    e.heard = monotonic_s();
    e.stopped = e.stopped || s.state == Status::STATE_STOPPED;
  });
  // A supervisor is done when it said goodbye and its pid is gone (or 10 s passed: the pid may be
  // another machine's, and a process of this one may have the same number), or when it has been
  // silent for 2 s.
  const auto finished = [](const Seen& e) {
    const double silent = monotonic_s() - e.heard;
    return e.stopped ? ::kill(e.last.pid, 0) != 0 || silent > 10.0 : silent > 2.0;
  };
  const double start = monotonic_s();
  double last_send = -10;
  while (!g_stop) {
    const double now = monotonic_s();
    if (now - last_send >= 1.0) {
      send_command(lcm, o, humanoid::supervisor_command_t::COMMAND_DOWN, "");
      last_send = now;
    }
    handle_for(lcm, 0.05);
    const bool all_heard = now - start > 1.5;  // the time for every supervisor to answer
    if (all_heard && std::all_of(seen.begin(), seen.end(), [&](const auto& kv) { return finished(kv.second); })) break;
    if (now - start > 120) {
      std::cerr << "supervisor: down timed out after 120 s\n";
      return 1;
    }
  }
  if (seen.empty()) {
    std::cout << "no supervisor answered on " << url << ": nothing to stop\n";
    return 0;
  }
  for (const auto& [k, e] : seen) {
    std::cout << fmt::format("group '{}' on host '{}': {} ({} processes; logs in {})\n", k.second, k.first,
                             e.stopped ? "stopped" : "no longer answering", e.last.num_processes, e.last.run_dir);
  }
  return 0;
}

int cmd_restart(const Options& o, const std::string& url) {
  lcm::LCM lcm(url);
  if (!lcm.good()) throw std::runtime_error("cannot open LCM on " + url);
  const auto before = collect_status(lcm, 1.0, o.group_filter);
  int restarts = -1;
  std::string host;
  for (const auto& h : before) {
    for (int i = 0; i < h.num_processes; ++i) {
      if (h.name[i] == o.target) {
        restarts = h.restarts[i];
        host = h.host;
      }
    }
  }
  if (restarts < 0) {
    std::cerr << "supervisor: no supervisor runs a process named '" << o.target << "' on " << url << "\n";
    return 3;
  }
  Options oo = o;
  oo.host = host;
  oo.host_given = true;
  send_command(lcm, oo, humanoid::supervisor_command_t::COMMAND_RESTART, o.target);
  const double end = monotonic_s() + 60;
  while (!g_stop && monotonic_s() < end) {
    for (const auto& h : collect_status(lcm, 0.6, o.group_filter)) {
      for (int i = 0; i < h.num_processes; ++i) {
        if (h.host == host && h.name[i] == o.target && h.restarts[i] > restarts &&
            h.process_state[i] == Status::PROCESS_READY) {
          std::cout << fmt::format("{} on host {} restarted: pid {}, ready\n", o.target, host, h.process_pid[i]);
          return 0;
        }
      }
    }
  }
  std::cerr << "supervisor: " << o.target << " did not come back ready within 60 s (supervisor logs " << o.target << ")\n";
  return 1;
}

int cmd_logs(const Options& o, const std::string& url) {
  std::string path;
  {
    lcm::LCM lcm(url);
    if (lcm.good()) {
      for (const auto& h : collect_status(lcm, 1.0, o.group_filter)) {
        for (int i = 0; i < h.num_processes; ++i) {
          if (h.name[i] == o.target) path = h.run_dir + "/" + o.target + ".log";
        }
      }
    }
  }
  if (path.empty() || !fs::exists(path)) {
    // Not running (or on another machine): the latest run folder here.
    for (const auto& entry : {fs::path(o.run_root) / "latest", fs::path(o.run_root) / ("latest-" + o.host)}) {
      if (fs::exists(entry / (o.target + ".log"))) path = (entry / (o.target + ".log")).string();
    }
  }
  if (path.empty() || !fs::exists(path)) {
    std::cerr << "supervisor: no log for '" << o.target << "' (not running here, and not in " << o.run_root << "/latest)\n";
    return 3;
  }
  std::cout << tail_file(path, o.lines) << std::flush;
  if (!o.follow) return 0;
  std::ifstream in(path);
  in.seekg(0, std::ios::end);
  std::string line;
  while (!g_stop) {
    if (std::getline(in, line)) {
      std::cout << line << std::endl;
    } else {
      in.clear();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  return 0;
}

int cmd_groups(const Options& o) {
  const launch::GroupsFile file = launch::GroupsFile::load(o.groups_file, o.vars);
  std::cout << "groups in " << file.path << ":\n";
  for (const auto& n : file.names) {
    const auto& g = file.groups.at(n);
    std::cout << fmt::format("  {:<12} {}\n", n, g.description);
    for (const auto& p : g.processes) {
      std::cout << fmt::format("      {:<16} {}{}{}{}\n", p.name, p.command, g.host_of(p).empty() ? "" : "  @" + g.host_of(p),
                               p.critical ? "  critical" : "", p.depends_on.empty() ? "" : "  after " + fmt::format("{}", fmt::join(p.depends_on, ",")));
    }
    for (const auto& u : unmet_inputs(g)) std::cout << fmt::format("      (needs from outside: {})\n", u);
  }
  return 0;
}

}  // namespace hpr::supervisor_cli
