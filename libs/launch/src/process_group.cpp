#include "hpr/launch/process_group.hpp"

#include "hpr/common/auth.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <spawn.h>
#include <netinet/in.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sched.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <thread>

namespace hpr::launch {

std::string unique_lcm_url() {
  // A port the kernel reports free for UDP, and a random group in 239.255.0.0/16.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = 0;
  int port = 0;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0) {
    socklen_t len = sizeof(addr);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    port = ntohs(addr.sin_port);
  }
  if (fd >= 0) ::close(fd);
  std::random_device rd;
  std::mt19937 gen(rd() ^ static_cast<unsigned>(::getpid()));
  if (port == 0) port = 20000 + static_cast<int>(gen() % 30000);
  const int a = 1 + static_cast<int>(gen() % 250), b = 1 + static_cast<int>(gen() % 250);
  return "udpm://239.255." + std::to_string(a) + "." + std::to_string(b) + ":" + std::to_string(port) + "?ttl=0";
}

std::string executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

int run_to_completion(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  if (argv.empty() || ::posix_spawnp(&pid, args[0], nullptr, nullptr, args.data(), environ) != 0) return 127;
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

ProcessGroup::ProcessGroup(std::string lcm_url, std::string bin_dir)
    : lcm_url_(std::move(lcm_url)), bin_dir_(std::move(bin_dir)), key_path_(auth::key_path()) {
  if (bin_dir_.empty()) bin_dir_ = executable_dir();
  // The deployment's key, created on first use: the processes started sign and check commands with it.
  (void)auth::load_or_create_key(key_path_);
}

ProcessGroup::~ProcessGroup() { stop_all(); }

pid_t ProcessGroup::start(const std::string& exe, const std::vector<std::string>& args,
                          const std::map<std::string, std::string>& env, const std::string& log_file) {
  StartOptions o;
  o.env = env;
  o.log_file = log_file;
  return start(exe, args, o);
}

namespace {

/// The command to exec: a bare name from `bin_dir` when it is there, else as given (execvp searches PATH).
std::string resolve_command(const std::string& exe, const std::string& bin_dir) {
  if (exe.find('/') != std::string::npos) return exe;
  const std::string local = bin_dir + "/" + exe;
  return ::access(local.c_str(), X_OK) == 0 ? local : exe;
}

/// In the child, after fork: a message on its stderr (async-signal-safe).
void child_note(const char* what) {
  const char prefix[] = "[launch] warn: ";
  (void)!::write(STDERR_FILENO, prefix, sizeof(prefix) - 1);
  (void)!::write(STDERR_FILENO, what, std::strlen(what));
  (void)!::write(STDERR_FILENO, "\n", 1);
}

}  // namespace

pid_t ProcessGroup::start(const std::string& exe, const std::vector<std::string>& args, const StartOptions& options) {
  const std::string path = resolve_command(exe, bin_dir_);
  std::vector<std::string> argv_s{path};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  // Everything the child needs is prepared before fork: the child only makes system calls.
  std::vector<char*> argv;
  for (auto& s : argv_s) argv.push_back(s.data());
  argv.push_back(nullptr);
  cpu_set_t cpus;
  CPU_ZERO(&cpus);
  for (const int c : options.cpus) CPU_SET(c, &cpus);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed: " + std::string(std::strerror(errno)));
  if (pid == 0) {
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    ::setenv("LCM_DEFAULT_URL", lcm_url_.c_str(), 1);
    ::setenv("HPR_LCM_KEY_FILE", key_path_.c_str(), 1);
    for (const auto& [k, v] : options.env) ::setenv(k.c_str(), v.c_str(), 1);
    if (!options.log_file.empty()) {
      const int fd = ::open(options.log_file.c_str(), O_WRONLY | O_CREAT | (options.append_log ? O_APPEND : O_TRUNC), 0644);
      if (fd >= 0) {
        ::dup2(fd, STDOUT_FILENO);
        ::dup2(fd, STDERR_FILENO);
        ::close(fd);
      }
    }
    if (!options.working_dir.empty() && ::chdir(options.working_dir.c_str()) != 0) {
      child_note("cannot enter the working directory");
      ::_exit(126);
    }
    if (!options.cpus.empty() && ::sched_setaffinity(0, sizeof(cpus), &cpus) != 0) {
      child_note("CPU affinity refused by the system; running on any CPU");
    }
    if (options.rt_priority > 0) {
      sched_param sp{};
      sp.sched_priority = options.rt_priority;
      if (::sched_setscheduler(0, SCHED_FIFO, &sp) != 0) child_note("real-time priority refused by the system (needs root or CAP_SYS_NICE); running with the normal scheduler");
    }
    ::execvp(path.c_str(), argv.data());
    child_note("exec failed: command not found or not executable");
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  pids_.push_back(pid);
  return pid;
}

void ProcessGroup::signal(pid_t pid, int sig) { ::kill(pid, sig); }

void ProcessGroup::signal_group(pid_t pid, int sig) { ::kill(-pid, sig); }

ProcessResult ProcessGroup::wait(pid_t pid, std::chrono::milliseconds timeout) {
  if (auto it = reaped_.find(pid); it != reaped_.end()) return it->second;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (true) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) {
      reap(pid, status);
      return reaped_[pid];
    }
    if (r < 0) return reaped_[pid];
    if (std::chrono::steady_clock::now() >= end) return ProcessResult{};
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

bool ProcessGroup::running(pid_t pid) {
  if (reaped_.count(pid) != 0) return false;
  int status = 0;
  const pid_t r = ::waitpid(pid, &status, WNOHANG);
  if (r == 0) return true;
  if (r == pid) reap(pid, status);
  return false;
}

void ProcessGroup::reap(pid_t pid, int status) {
  ProcessResult res;
  if (WIFEXITED(status)) {
    res.exited = true;
    res.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    res.signal = WTERMSIG(status);
  }
  reaped_[pid] = res;
}

void ProcessGroup::stop_all(std::chrono::milliseconds grace) {
  for (pid_t pid : pids_) {
    if (running(pid)) ::kill(-pid, SIGTERM);
  }
  const auto end = std::chrono::steady_clock::now() + grace;
  for (pid_t pid : pids_) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (wait(pid, std::max(left, std::chrono::milliseconds(0))).exited) continue;
    if (running(pid)) {
      ::kill(-pid, SIGKILL);
      wait(pid, std::chrono::milliseconds(2000));
    }
  }
  for (pid_t pid : pids_) ::kill(-pid, SIGKILL);  // anything left in the groups
  pids_.clear();
}

}  // namespace hpr::launch
