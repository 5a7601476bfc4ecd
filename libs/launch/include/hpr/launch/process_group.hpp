#pragma once
/// \file
/// Starting and stopping the stack's processes from a tool or a test: each child in its own process
/// group (so that stopping it also stops whatever it started), LCM_DEFAULT_URL set for it, output to
/// a log file, and SIGKILL when the parent dies (PR_SET_PDEATHSIG), so nothing is left behind.

#include <sys/types.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

namespace hpr::launch {

/// An LCM URL no other run uses at the same time: a free UDP port and a random multicast group in
/// 239.255.0.0/16, with ttl 0 (never leaves the host).
std::string unique_lcm_url();

/// The directory of the running executable (where the stack's other executables are installed).
std::string executable_dir();

/// Runs a program in the foreground (this process's stdin, stdout and stderr) and waits for it:
/// `argv[0]` a path, or a name looked up on PATH. Returns its exit status, 128 + the signal that
/// ended it, or 127 when it could not be started.
int run_to_completion(const std::vector<std::string>& argv);

struct ProcessResult {
  bool exited = false;  ///< false: still running or killed by a signal
  int exit_code = -1;
  int signal = 0;
};

/// How to start one process (everything but the command line).
struct StartOptions {
  std::map<std::string, std::string> env;  ///< added to the environment (after LCM_DEFAULT_URL)
  std::string log_file;                    ///< stdout and stderr; empty: inherited
  bool append_log = false;                 ///< append rather than truncate (a restart keeps the earlier output)
  std::string working_dir;                 ///< empty: the caller's
  std::vector<int> cpus;                   ///< CPU affinity; empty: any CPU
  int rt_priority = 0;                     ///< SCHED_FIFO priority 1..99; 0: the normal scheduler
};

class ProcessGroup {
 public:
  /// `lcm_url` is given to every child as LCM_DEFAULT_URL; executables named without a '/' are
  /// looked up in `bin_dir` (default: executable_dir()). The deployment's key (auth::key_path()) is
  /// created when there is none (throws auth::AuthError when it cannot be, or is open to others)
  /// and named to every child as HPR_LCM_KEY_FILE.
  explicit ProcessGroup(std::string lcm_url = unique_lcm_url(), std::string bin_dir = "");
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  [[nodiscard]] const std::string& lcm_url() const { return lcm_url_; }
  [[nodiscard]] const std::string& bin_dir() const { return bin_dir_; }
  [[nodiscard]] const std::string& key_path() const { return key_path_; }

  /// Starts `exe` with `args`; stdout and stderr go to `log_file` when given (else inherited).
  /// Returns the pid. Throws std::runtime_error when fork fails.
  pid_t start(const std::string& exe, const std::vector<std::string>& args,
              const std::map<std::string, std::string>& env = {}, const std::string& log_file = "");
  /// Starts with the full set of options. A command without a '/' is looked up in `bin_dir`, then
  /// on PATH. CPU affinity and a real-time priority the system refuses (no permission) are reported
  /// on the child's log and the process runs without them.
  pid_t start(const std::string& exe, const std::vector<std::string>& args, const StartOptions& options);
  /// Sends `sig` to one process.
  void signal(pid_t pid, int sig);
  /// Waits up to `timeout` for the process to end.
  ProcessResult wait(pid_t pid, std::chrono::milliseconds timeout);
  [[nodiscard]] bool running(pid_t pid);
  /// Sends `sig` to the process group of `pid` (the process and whatever it started).
  void signal_group(pid_t pid, int sig);
  /// SIGTERM to every process group, SIGKILL after `grace`; reaps all.
  void stop_all(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));
  [[nodiscard]] const std::vector<pid_t>& pids() const { return pids_; }

 private:
  void reap(pid_t pid, int status);

  std::string lcm_url_, bin_dir_, key_path_;
  std::vector<pid_t> pids_;
  std::map<pid_t, ProcessResult> reaped_;
};

}  // namespace hpr::launch
