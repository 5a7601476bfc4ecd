// supervisor: starts, watches and stops the stack's process groups (config/groups.yaml).
//
//   supervisor up GROUP      start this host's share of GROUP in the background; returns when it is up
//   supervisor down          stop every group on every host (or --host, --group)
//   supervisor status        one table for every host's supervisor, over LCM
//   supervisor logs NAME     a process's log from the run folder
//   supervisor restart NAME  stop a process and start it again
//
// Each host runs its own supervisor; they publish SUPERVISOR_STATUS and obey SUPERVISOR_COMMAND on
// the group's LCM URL, so that a status or a down from any host covers them all. When a process
// marked critical dies, the supervisor publishes OPERATOR damp at once.
#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "hpr/msg/channels.hpp"  // every channel with its message type
#include "hpr/msg/commands.hpp"
#include "hpr/node/lcm_url.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fmt/chrono.h>
#include <fmt/format.h>
#include <fstream>
#include <functional>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/launch/groups.hpp"
#include "hpr/launch/process_group.hpp"
#include "hpr/launch/supervisor.hpp"
#include "hpr/node/lifecycle.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/common/auth.hpp"
#include "supervisor_cli.hpp"

using namespace hpr;
using launch::GroupState;
using launch::ProcessState;
using namespace hpr::supervisor_cli;

namespace {

constexpr const char* kUsage = R"(supervisor: starts, watches and stops the stack's process groups

usage: supervisor up GROUP [options]     start this host's share of GROUP; returns once it is up
       supervisor down [options]         stop the groups of every host (or --host / --group)
       supervisor status [options]       status of every host's supervisor (from LCM)
       supervisor logs NAME [-f] [-n N]  the log of process NAME in the run folder
       supervisor restart NAME [options] stop process NAME and start it again
       supervisor groups [options]       list the groups of the file
       supervisor keygen                 create the deployment's LCM key if there is none; print its path

options:
  --groups FILE     group file (default: $HPR_GROUPS, else config/groups.yaml of this build or install)
  --host NAME       this supervisor's host name in the group (default: the machine's host name)
  --group NAME      (down, status) only this group
  --var KEY=VALUE   set a variable of the group file (e.g. --var robot=h1_2)
  --run-root DIR    where run folders go (default: $HPR_RUN_ROOT, else ./output/runs)
  --lcm-url URL     LCM URL for the group and the supervisors (default: lcm_url of the file, else
                    $LCM_DEFAULT_URL)

Commands and the control chain's samples (OPERATOR, JOINT_COMMAND, SUPERVISOR_COMMAND, ROBOT_SENSORS,
ROBOT_STATE, ...) are signed with the key file
$HPR_LCM_KEY_FILE (default ~/.config/hpr/lcm.key): `up` creates it when there is none and names it to
every process; the other hosts of a multi-host group need a copy (mode 0600).
  --foreground      (up) stay attached; Ctrl-C stops the group
  --json            (status) one JSON object instead of the table
  --wait S          (status) seconds to listen for the supervisors (default 1.2)
  -f, -n N          (logs) follow; last N lines (default 100)
)";

std::string default_groups_file() {
  if (const char* e = std::getenv("HPR_GROUPS")) return e;
  const fs::path exe = launch::executable_dir();
  for (const fs::path& c : {exe / "../../config/groups.yaml", exe / "../share/hpr/config/groups.yaml", fs::path("config/groups.yaml")}) {
    if (fs::exists(c)) return fs::weakly_canonical(c).string();
  }
  return "config/groups.yaml";
}

