#pragma once
/// \file Integration-test support: running the stack's command-line tools and collecting their
/// output, and two network namespaces joined by a veth pair standing for two hosts.

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

namespace hpr::test {

/// Quotes one argument for /bin/sh.
inline std::string quote(const std::string& s) {
  std::string out;
  out.reserve(s.size() + 2);
  out.push_back('\'');
  for (const char c : s) {
    if (c == '\'') {
      out.append("'\\''");
    } else {
      out.push_back(c);
    }
  }
  out.push_back('\'');
  return out;
}

struct CommandResult {
  int exit_code = -1;
  std::string out;  ///< stdout (stderr goes to the test's output)
};

/// Runs `argv` (through /bin/sh, each argument quoted), optionally prefixed (e.g. "ip netns exec X").
inline CommandResult run_command(const std::vector<std::string>& argv, const std::string& prefix = "") {
  std::string cmd = prefix;
  for (const auto& a : argv) {
    if (!cmd.empty()) cmd.push_back(' ');
    cmd.append(quote(a));
  }
  CommandResult r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = ::pclose(p);
  r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// Brings the supervised groups on `lcm_url` down when it goes out of scope, unless dismissed:
/// whatever assertion fails in a test, its group does not outlive it (a chain left running loads
/// the machine under every later test). `prefix` runs the command elsewhere (a host's namespace).
class GroupDown {
 public:
  GroupDown(std::string supervisor, std::string lcm_url, std::string prefix = "")
      : supervisor_(std::move(supervisor)), url_(std::move(lcm_url)), prefix_(std::move(prefix)) {}
  GroupDown(const GroupDown&) = delete;
  GroupDown& operator=(const GroupDown&) = delete;
  ~GroupDown() {
    if (armed_) (void)run_command({supervisor_, "down", "--lcm-url", url_}, prefix_);
  }
  /// The test brought the group down itself.
  void dismiss() { armed_ = false; }

 private:
  std::string supervisor_, url_, prefix_;
  bool armed_ = true;
};

/// The whole content of a text file ("" when it cannot be read).
inline std::string read_file(const std::string& path) {
  std::string out;
  if (FILE* f = std::fopen(path.c_str(), "r")) {
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = std::fread(buf.data(), 1, buf.size(), f)) > 0) out.append(buf.data(), n);
    std::fclose(f);
  }
  return out;
}

/// Two network namespaces ("hosts") joined by a veth pair, each with multicast routed on the
/// link, removed on destruction. Needs root and iproute2; `ok` false and `why` say otherwise.
class NetnsPair {
 public:
  NetnsPair() {
    const std::string id = std::to_string(::getpid() % 100000);
    a = "hpr" + id + "a";
    b = "hpr" + id + "b";
    const std::string va = "hv" + id + "a", vb = "hv" + id + "b";
    if (::geteuid() != 0) {
      why = "needs root (network namespaces)";
      return;
    }
    if (std::system("command -v ip > /dev/null 2>&1") != 0) {
      why = "needs iproute2 (ip)";
      return;
    }
    const std::string sub = "10." + std::to_string(200 + ::getpid() % 50) + "." + std::to_string(::getpid() % 250) + ".";
    const std::vector<std::string> steps = {
        "ip netns add " + a, "ip netns add " + b, "ip link add " + va + " type veth peer name " + vb,
        "ip link set " + va + " netns " + a, "ip link set " + vb + " netns " + b,
        "ip -n " + a + " addr add " + sub + "1/24 dev " + va, "ip -n " + b + " addr add " + sub + "2/24 dev " + vb,
        "ip -n " + a + " link set " + va + " up", "ip -n " + b + " link set " + vb + " up",
        "ip -n " + a + " link set lo up", "ip -n " + b + " link set lo up",
        "ip -n " + a + " route add 239.0.0.0/8 dev " + va, "ip -n " + b + " route add 239.0.0.0/8 dev " + vb};
    for (const auto& s : steps) {
      if (std::system((s + " 2>/dev/null").c_str()) != 0) {
        why = "cannot set up network namespaces here: '" + s + "' failed";
        return;
      }
    }
    ok = true;
  }
  ~NetnsPair() {
    leave();
    std::system(("ip netns del " + a + " 2>/dev/null; ip netns del " + b + " 2>/dev/null").c_str());
  }
  NetnsPair(const NetnsPair&) = delete;
  NetnsPair& operator=(const NetnsPair&) = delete;

  [[nodiscard]] std::string exec(const std::string& ns) const { return "ip netns exec " + ns; }
  /// Moves the calling thread into namespace `ns` (sockets opened afterwards live there).
  bool enter(const std::string& ns) {
    if (home_ < 0) home_ = ::open("/proc/self/ns/net", O_RDONLY | O_CLOEXEC);
    const int fd = ::open(("/var/run/netns/" + ns).c_str(), O_RDONLY | O_CLOEXEC);
    const bool done = fd >= 0 && ::setns(fd, CLONE_NEWNET) == 0;
    if (fd >= 0) ::close(fd);
    return done;
  }
  /// Back to the namespace the test started in.
  void leave() {
    if (home_ >= 0) {
      ::setns(home_, CLONE_NEWNET);
      ::close(home_);
      home_ = -1;
    }
  }

  bool ok = false;
  std::string why, a, b;

 private:
  int home_ = -1;
};

/// The control processes (estimator, planner and wbc critical) as lines of a groups file's `processes:`,
/// placed on `host`, each with `--config ${cfg}`.
inline std::string control_processes_yaml(const std::string& host) {
  const std::string on = "host: " + host + ", args: [--config, '${cfg}']";
  return "      estimator: {command: estimator, " + on + ", critical: true}\n" +
         "      planner: {command: planner, " + on + ", critical: true, depends_on: [estimator]}\n" +
         "      wbc: {command: wbc, " + on + ", critical: true, depends_on: [planner]}\n" +
         "      reference_gen: {command: reference_gen, " + on + "}\n" +
         "      motion_opt: {command: motion_opt, " + on + "}\n";
}

}  // namespace hpr::test
