// The supervisor's shared helpers (supervisor_cli.hpp).
#include <poll.h>
#include <unistd.h>

#include <humanoid/health_t.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <deque>
#include <fstream>

#include "hpr/common/time.hpp"
#include "hpr/launch/supervisor.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/graph/data_flow.hpp"
#include "hpr/node/lifecycle.hpp"
#include "supervisor_cli.hpp"

namespace hpr::supervisor_cli {

using launch::GroupState;
using launch::ProcessState;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

std::string machine_host() {
  char buf[256] = {};
  ::gethostname(buf, sizeof(buf) - 1);
  std::string h = buf;
  if (const auto dot = h.find('.'); dot != std::string::npos) h.resize(dot);
  return h.empty() ? "localhost" : h;
}

std::string resolve_url(const Options& o, const launch::GroupsFile* f) {
  if (!o.lcm_url.empty()) return o.lcm_url;
  if (f != nullptr && !f->lcm_url.empty()) return f->lcm_url;
  if (const char* e = std::getenv("LCM_DEFAULT_URL"); e != nullptr && *e != '\0') return e;
  return "udpm://239.255.76.67:7667?ttl=0";
}

std::string now_text() {
  const auto t = std::chrono::system_clock::now();
  const std::time_t s = std::chrono::system_clock::to_time_t(t);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count() % 1000;
  char buf[32];
  std::strftime(buf, sizeof(buf), "%T", std::localtime(&s));
  return fmt::format("{}.{:03d}", buf, static_cast<int>(ms));
}

const char* health_text(int s) {
  switch (s) {
    case humanoid::health_t::STATE_STARTING: return "starting";
    case humanoid::health_t::STATE_OK: return "ok";
    case humanoid::health_t::STATE_DEGRADED: return "degraded";
    case humanoid::health_t::STATE_FAULT: return "FAULT";
    case humanoid::health_t::STATE_STOPPING: return "stopping";
    case humanoid::supervisor_status_t::HEALTH_HUNG: return "HUNG";
    default: return "-";
  }
}

std::string uptime_text(double s) {
  if (s <= 0) return "-";
  if (s < 60) return fmt::format("{:.1f}s", s);
  if (s < 3600) return fmt::format("{}m{:02d}s", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  return fmt::format("{}h{:02d}m", static_cast<int>(s) / 3600, (static_cast<int>(s) / 60) % 60);
}

/// The status table of one or more hosts' supervisors.
std::string render(const std::vector<Status>& hosts) {
  std::ostringstream out;
  for (const auto& h : hosts) {
    out << fmt::format("group {} on host {}: {}  (supervisor pid {}, run folder {})\n", h.group, h.host,
                       launch::to_string(static_cast<GroupState>(h.state)), h.pid, h.run_dir);
    if (!h.message.empty()) out << "  last event: " << h.message << "\n";
  }
  out << fmt::format("{:<16} {:<10} {:<9} {:>8} {:>9} {:>8} {:>9} {:>7} {:<9} {:<9} {}\n", "NAME", "HOST", "STATE", "PID", "UPTIME",
                     "RESTARTS", "RATE[Hz]", "MISSES", "HEALTH", "LIFECYCLE", "DETAIL");
  for (const auto& h : hosts) {
    for (int i = 0; i < h.num_processes; ++i) {
      const auto ps = static_cast<ProcessState>(h.process_state[i]);
      const bool live = ps == ProcessState::kStarting || ps == ProcessState::kReady || ps == ProcessState::kStopping;
      out << fmt::format("{:<16} {:<10} {:<9} {:>8} {:>9} {:>8} {:>9} {:>7} {:<9} {:<9} {}\n", h.name[i] + (h.critical[i] ? "*" : ""), h.host,
                         launch::to_string(ps), live ? std::to_string(h.process_pid[i]) : "-", live ? uptime_text(h.uptime_s[i]) : "-",
                         h.restarts[i], h.health_state[i] >= 0 ? fmt::format("{:.1f}", h.rate_hz[i]) : "-",
                         h.health_state[i] >= 0 ? std::to_string(h.deadline_misses[i]) : "-", health_text(h.health_state[i]),
                         live && h.lifecycle[i] >= 0 ? node::to_string(static_cast<node::Lifecycle>(h.lifecycle[i])) : "-", h.detail[i]);
    }
  }
  out << "(* critical: its death, or a HEALTH silence longer than its hung_after, commands OPERATOR damp)\n";
  return out.str();
}

std::string tail_file(const std::string& path, int lines) {
  std::ifstream in(path);
  if (!in) return "";
  std::deque<std::string> last;
  std::string line;
  while (std::getline(in, line)) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const auto& l : last) out += l + "\n";
  return out;
}

/// Handles messages for `timeout_s`, and always whatever is already queued: a supervisor that was
/// not scheduled for a while reads the HEALTH sent meanwhile before it judges any node hung.
void handle_for(lcm::LCM& lcm, double timeout_s) {
  const double end = monotonic_s() + timeout_s;
  while (!g_stop) {
    const double left = std::max(0.0, end - monotonic_s());
    pollfd p{lcm.getFileno(), POLLIN, 0};
    if (poll_for({&p, 1}, left) > 0 && (p.revents & POLLIN) != 0) {
      lcm.handle();
    } else if (left <= 0) {
      break;
    }
  }
}

/// The latest status of each (host, group) heard within `wait_s`.
std::vector<Status> collect_status(lcm::LCM& lcm, double wait_s, const std::string& group_filter) {
  std::map<std::pair<std::string, std::string>, Status> latest;
  {
    Subscription sub(lcm, hpr::msg::channels::kSupervisorStatus, [&](const Status& s) {
      if (!group_filter.empty() && s.group != group_filter) return;
      latest[{s.host, s.group}] = s;
    });
    handle_for(lcm, wait_s);
  }
  std::vector<Status> out;
  for (auto& [k, v] : latest) {
    if (v.state != Status::STATE_STOPPED) out.push_back(v);
  }
  return out;
}

/// The group's inputs that none of its processes writes (the stack's declared data flow), e.g. the
/// sensors of the `control` group, which a backend group provides.
std::vector<std::string> unmet_inputs(const launch::GroupSpec& g) {
  std::vector<std::string> commands;
  for (const auto& p : g.processes) commands.push_back(fs::path(p.command).filename().string());
  return graph::unmet_inputs(commands);
}

}  // namespace hpr::supervisor_cli