Status make_status(const launch::Supervisor& sup, std::int64_t seq, const std::string& message, double now) {
  Status m;
  m.tick = seq;
  m.utime = wall_us();
  m.host = sup.host();
  m.group = sup.group().name;
  m.pid = static_cast<int32_t>(::getpid());
  m.run_dir = sup.run_dir();
  m.state = static_cast<int8_t>(sup.state());
  m.message = message;
  for (const auto& p : sup.processes()) {
    m.name.push_back(p.name);
    m.process_state.push_back(static_cast<int8_t>(p.state));
    m.process_pid.push_back(p.pid);
    m.uptime_s.push_back(p.pid > 0 ? now - p.started_at : 0.0);
    m.restarts.push_back(p.restarts);
    m.critical.push_back(p.critical ? 1 : 0);
    m.health_state.push_back(p.hung ? humanoid::supervisor_status_t::HEALTH_HUNG : static_cast<int8_t>(p.health_state));
    m.lifecycle.push_back(static_cast<int8_t>(p.lifecycle));
    m.rate_hz.push_back(p.rate_hz);
    m.deadline_misses.push_back(p.deadline_misses);
    // A running process's detail is what its HEALTH reports wrong; an ended one's how it ended.
    std::string detail = p.detail.empty() ? p.faults : p.faults.empty() ? p.detail : p.detail + "; " + p.faults;
    if (p.hung) detail = "no HEALTH: stopped, stuck or starved" + (detail.empty() ? "" : "; last: " + detail);
    m.detail.push_back(detail);
  }
  m.num_processes = static_cast<int32_t>(m.name.size());
  return m;
}

// ---------------------------------------------------------------------------------------------
// The running supervisor.

/// SUPERVISOR_COMMAND for this host and group (signed with the deployment's key): a down (and who
/// asked) and restarts; refusals counted, and said once a second at most.
class CommandIntake {
 public:
  CommandIntake(lcm::LCM& lcm, const auth::Key& key, const std::string& me, const std::string& group, launch::Supervisor& sup)
      : me_(me), group_(group), sup_(sup),
        sub_(lcm, hpr::msg::channels::kSupervisorCommand, [this](const humanoid::supervisor_command_t& c) { on(c); }, &key) {}
  bool down_requested = false;
  std::string down_source;  ///< who asked for the down: the goodbye names it

 private:
  void on(const humanoid::supervisor_command_t& c) {
    if (!c.host.empty() && c.host != me_) return;
    if (!c.group.empty() && c.group != group_) return;
    if (const std::string why = msg::check_supervisor_command(c); !why.empty()) {
      ++refused_;
      if (monotonic_s() - last_refusal_log_ >= 1.0) {
        last_refusal_log_ = monotonic_s();
        std::cout << fmt::format("[{}] SUPERVISOR_COMMAND from '{}' refused: {} ({} refused so far)", now_text(), c.source, why, refused_)
                  << std::endl;
      }
      return;
    }
    if (c.command == humanoid::supervisor_command_t::COMMAND_DOWN) {
      if (!down_requested) {
        std::cout << fmt::format("[{}] down requested by {}", now_text(), c.source) << std::endl;
        down_source = c.source;
      }
      down_requested = true;
    } else if (c.command == humanoid::supervisor_command_t::COMMAND_RESTART) {
      if (sup_.restart(c.process, monotonic_s())) {
        std::cout << fmt::format("[{}] {}: restart requested by {}", now_text(), c.process, c.source) << std::endl;
      }
    }
  }

  const std::string me_, group_;
  launch::Supervisor& sup_;
  double last_refusal_log_ = -1e9;
  std::int64_t refused_ = 0;
  Subscription<humanoid::supervisor_command_t> sub_;
};

/// OPERATOR damp, signed, to every drive of the deployment (a critical process died or hung, or the
/// group goes down while one runs).
class Damper {
 public:
  Damper(lcm::LCM& lcm, const auth::Key& key, const std::string& me) : lcm_(lcm), key_(key), me_(me) {}
  void send(const std::string& reason) {
    humanoid::operator_t op{};
    op.tick = ++seq_;
    op.utime = wall_us();
    op.source = "supervisor@" + me_;
    op.command = humanoid::operator_t::COMMAND_DAMP;
    op.support = 0;
    op.reason = reason;
    op.num_params = 0;
    node::publish_signed(lcm_, hpr::msg::channels::kOperator.name, op, key_);
    std::cout << fmt::format("[{}] OPERATOR damp sent: {}", now_text(), reason) << std::endl;
  }

 private:
  lcm::LCM& lcm_;
  const auth::Key& key_;
  const std::string me_;
  std::int64_t seq_ = 0;
};

/// The text `supervisor up` prints when the group failed: the status and the failed processes' last lines.
std::string failure_text(const launch::Supervisor& sup, const std::string& why, const Status& status) {
  std::string text = "failed: " + why + "\n" + render({status});
  for (const auto& p : sup.processes()) {
    if (p.state == ProcessState::kFailed) text += "\n--- last lines of " + sup.log_file(p.name) + "\n" + tail_file(sup.log_file(p.name), 15);
  }
  return text;
}

