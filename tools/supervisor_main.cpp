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

#include <humanoid/health_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/supervisor_command_t.hpp>
#include <humanoid/supervisor_status_t.hpp>

#include "hpr/msg/commands.hpp"

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
#include "hpr/msg/graph.hpp"
#include "hpr/node/lifecycle.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/common/auth.hpp"

namespace fs = std::filesystem;
using namespace hpr;
using launch::GroupState;
using launch::ProcessState;
using Status = humanoid::supervisor_status_t;

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

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Options {
  std::string command, target;  // target: group (up) or process (logs, restart)
  std::string groups_file, host, group_filter, run_root, lcm_url;
  std::map<std::string, std::string> vars;
  bool host_given = false, foreground = false, json = false, follow = false;
  double wait_s = 1.2;
  int lines = 100;
};

std::string machine_host() {
  char buf[256] = {};
  ::gethostname(buf, sizeof(buf) - 1);
  std::string h = buf;
  if (const auto dot = h.find('.'); dot != std::string::npos) h.resize(dot);
  return h.empty() ? "localhost" : h;
}

std::string default_groups_file() {
  if (const char* e = std::getenv("HPR_GROUPS")) return e;
  const fs::path exe = launch::executable_dir();
  for (const fs::path& c : {exe / "../../config/groups.yaml", exe / "../share/hpr/config/groups.yaml", fs::path("config/groups.yaml")}) {
    if (fs::exists(c)) return fs::weakly_canonical(c).string();
  }
  return "config/groups.yaml";
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

/// A typed LCM subscription calling a std::function (this LCM release has no lambda subscribe).
/// A message that does not decode is counted (errors()) and logged, rate limited, with its
/// channel and size, instead of LCM's own line per message. With a key, a message without its valid
/// authentication code is refused the same way before it is decoded (unauthenticated()).
template <class Msg>
class Subscription {
 public:
  Subscription(lcm::LCM& lcm, const std::string& channel, std::function<void(const Msg&)> f, const auth::Key* key = nullptr)
      : lcm_(lcm), f_(std::move(f)), key_(key) {
    sub_ = lcm_.subscribe(channel, &Subscription::on, this);
  }
  ~Subscription() { lcm_.unsubscribe(sub_); }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  [[nodiscard]] std::int64_t errors() const { return errors_; }
  [[nodiscard]] std::int64_t unauthenticated() const { return unauthenticated_; }

 private:
  void on(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (key_ != nullptr && !auth::verify(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, *key_)) {
      ++errors_;
      ++unauthenticated_;
      hpr::log::warn("{}: a message of {} bytes refused: no valid authentication code (not signed with {}; {} refused so far)",
                     channel, rbuf->data_size, key_->path, unauthenticated_);
      return;
    }
    if (msg_.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      ++errors_;
      hpr::log::warn("{}: a message of {} bytes is not a valid {} ({} so far)", channel, rbuf->data_size, Msg::getTypeName(), errors_);
      return;
    }
    f_(msg_);
  }
  lcm::LCM& lcm_;
  std::function<void(const Msg&)> f_;
  const auth::Key* key_ = nullptr;
  lcm::Subscription* sub_ = nullptr;
  Msg msg_{};
  std::int64_t errors_ = 0, unauthenticated_ = 0;
};

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

// ---------------------------------------------------------------------------------------------
// The running supervisor.

int run_supervisor(const launch::GroupSpec& group, const Options& o, const std::string& url, const std::string& run_dir, int notify_fd) {
  const auto notify = [&](const std::string& text) {
    if (notify_fd < 0) return;
    (void)!::write(notify_fd, text.data(), text.size());
    ::close(notify_fd);
    notify_fd = -1;
  };
  hpr::log::init("supervisor");
  lcm::LCM lcm(url);
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

  Subscription<humanoid::health_t> health_sub(lcm, "HEALTH", [&](const humanoid::health_t& h) {
    sup.on_health(h.node, h.state, h.lifecycle, h.rate_hz, h.deadline_misses, h.faults, monotonic_s());
  });

  const std::string& me = o.host;
  Subscription<Status> status_sub(lcm, "SUPERVISOR_STATUS", [&](const Status& s) {
    if (s.host == me || s.group != group.name) return;
    for (int i = 0; i < s.num_processes; ++i) {
      sup.on_remote_ready(s.name[i], s.process_state[i] == Status::PROCESS_READY);
    }
  });
  bool down_requested = false;
  std::string down_source;  // who asked for the down: the goodbye names it
  double last_refusal_log = -1e9;
  std::int64_t refused_commands = 0;
  Subscription<humanoid::supervisor_command_t> command_sub(lcm, "SUPERVISOR_COMMAND", [&](const humanoid::supervisor_command_t& c) {
    if (!c.host.empty() && c.host != me) return;
    if (!c.group.empty() && c.group != group.name) return;
    if (const std::string why = msg::check_supervisor_command(c); !why.empty()) {
      ++refused_commands;
      if (monotonic_s() - last_refusal_log >= 1.0) {  // one line a second at most
        last_refusal_log = monotonic_s();
        std::cout << fmt::format("[{}] SUPERVISOR_COMMAND from '{}' refused: {} ({} refused so far)", now_text(), c.source, why,
                                 refused_commands)
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
      if (sup.restart(c.process, monotonic_s())) {
        std::cout << fmt::format("[{}] {}: restart requested by {}", now_text(), c.process, c.source) << std::endl;
      }
    }
  }, &key);

  std::int64_t seq = 0, damp_seq = 0;
  const auto publish_damp = [&](const std::string& reason) {
    humanoid::operator_t op{};
    op.tick = ++damp_seq;
    op.utime = wall_us();
    op.source = "supervisor@" + me;
    op.command = humanoid::operator_t::COMMAND_DAMP;
    op.support = 0;
    op.reason = reason;
    op.num_params = 0;
    node::publish_signed(lcm, "OPERATOR", op, key);
    std::cout << fmt::format("[{}] OPERATOR damp sent: {}", now_text(), reason) << std::endl;
  };

  std::cout << fmt::format("[{}] supervisor for group '{}' on host '{}', LCM {}, run folder {}", now_text(), group.name, me, url, run_dir) << std::endl;
  sup.up(monotonic_s());
  double last_status = -1;
  bool failed = false, down_started = false;
  while (true) {
    handle_for(lcm, 0.01);
    hpr::log::flush_repeats();
    const double now = monotonic_s();
    if ((g_stop || down_requested) && !down_started) {
      down_started = true;
      const bool critical_running = std::any_of(sup.processes().begin(), sup.processes().end(), [](const launch::ProcessStatus& p) {
        return p.critical && (p.state == ProcessState::kReady || p.state == ProcessState::kStarting);
      });
      if (critical_running) publish_damp("group '" + group.name + "' going down on " + me);
      sup.down(now);
    }
    sup.step(now);
    for (const auto& e : sup.take_events()) {
      const std::string line = e.process.empty() ? e.text : e.process + ": " + e.text;
      std::cout << fmt::format("[{}] {}", now_text(), line) << std::endl;
      last_event = line;
      changed = true;
      using K = launch::SupervisorEvent::Kind;
      if ((e.kind == K::kCriticalDied || e.kind == K::kCriticalHung) && !down_started) publish_damp(e.text);
      if (e.kind == K::kGroupUp) notify("up\n" + render({make_status(sup, seq, last_event, now)}));
      if (e.kind == K::kGroupFailed) {
        failed = true;
        std::string text = "failed: " + e.text + "\n" + render({make_status(sup, seq, last_event, now)});
        for (const auto& p : sup.processes()) {
          if (p.state == ProcessState::kFailed) text += "\n--- last lines of " + sup.log_file(p.name) + "\n" + tail_file(sup.log_file(p.name), 15);
        }
        notify(text);
        down_requested = true;
      }
    }
    if (changed || now - last_status >= 0.5) {
      Status m = make_status(sup, ++seq, last_event, now);
      lcm.publish("SUPERVISOR_STATUS", &m);
      last_status = now;
      changed = false;
    }
    if (down_started && sup.all_ended()) break;
  }
  launcher.stop_all(std::chrono::milliseconds(500));
  Status m = make_status(sup, ++seq, down_source.empty() ? "stopped" : "stopped: down by " + down_source, monotonic_s());
  m.state = Status::STATE_STOPPED;
  for (int i = 0; i < 3; ++i) {
    lcm.publish("SUPERVISOR_STATUS", &m);
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

/// The latest status of each (host, group) heard within `wait_s`.
std::vector<Status> collect_status(lcm::LCM& lcm, double wait_s, const std::string& group_filter) {
  std::map<std::pair<std::string, std::string>, Status> latest;
  {
    Subscription<Status> sub(lcm, "SUPERVISOR_STATUS", [&](const Status& s) {
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
  return msg::unmet_inputs(commands);
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
  node::publish_signed(lcm, "SUPERVISOR_COMMAND", c, key);
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
  Subscription<Status> sub(lcm, "SUPERVISOR_STATUS", [&](const Status& s) {
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
