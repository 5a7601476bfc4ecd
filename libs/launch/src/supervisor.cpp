#include "hpr/launch/supervisor.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

namespace hpr::launch {

const char* to_string(ProcessState s) {
  switch (s) {
    case ProcessState::kWaiting: return "waiting";
    case ProcessState::kStarting: return "starting";
    case ProcessState::kReady: return "running";
    case ProcessState::kBackoff: return "backoff";
    case ProcessState::kStopping: return "stopping";
    case ProcessState::kStopped: return "stopped";
    case ProcessState::kExited: return "exited";
    case ProcessState::kFailed: return "failed";
  }
  return "?";
}

const char* to_string(GroupState s) {
  switch (s) {
    case GroupState::kStarting: return "starting";
    case GroupState::kUp: return "up";
    case GroupState::kDegraded: return "degraded";
    case GroupState::kStopping: return "stopping";
    case GroupState::kStopped: return "stopped";
    case GroupState::kFailed: return "failed";
  }
  return "?";
}

std::string describe(const ProcessResult& r) {
  if (r.exited) return "exited with status " + std::to_string(r.exit_code);
  if (r.signal != 0) return "killed by signal " + std::to_string(r.signal) + " (" + ::strsignal(r.signal) + ")";
  return "ended";
}

namespace {
bool running_state(ProcessState s) {
  return s == ProcessState::kStarting || s == ProcessState::kReady || s == ProcessState::kStopping;
}
}  // namespace

Supervisor::Supervisor(GroupSpec group, std::string host, std::string run_dir, ProcessGroup& launcher)
    : group_(std::move(group)), host_(std::move(host)), run_dir_(std::move(run_dir)), launcher_(launcher) {
  for (const auto& p : group_.processes) {
    if (!group_.runs_on(p, host_)) continue;
    ProcessStatus s;
    s.name = p.name;
    s.critical = p.critical;
    status_.push_back(s);
    Slot slot;
    slot.spec = &p;
    slots_.push_back(slot);
  }
}

void Supervisor::emit(SupervisorEvent::Kind kind, const std::string& process, std::string text) {
  events_.push_back({kind, process, std::move(text)});
}

std::vector<SupervisorEvent> Supervisor::take_events() {
  std::vector<SupervisorEvent> out;
  out.swap(events_);
  return out;
}

void Supervisor::up(double now) {
  going_down_ = false;
  announced_up_ = false;
  state_ = GroupState::kStarting;
  for (auto& s : status_) {
    if (!running_state(s.state)) s.state = ProcessState::kWaiting;
  }
  if (status_.empty()) emit(SupervisorEvent::Kind::kWarning, "", "no process of group '" + group_.name + "' runs on host '" + host_ + "'");
  step(now);
}

void Supervisor::down(double now) {
  if (!going_down_) emit(SupervisorEvent::Kind::kInfo, "", "stopping group '" + group_.name + "'");
  going_down_ = true;
  step(now);
}

bool Supervisor::restart(const std::string& name, double now) {
  for (std::size_t i = 0; i < status_.size(); ++i) {
    if (status_[i].name != name) continue;
    if (going_down_) return false;
    if (running_state(status_[i].state)) {
      slots_[i].restart_after_stop = true;
      if (status_[i].state != ProcessState::kStopping) begin_stop(i, now);
    } else {
      ++status_[i].restarts;
      start(i, now);
    }
    emit(SupervisorEvent::Kind::kInfo, name, "restart requested");
    return true;
  }
  return false;
}

bool Supervisor::dependency_ready(const std::string& name) const {
  for (const auto& s : status_) {
    if (s.name == name) return s.state == ProcessState::kReady;
  }
  return std::find(remote_ready_.begin(), remote_ready_.end(), name) != remote_ready_.end();
}

bool Supervisor::started(const std::string& health_node, pid_t pid) const {
  for (std::size_t i = 0; i < status_.size(); ++i) {
    if (slots_[i].spec->health_node == health_node && pid != 0 && status_[i].pid == pid) return true;
  }
  return false;
}

void Supervisor::on_remote_ready(const std::string& name, bool ready) {
  const auto it = std::find(remote_ready_.begin(), remote_ready_.end(), name);
  if (ready && it == remote_ready_.end()) remote_ready_.push_back(name);
  if (!ready && it != remote_ready_.end()) remote_ready_.erase(it);
}

void Supervisor::on_health(const std::string& node, int state, int lifecycle, double rate_hz, std::int64_t deadline_misses,
                           const std::vector<std::string>& faults, double now) {
  for (std::size_t i = 0; i < status_.size(); ++i) {
    if (slots_[i].spec->health_node != node) continue;
    status_[i].health_state = state;
    status_[i].lifecycle = lifecycle;
    status_[i].rate_hz = rate_hz;
    status_[i].deadline_misses = deadline_misses;
    status_[i].faults.clear();
    for (const auto& f : faults) status_[i].faults += (status_[i].faults.empty() ? "" : "; ") + f;
    if (status_[i].hung) {
      status_[i].hung = false;
      emit(SupervisorEvent::Kind::kWarning, status_[i].name,
           fmt::format("answering again after {:.3f} s without HEALTH (a damp it caused stays until an enable)", now - slots_[i].health_seen_at));
    }
    slots_[i].health_seen_at = now;
  }
}

void Supervisor::start(std::size_t i, double now) {
  const ProcessSpec& p = *slots_[i].spec;
  ProcessStatus& s = status_[i];
  StartOptions o;
  o.env = p.env;
  o.log_file = log_file(p.name);
  o.append_log = true;
  o.cpus = p.cpus;
  o.rt_priority = p.rt_priority;
  // A watched node must report often enough to be judged within hung_after.
  if (p.hung_after_s > 0) o.env["HPR_HEALTH_RATE_HZ"] = fmt::format("{:.1f}", kHealthPerHungTime / p.hung_after_s);
  {
    // A header per start, so that a restart is visible in the process's log.
    std::ofstream log(o.log_file, std::ios::app);
    const std::time_t t = std::time(nullptr);
    char when[32];
    std::strftime(when, sizeof(when), "%F %T", std::localtime(&t));
    log << "=== " << when << " supervisor: start " << (s.restarts + 1) << " of '" << p.name << "': " << p.command;
    for (const auto& a : p.args) log << ' ' << a;
    log << " ===\n";
  }
  try {
    s.pid = launcher_.start(p.command, p.args, o);
  } catch (const std::exception& e) {
    s.pid = 0;
    s.state = ProcessState::kFailed;
    s.detail = e.what();
    emit(SupervisorEvent::Kind::kWarning, p.name, std::string("could not start: ") + e.what());
    return;
  }
  s.started_at = now;
  s.health_state = -1;
  s.lifecycle = -1;
  s.rate_hz = 0;
  s.faults.clear();
  s.hung = false;
  slots_[i].health_seen_at = -1;
  slots_[i].killed = false;
  slots_[i].restart_after_stop = false;
  slots_[i].failed_readiness = false;
  s.detail.clear();
  s.state = p.ready_on == ReadyOn::kStart ? ProcessState::kReady : ProcessState::kStarting;
  emit(SupervisorEvent::Kind::kInfo, p.name, "started, pid " + std::to_string(s.pid));
}

void Supervisor::begin_stop(std::size_t i, double now) {
  const ProcessSpec& p = *slots_[i].spec;
  status_[i].state = ProcessState::kStopping;
  slots_[i].stop_deadline = now + p.stop_timeout_s;
  slots_[i].killed = false;
  launcher_.signal(status_[i].pid, p.stop_signal);
}

void Supervisor::handle_end(std::size_t i, const ProcessResult& r, double now) {
  ProcessStatus& s = status_[i];
  Slot& slot = slots_[i];
  const ProcessSpec& p = *slot.spec;
  // Whatever the process started goes with it.
  launcher_.signal_group(s.pid, SIGKILL);
  s.pid = 0;
  s.health_state = -1;
  s.lifecycle = -1;
  s.rate_hz = 0;
  s.faults.clear();
  s.hung = false;
  if (s.state == ProcessState::kStopping) {
    if (slot.failed_readiness) {
      s.state = ProcessState::kFailed;
    } else if (slot.restart_after_stop && !going_down_) {
      ++s.restarts;
      start(i, now);
    } else {
      s.state = ProcessState::kStopped;
      s.detail = describe(r) + (slot.killed ? " (SIGKILL after the grace period)" : "");
    }
    return;
  }
  s.detail = describe(r);
  if (p.critical) emit(SupervisorEvent::Kind::kCriticalDied, p.name, p.name + " (critical) " + s.detail);
  const bool failure = !(r.exited && r.exit_code == 0);
  const bool again = !going_down_ && (p.restart == RestartPolicy::kAlways || (p.restart == RestartPolicy::kOnFailure && failure));
  if (again && s.restarts < p.max_restarts) {
    const double delay = std::min(p.backoff_max_s, p.backoff_s * std::pow(2.0, s.restarts));
    slot.restart_at = now + delay;
    s.state = ProcessState::kBackoff;
    emit(SupervisorEvent::Kind::kWarning, p.name,
         s.detail + "; restart " + std::to_string(s.restarts + 1) + " in " + std::to_string(delay).substr(0, 5) + " s");
    return;
  }
  s.state = failure ? ProcessState::kFailed : ProcessState::kExited;
  if (again) s.detail += "; no restart left (" + std::to_string(p.max_restarts) + " used)";
  emit(SupervisorEvent::Kind::kWarning, p.name, s.detail);
}

void Supervisor::step(double now) {
  // Reap.
  for (std::size_t i = 0; i < status_.size(); ++i) {
    if (!running_state(status_[i].state) || status_[i].pid <= 0) continue;
    if (launcher_.running(status_[i].pid)) continue;
    handle_end(i, launcher_.wait(status_[i].pid, std::chrono::milliseconds(0)), now);
  }
  // Watched processes whose HEALTH stopped: hung (stopped, stuck in a step, or starved). Judged only
  // when this supervisor itself ran a moment ago: after it was not scheduled for a while, the HEALTH
  // sent meanwhile is still queued, and a silence it measures now would be its own. And judged only
  // once the whole group is up, the silence counted from then at the earliest: while the others
  // start (the simulator settling, the optimiser setting up, at real-time priorities, on two cores
  // most of them) a ready process may wait for a CPU longer than hung_after.
  const bool awake = last_step_ >= 0 && now - last_step_ <= kMaxJudgingGap;
  last_step_ = now;
  for (std::size_t i = 0; i < status_.size() && awake && announced_up_; ++i) {
    ProcessStatus& s = status_[i];
    const Slot& slot = slots_[i];
    const double after = slot.spec->hung_after_s;
    if (after <= 0 || s.hung || s.state != ProcessState::kReady || s.pid <= 0 || slot.health_seen_at < s.started_at) continue;
    const double silent_since = std::max(slot.health_seen_at, up_at_);
    if (now - silent_since <= after) continue;
    s.hung = true;
    const std::string text = fmt::format("{}hung: no HEALTH for {:.0f} ms (hung_after {:.0f} ms)", s.critical ? "(critical) " : "",
                                         (now - silent_since) * 1e3, after * 1e3);
    emit(s.critical ? SupervisorEvent::Kind::kCriticalHung : SupervisorEvent::Kind::kWarning, s.name,
         s.critical ? s.name + " " + text : text);
  }
  // Stops that outlast their grace period.
  for (std::size_t i = 0; i < status_.size(); ++i) {
    if (status_[i].state == ProcessState::kStopping && !slots_[i].killed && now >= slots_[i].stop_deadline) {
      launcher_.signal_group(status_[i].pid, SIGKILL);
      slots_[i].killed = true;
      emit(SupervisorEvent::Kind::kWarning, status_[i].name, "did not stop within " + std::to_string(slots_[i].spec->stop_timeout_s).substr(0, 4) + " s: SIGKILL");
    }
  }
  if (going_down_) {
    // Last started first: a process is signalled once everything started after it has ended.
    for (std::size_t k = status_.size(); k-- > 0;) {
      ProcessStatus& s = status_[k];
      if (s.state == ProcessState::kWaiting || s.state == ProcessState::kBackoff) s.state = ProcessState::kStopped;
      if (s.state == ProcessState::kStopping) break;
      if (s.state == ProcessState::kStarting || s.state == ProcessState::kReady) {
        begin_stop(k, now);
        break;
      }
    }
  } else if (state_ != GroupState::kFailed) {
    for (std::size_t i = 0; i < status_.size(); ++i) {
      ProcessStatus& s = status_[i];
      const ProcessSpec& p = *slots_[i].spec;
      switch (s.state) {
        case ProcessState::kWaiting:
          if (std::all_of(p.depends_on.begin(), p.depends_on.end(), [&](const std::string& d) { return dependency_ready(d); })) start(i, now);
          break;
        case ProcessState::kStarting:
          if (slots_[i].health_seen_at >= s.started_at) {
            s.state = ProcessState::kReady;
            char buf[64];
            std::snprintf(buf, sizeof(buf), "ready after %.2f s", now - s.started_at);
            emit(SupervisorEvent::Kind::kInfo, p.name, buf);
          } else if (now - s.started_at > p.ready_timeout_s) {
            char buf[160];
            std::snprintf(buf, sizeof(buf), "not ready within %.1f s (no HEALTH from node '%s')", p.ready_timeout_s, p.health_node.c_str());
            s.detail = buf;
            emit(SupervisorEvent::Kind::kWarning, p.name, s.detail);
            slots_[i].failed_readiness = true;
            begin_stop(i, now);
          }
          break;
        case ProcessState::kBackoff:
          if (now >= slots_[i].restart_at) {
            ++s.restarts;
            start(i, now);
          }
          break;
        default:
          break;
      }
    }
  }
  update_group_state(now);
}

bool Supervisor::all_ended() const {
  return std::none_of(status_.begin(), status_.end(), [](const ProcessStatus& s) { return running_state(s.state); });
}

void Supervisor::update_group_state(double now) {
  const auto any = [&](auto pred) { return std::any_of(status_.begin(), status_.end(), pred); };
  if (going_down_) {
    state_ = all_ended() ? GroupState::kStopped : GroupState::kStopping;
  } else if (state_ == GroupState::kFailed) {
    // stays failed until down()
  } else if (!announced_up_ && any([](const ProcessStatus& s) { return s.state == ProcessState::kFailed; })) {
    state_ = GroupState::kFailed;
    std::string why;
    for (const auto& s : status_) {
      if (s.state == ProcessState::kFailed) why += (why.empty() ? "" : "; ") + s.name + ": " + s.detail;
    }
    emit(SupervisorEvent::Kind::kGroupFailed, "", "group '" + group_.name + "' failed to come up: " + why);
  } else if (std::all_of(status_.begin(), status_.end(), [](const ProcessStatus& s) { return s.state == ProcessState::kReady; })) {
    const bool unhealthy = any([](const ProcessStatus& s) { return s.hung || (s.health_state >= 2 && s.health_state <= 3); });
    state_ = unhealthy && announced_up_ ? GroupState::kDegraded : GroupState::kUp;
    if (!announced_up_) {
      announced_up_ = true;
      up_at_ = now;
      emit(SupervisorEvent::Kind::kGroupUp, "", "group '" + group_.name + "' up on host '" + host_ + "'");
    }
  } else if (announced_up_) {
    state_ = GroupState::kDegraded;
  } else {
    state_ = GroupState::kStarting;
  }
}

}  // namespace hpr::launch