int run_supervisor(const launch::GroupSpec& group, const Options& o, const std::string& url, const std::string& run_dir, int notify_fd) {
  const auto notify = [&](const std::string& text) {
    if (notify_fd < 0) return;
    (void)!::write(notify_fd, text.data(), text.size());
    ::close(notify_fd);
    notify_fd = -1;
  };
  hpr::log::init("supervisor");
  // It judges hangs by HEALTH among every message of the stack: a receive buffer of seconds of
  // traffic (as a recorder's), so that a moment without a core loses no HEALTH and raises no false hang.
  lcm::LCM lcm(hpr::node::with_receive_buffer(url, hpr::node::kRecorderBufferBytes));
  if (!lcm.good()) {
    const std::string msg = "failed: cannot open LCM on " + url + " (is multicast enabled on the interface? tools/install-deps sets it up)\n";
    std::cerr << msg;
    notify(msg);
    return 1;
  }
  launch::ProcessGroup launcher(url);  // creates the deployment's key when there is none
  const auth::Key key = auth::load_key(launcher.key_path());
  launch::Supervisor sup(group, o.host, run_dir, launcher);
  std::string last_event;
  bool changed = true;

  // HEALTH is taken only signed with the key, and only from the process this supervisor started
  // under that node's name (its pid): a forged or replayed HEALTH does not clear a hang.
  std::int64_t foreign_health = 0;
  Subscription health_sub(
      lcm, hpr::msg::channels::kHealth,
      [&](const humanoid::health_t& h) {
        if (!sup.started(h.node, h.pid)) {
          ++foreign_health;
          hpr::log::warn("HEALTH of {} from pid {} ignored: not the process this supervisor runs as {} ({} so far)", h.node, h.pid, h.node,
                         foreign_health);
          return;
        }
        sup.on_health(h.node, h.state, h.lifecycle, h.rate_hz, h.deadline_misses, h.faults, monotonic_s());
      },
      &key);
  const std::string& me = o.host;
  Subscription status_sub(lcm, hpr::msg::channels::kSupervisorStatus, [&](const Status& s) {
    if (s.host == me || s.group != group.name) return;
    for (int i = 0; i < s.num_processes; ++i) {
      sup.on_remote_ready(s.name[i], s.process_state[i] == Status::PROCESS_READY);
    }
  }, &key);
  CommandIntake commands(lcm, key, me, group.name, sup);
  Damper damper(lcm, key, me);

  std::cout << fmt::format("[{}] supervisor for group '{}' on host '{}', LCM {}, run folder {}", now_text(), group.name, me, url, run_dir) << std::endl;
  sup.up(monotonic_s());
  std::int64_t seq = 0;
  double last_status = -1;
  bool failed = false, down_started = false;
  while (true) {
    handle_for(lcm, 0.01);
    hpr::log::flush_repeats();
    const double now = monotonic_s();
    if ((g_stop || commands.down_requested) && !down_started) {
      down_started = true;
      const bool critical_running = std::any_of(sup.processes().begin(), sup.processes().end(), [](const launch::ProcessStatus& p) {
        return p.critical && (p.state == ProcessState::kReady || p.state == ProcessState::kStarting);
      });
      if (critical_running) damper.send("group '" + group.name + "' going down on " + me);
      sup.down(now);
    }
    sup.step(now);
    for (const auto& e : sup.take_events()) {
      const std::string line = e.process.empty() ? e.text : e.process + ": " + e.text;
      std::cout << fmt::format("[{}] {}", now_text(), line) << std::endl;
      last_event = line;
      changed = true;
      using K = launch::SupervisorEvent::Kind;
      if ((e.kind == K::kCriticalDied || e.kind == K::kCriticalHung) && !down_started) damper.send(e.text);
      if (e.kind == K::kGroupUp) notify("up\n" + render({make_status(sup, seq, last_event, now)}));
      if (e.kind == K::kGroupFailed) {
        failed = true;
        notify(failure_text(sup, e.text, make_status(sup, seq, last_event, now)));
        commands.down_requested = true;
      }
    }
    if (changed || now - last_status >= 0.5) {
      Status m = make_status(sup, ++seq, last_event, now);
      node::publish_signed(lcm, hpr::msg::channels::kSupervisorStatus.name, m, key);
      last_status = now;
      changed = false;
    }
    if (down_started && sup.all_ended()) break;
  }
  launcher.stop_all(std::chrono::milliseconds(500));
  Status m = make_status(sup, ++seq, commands.down_source.empty() ? "stopped" : "stopped: down by " + commands.down_source, monotonic_s());
  m.state = Status::STATE_STOPPED;
  for (int i = 0; i < 3; ++i) {
    node::publish_signed(lcm, hpr::msg::channels::kSupervisorStatus.name, m, key);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::cout << fmt::format("[{}] group '{}' stopped on host '{}'", now_text(), group.name, me) << std::endl;
  notify(failed ? "failed: stopped\n" : "stopped before it was up\n");
  return failed ? 1 : 0;
}

std::string make_run_dir(const Options& o, const launch::GroupSpec& g) {
  const std::time_t t = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&t));
  const fs::path root = o.run_root;
  std::string base = std::string(stamp) + "-" + g.name + (g.hosts().empty() ? "" : "-" + o.host);
  fs::path dir = root / base;
  for (int i = 2; fs::exists(dir); ++i) dir = root / (base + "." + std::to_string(i));
  fs::create_directories(dir);
  const fs::path latest = root / (g.hosts().empty() ? std::string("latest") : "latest-" + o.host);
  std::error_code ec;
  fs::remove(latest, ec);
  fs::create_directory_symlink(dir.filename(), latest, ec);
  return fs::absolute(dir).lexically_normal().string();
}

