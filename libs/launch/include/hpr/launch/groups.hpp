#pragma once
/// \file
/// Process groups for the supervisor, loaded from YAML (config/groups.yaml) and validated on load:
/// an error names the file, line, key and value.
///
///     vars: {robot: toro}                       # ${robot}, overridable on the command line
///     defaults: {stop_timeout: 3.0}             # any process key, for every process
///     groups:
///       control:
///         processes:
///           estimator: {command: estimator, args: [--config, "${config_dir}/${robot}.yaml"], critical: true}
///       sim:
///         include: [control]                    # the processes of other groups, shared
///         processes:
///           sim_bullet: {command: sim_bullet, args: [...], rt_priority: 80}
///
/// Process keys: command, args, env, host, depends_on, ready (health | start), health_node,
/// ready_timeout [s], restart (never | on-failure | always), backoff [s], backoff_max [s],
/// max_restarts, stop_signal (SIGTERM, SIGINT, ...), stop_timeout [s], cpus, rt_priority (1..99),
/// critical. Predefined variables: config_dir (the directory of the file) and any environment
/// variable.

#include <csignal>
#include <map>
#include <string>
#include <vector>

namespace hpr::launch {

enum class RestartPolicy { kNever, kOnFailure, kAlways };
/// When a started process counts as ready (and what depends on it may start).
enum class ReadyOn { kStart, kHealth };

struct ProcessSpec {
  std::string name;
  std::string command;  ///< a bare name is looked up among the stack's executables, then on PATH
  std::vector<std::string> args;
  std::map<std::string, std::string> env;
  std::string host;  ///< empty: the group's default host
  std::vector<std::string> depends_on;
  ReadyOn ready_on = ReadyOn::kHealth;
  std::string health_node;  ///< the node name in its HEALTH messages (default: the process name)
  double ready_timeout_s = 20.0;
  RestartPolicy restart = RestartPolicy::kNever;
  double backoff_s = 0.5;       ///< first restart delay, doubled per restart
  double backoff_max_s = 10.0;  ///< upper bound of the delay
  int max_restarts = 5;         ///< then the process is failed
  int stop_signal = SIGTERM;
  double stop_timeout_s = 3.0;  ///< grace period before SIGKILL
  std::vector<int> cpus;        ///< CPU affinity; empty: any
  int rt_priority = 0;          ///< SCHED_FIFO priority; 0: normal scheduling
  bool critical = false;        ///< its death commands OPERATOR damp at once
  /// [s] A running process whose HEALTH stops for this long is hung (a critical one: OPERATOR damp,
  /// as for a death); 0: not watched. The supervisor asks the node for HEALTH at kHealthPerHungTime
  /// per hung_after (environment variable HPR_HEALTH_RATE_HZ).
  double hung_after_s = 0.0;
};

/// HEALTH messages per hung_after period that a watched node is asked for.
inline constexpr double kHealthPerHungTime = 4.0;

struct GroupSpec {
  std::string name;
  std::string description;
  std::string default_host;  ///< where processes without a host run; empty: on every supervisor that runs the group
  std::vector<ProcessSpec> processes;  ///< in start order: every process after what it depends on

  /// The host that runs `p` ("" when any supervisor runs it).
  [[nodiscard]] const std::string& host_of(const ProcessSpec& p) const { return p.host.empty() ? default_host : p.host; }
  /// True when a supervisor on `host` runs `p`.
  [[nodiscard]] bool runs_on(const ProcessSpec& p, const std::string& host) const {
    return host_of(p).empty() || host_of(p) == host;
  }
  [[nodiscard]] const ProcessSpec* find(const std::string& name) const;
  /// The named hosts of the group (empty when every process runs on one supervisor).
  [[nodiscard]] std::vector<std::string> hosts() const;
};

struct GroupsFile {
  std::string path;
  std::string lcm_url;  ///< empty: LCM_DEFAULT_URL
  std::vector<std::string> names;  ///< the groups in file order
  std::map<std::string, GroupSpec> groups;

  /// Loads and validates `path`; `vars` override the file's `vars`. Throws ConfigError.
  static GroupsFile load(const std::string& path, const std::map<std::string, std::string>& vars = {});
  /// The named group; throws std::invalid_argument listing the groups when there is none.
  [[nodiscard]] const GroupSpec& group(const std::string& name) const;
};

/// "SIGTERM" → SIGTERM (also without the SIG prefix); -1 when unknown.
int signal_number(const std::string& name);
const char* to_string(RestartPolicy p);

}  // namespace hpr::launch
