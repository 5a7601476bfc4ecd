#pragma once
/// \file
/// The supervisor's core, without LCM: runs this host's share of a process group in dependency
/// order, decides readiness (a HEALTH message from the node, fed in by the caller, or the start
/// itself), restarts per policy with exponential back-off, stops in reverse order with each
/// process's signal and grace period, marks a watched process hung when its HEALTH stops for
/// longer than its hung_after, and reports what happened as events. The caller owns the
/// clock (`now` in seconds, monotonic) and the I/O: tools/supervisor_main.cpp puts it on LCM.

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "hpr/launch/groups.hpp"
#include "hpr/launch/process_group.hpp"

namespace hpr::launch {

/// Values match supervisor_status_t.PROCESS_*.
enum class ProcessState : std::int8_t {
  kWaiting = 0,   ///< not started: waiting for what it depends on
  kStarting = 1,  ///< running, not ready yet
  kReady = 2,     ///< running and ready
  kBackoff = 3,   ///< ended; restarts after the back-off delay
  kStopping = 4,  ///< stop signal sent, waiting for it to end
  kStopped = 5,   ///< stopped on request
  kExited = 6,    ///< ended by itself with status 0, not restarted
  kFailed = 7,    ///< ended with a failure (or never became ready) and is not restarted
};
/// Values match supervisor_status_t.STATE_*.
enum class GroupState : std::int8_t { kStarting = 0, kUp = 1, kDegraded = 2, kStopping = 3, kStopped = 4, kFailed = 5 };

const char* to_string(ProcessState s);
const char* to_string(GroupState s);

struct ProcessStatus {
  std::string name;
  ProcessState state = ProcessState::kWaiting;
  pid_t pid = 0;
  double started_at = 0;  ///< [s] monotonic, last start
  int restarts = 0;
  bool critical = false;
  int health_state = -1;  ///< from HEALTH; -1 before the first
  int lifecycle = -1;     ///< from HEALTH (health_t.LIFECYCLE_*); -1 before the first
  double rate_hz = 0;
  std::int64_t deadline_misses = 0;
  std::string detail;  ///< last exit, readiness or start failure
  std::string faults;  ///< the node's current faults from its HEALTH, "; "-separated
  bool hung = false;   ///< running, but its HEALTH stopped for longer than hung_after
};

struct SupervisorEvent {
  enum class Kind { kInfo, kWarning, kCriticalDied, kCriticalHung, kGroupUp, kGroupFailed };
  Kind kind = Kind::kInfo;
  std::string process;  ///< empty for group events
  std::string text;
};

class Supervisor {
 public:
  /// Runs the processes of `group` that run on `host`; process logs go to `run_dir`/NAME.log.
  Supervisor(GroupSpec group, std::string host, std::string run_dir, ProcessGroup& launcher);
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  /// Starts the group: processes start as their dependencies become ready.
  void up(double now);
  /// Stops every process, last started first.
  void down(double now);
  /// Stops one process and starts it again (counted as a restart).
  bool restart(const std::string& name, double now);
  /// Advances: reaps ended processes, applies restart policies, starts what may start, checks
  /// readiness deadlines, marks hung processes, escalates stops to SIGKILL. Call every few
  /// milliseconds (at most 25 ms apart for hangs to be judged), after handling the HEALTH received.
  void step(double now);

  /// A HEALTH message from node `node` (state per health_t.STATE_*, `faults` its current fault texts).
  void on_health(const std::string& node, int state, int lifecycle, double rate_hz, std::int64_t deadline_misses,
                 const std::vector<std::string>& faults, double now);
  /// A process of this group that another host runs became ready (or stopped being ready).
  void on_remote_ready(const std::string& name, bool ready);
  /// Whether `pid` is the running process this supervisor started whose HEALTH names `health_node`.
  [[nodiscard]] bool started(const std::string& health_node, pid_t pid) const;

  std::vector<SupervisorEvent> take_events();
  [[nodiscard]] GroupState state() const { return state_; }
  [[nodiscard]] const GroupSpec& group() const { return group_; }
  [[nodiscard]] const std::string& host() const { return host_; }
  [[nodiscard]] const std::string& run_dir() const { return run_dir_; }
  /// This host's processes, in start order.
  [[nodiscard]] const std::vector<ProcessStatus>& processes() const { return status_; }
  [[nodiscard]] std::string log_file(const std::string& name) const { return run_dir_ + "/" + name + ".log"; }
  /// True when every process of this host has ended (after down(), or all exited).
  [[nodiscard]] bool all_ended() const;

 private:
  struct Slot {
    const ProcessSpec* spec = nullptr;
    bool restart_after_stop = false;
    bool failed_readiness = false;  ///< stopped because it was not ready in time: failed once it ends
    double restart_at = 0, stop_deadline = 0, health_seen_at = -1;
    bool killed = false;
  };
  [[nodiscard]] bool dependency_ready(const std::string& name) const;
  void start(std::size_t i, double now);
  void handle_end(std::size_t i, const ProcessResult& r, double now);
  void begin_stop(std::size_t i, double now);
  void update_group_state(double now);
  void emit(SupervisorEvent::Kind kind, const std::string& process, std::string text);

  GroupSpec group_;
  std::string host_, run_dir_;
  ProcessGroup& launcher_;
  std::vector<ProcessStatus> status_;
  std::vector<Slot> slots_;
  std::vector<std::string> remote_ready_;
  std::vector<SupervisorEvent> events_;
  GroupState state_ = GroupState::kStopped;
  bool going_down_ = false, announced_up_ = false;
  double up_at_ = 0.0;  ///< [s] monotonic, when the group was last announced up
  double last_step_ = -1;  ///< [s] the previous step's time
  /// [s] A step more than this after the previous one does not judge hangs (see step()).
  static constexpr double kMaxJudgingGap = 0.025;
};

/// "exited with status 3", "killed by signal 9 (Killed)".
std::string describe(const ProcessResult& r);

}  // namespace hpr::launch