int cmd_up(const Options& o) {
  const launch::GroupsFile file = launch::GroupsFile::load(o.groups_file, o.vars);
  const launch::GroupSpec& group = file.group(o.target);
  for (const auto& u : unmet_inputs(group)) {
    std::cout << fmt::format("supervisor: note: in group '{}', {}: another group or host must provide it\n", group.name, u);
  }
  const auto hosts = group.hosts();
  if (!hosts.empty() && std::find(hosts.begin(), hosts.end(), o.host) == hosts.end() && !group.default_host.empty() && group.default_host != o.host) {
    std::string list;
    for (const auto& h : hosts) list += (list.empty() ? "" : ", ") + h;
    std::cerr << fmt::format("supervisor: group '{}' places its processes on hosts {}; this supervisor is '{}' (use --host)\n", group.name, list, o.host);
    return 2;
  }
  const std::string url = resolve_url(o, &file);
  {
    // One supervisor per host and group on a URL: a second `up` would start every process twice.
    lcm::LCM probe(url);
    if (!probe.good()) {
      std::cerr << "supervisor: cannot open LCM on " << url << " (is multicast routed? tools/install-deps sets up loopback)\n";
      return 1;
    }
    for (const auto& s : collect_status(probe, 0.7, group.name)) {
      if (s.host == o.host) {
        std::cerr << fmt::format("supervisor: group '{}' is already {} on host '{}' (supervisor pid {}, run folder {}); "
                                 "`supervisor down` first\n",
                                 group.name, launch::to_string(static_cast<GroupState>(s.state)), s.host, s.pid, s.run_dir);
        return 1;
      }
    }
  }
  const std::string run_dir = make_run_dir(o, group);
  {
    std::error_code ec;
    fs::copy_file(o.groups_file, fs::path(run_dir) / "groups.yaml", ec);
    // What tools/record and a reader of the folder need without parsing its name.
    std::ofstream(fs::path(run_dir) / "run.yaml") << "# written by `supervisor up`\n"
                                                  << "group: \"" << group.name << "\"\n"
                                                  << "host: \"" << o.host << "\"\n"
                                                  << "lcm_url: \"" << url << "\"\n"
                                                  << "started: \"" << fmt::format("{:%F %T}", fmt::localtime(std::time(nullptr))) << "\"\n";
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, SIG_IGN);
  std::signal(SIGPIPE, SIG_IGN);
  if (o.foreground) return run_supervisor(group, o, url, run_dir, -1);

  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  std::cout << fmt::format("supervisor: starting group '{}' on host '{}' (LCM {}); run folder {}", group.name, o.host, url, run_dir) << std::endl;
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    ::close(fds[0]);
    ::setsid();
    const int null = ::open("/dev/null", O_RDONLY);
    ::dup2(null, STDIN_FILENO);
    const int log = ::open((run_dir + "/supervisor.log").c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(log, STDOUT_FILENO);
    ::dup2(log, STDERR_FILENO);
    int rc = 1;
    try {
      rc = run_supervisor(group, o, url, run_dir, fds[1]);
    } catch (const std::exception& e) {
      std::cerr << "supervisor: " << e.what() << std::endl;
      const std::string msg = std::string("failed: ") + e.what() + "\n";
      (void)!::write(fds[1], msg.data(), msg.size());
    }
    std::_Exit(rc);
  }
  ::close(fds[1]);
  std::string text;
  char buf[4096];
  while (true) {
    const ssize_t n = ::read(fds[0], buf, sizeof(buf));
    if (n > 0) {
      text.append(buf, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) {
      if (g_stop) {
        ::kill(pid, SIGTERM);
        g_stop = false;
      }
      continue;
    }
    break;
  }
  ::close(fds[0]);
  if (text.rfind("up\n", 0) == 0) {
    std::cout << text.substr(3);
    std::cout << fmt::format("group '{}' is up (supervisor pid {}). Next: supervisor status | logs NAME | down; tools/lcm-spy to watch.\n", group.name, pid);
    return 0;
  }
  std::cerr << "supervisor: group '" << group.name << "' did not come up: " << (text.empty() ? "the supervisor ended (see " + run_dir + "/supervisor.log)\n" : text);
  int st = 0;
  ::waitpid(pid, &st, 0);
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  o.command = args[0];
  o.host = machine_host();
  o.run_root = std::getenv("HPR_RUN_ROOT") != nullptr ? std::getenv("HPR_RUN_ROOT") : "output/runs";
  try {
    hpr::ArgReader a(args);
    a.next();  // the command
    while (a.next()) {
      if (a.is("--groups")) {
        o.groups_file = a.value();
      } else if (a.is("--host")) {
        o.host = a.value();
        o.host_given = true;
      } else if (a.is("--group")) {
        o.group_filter = a.value();
      } else if (a.is("--var")) {
        const std::string kv = a.value();
        const auto eq = kv.find('=');
        if (eq == std::string::npos || eq == 0) throw UsageError("--var needs KEY=VALUE, got '" + kv + "'");
        o.vars[kv.substr(0, eq)] = kv.substr(eq + 1);
      } else if (a.is("--run-root")) {
        o.run_root = a.value();
      } else if (a.is("--lcm-url")) {
        o.lcm_url = a.value();
      } else if (a.is("--foreground")) {
        o.foreground = true;
      } else if (a.is("--json")) {
        o.json = true;
      } else if (a.is("--wait")) {
        o.wait_s = a.number();
      } else if (a.is("-f", "--follow")) {
        o.follow = true;
      } else if (a.is("-n")) {
        o.lines = a.integer();
      } else if (a.positional() && o.target.empty()) {
        o.target = a.current();
      } else {
        a.unknown();
      }
    }
    if (o.groups_file.empty()) o.groups_file = default_groups_file();
    const bool needs_target = o.command == "up" || o.command == "logs" || o.command == "restart";
    if (needs_target && o.target.empty()) throw UsageError(o.command + " needs a " + (o.command == "up" ? "GROUP" : "NAME"));
    if (o.command == "up") return cmd_up(o);
    if (o.command == "groups") return cmd_groups(o);
    if (o.command == "keygen") {
      const std::string path = auth::key_path();
      (void)auth::load_or_create_key(path);
      std::cout << path << "\n";
      return 0;
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    // The URL: --lcm-url, else the group file's, else the environment's.
    std::optional<launch::GroupsFile> file;
    if (o.lcm_url.empty() && fs::exists(o.groups_file)) file = launch::GroupsFile::load(o.groups_file, o.vars);
    const std::string url = resolve_url(o, file ? &*file : nullptr);
    if (o.command == "status") return cmd_status(o, url);
    if (o.command == "down") return cmd_down(o, url);
    if (o.command == "restart") return cmd_restart(o, url);
    if (o.command == "logs") return cmd_logs(o, url);
    throw UsageError("unknown command '" + o.command + "'");
  } catch (const ConfigError& e) {
    std::cerr << "supervisor: " << e.what() << "\n";
    return 2;
  } catch (const UsageError& e) {
    std::cerr << "supervisor: " << e.what() << "\n\n" << kUsage;
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "supervisor: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "supervisor: " << e.what() << "\n";
    return 1;
  }
}
