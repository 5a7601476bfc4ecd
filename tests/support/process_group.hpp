#pragma once
/// \file
/// Integration-test support: start processes of the stack, each test on its own LCM URL, and kill
/// everything that was started (the whole process group) when the test ends, even when it fails.
/// Children also receive SIGKILL if the test process itself dies (PR_SET_PDEATHSIG).

#include <sys/types.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

namespace hpr::test {

/// An LCM URL no other test uses at the same time: a free UDP port and a random multicast group.
std::string unique_lcm_url();

/// Directory of the built executables and of the source tree (set by CMake).
std::string bin_dir();
std::string source_dir();
/// A fresh, empty directory for this test's files.
std::string temp_dir(const std::string& tag);

struct ProcessResult {
  bool exited = false;   ///< false: still running or killed by a signal
  int exit_code = -1;
  int signal = 0;
};

class ProcessGroup {
 public:
  explicit ProcessGroup(std::string lcm_url = unique_lcm_url());
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  [[nodiscard]] const std::string& lcm_url() const { return lcm_url_; }

  /// Starts `exe` (a name in bin_dir() or a path) with `args`; LCM_DEFAULT_URL is set to lcm_url().
  /// stdout and stderr go to `log_file` when given. Returns the pid.
  pid_t start(const std::string& exe, const std::vector<std::string>& args,
              const std::map<std::string, std::string>& env = {}, const std::string& log_file = "");
  /// Sends `sig` to one process.
  void signal(pid_t pid, int sig);
  /// Waits up to `timeout` for the process to end.
  ProcessResult wait(pid_t pid, std::chrono::milliseconds timeout);
  [[nodiscard]] bool running(pid_t pid);
  /// SIGTERM to every process, SIGKILL after `grace`; reaps all.
  void stop_all(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));

 private:
  std::string lcm_url_;
  std::vector<pid_t> pids_;
  std::map<pid_t, ProcessResult> reaped_;
};

}  // namespace hpr::test
