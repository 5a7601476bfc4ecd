// The supervisor's core against real processes (sh, sleep): start order and readiness, restart
// policies with back-off, critical deaths, readiness deadlines, stop order with SIGKILL after the
// grace period, and nothing left behind.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <functional>
#include <thread>

#include "hpr/common/time.hpp"
#include "hpr/launch/supervisor.hpp"
#include "scratch_dir.hpp"

namespace {

using namespace hpr::launch;
using Kind = SupervisorEvent::Kind;

ProcessSpec proc(const std::string& name, const std::string& script) {
  ProcessSpec p;
  p.name = name;
  p.command = "/bin/sh";
  p.args = {"-c", script};
  p.health_node = name;
  return p;
}

struct Fixture {
  explicit Fixture(std::vector<ProcessSpec> ps, std::string host = "h1") {
    GroupSpec g;
    g.name = "test";
    g.processes = std::move(ps);
    static const hpr::test::ScratchDir scratch("supervisor");
    dir = scratch.path() / std::to_string(counter++);
    std::filesystem::create_directories(dir);
    sup = std::make_unique<Supervisor>(g, host, dir, launcher);
  }
  const ProcessStatus& st(const std::string& name) const {
    for (const auto& p : sup->processes()) {
      if (p.name == name) return p;
    }
    throw std::runtime_error("no process " + name);
  }
  /// Steps until `done` or `timeout_s`; collects the events.
  bool run_until(const std::function<bool()>& done, double timeout_s) {
    const double end = hpr::monotonic_s() + timeout_s;
    while (hpr::monotonic_s() < end) {
      sup->step(hpr::monotonic_s());
      for (auto& e : sup->take_events()) events.push_back(e);
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }
  [[nodiscard]] int count(Kind k) const {
    return static_cast<int>(std::count_if(events.begin(), events.end(), [&](const SupervisorEvent& e) { return e.kind == k; }));
  }
  static inline int counter = 0;
  std::string dir;
  ProcessGroup launcher{"udpm://239.255.1.1:7999?ttl=0", "/nonexistent"};
  std::unique_ptr<Supervisor> sup;
  std::vector<SupervisorEvent> events;
};

bool alive(pid_t pid) { return pid > 0 && ::kill(pid, 0) == 0; }

/// True while a process of process group `pgid` runs (zombies waiting for init do not count).
bool group_alive(pid_t pgid) {
  for (int i = 0; i < 200; ++i) {  // SIGKILL is delivered asynchronously: up to 1 s
    bool any = false;
    for (const auto& e : std::filesystem::directory_iterator("/proc")) {
      std::ifstream in(e.path() / "stat");
      std::string line;
      if (!std::getline(in, line)) continue;
      const auto close = line.rfind(')');
      if (close == std::string::npos) continue;
      std::istringstream rest(line.substr(close + 2));
      char state = 0;
      long ppid = 0, pgrp = 0;
      rest >> state >> ppid >> pgrp;
      if (pgrp == pgid && state != 'Z' && state != 'X') any = true;
    }
    if (!any) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

TEST(Supervisor, StartsInDependencyOrderOnceEachIsReady) {
  ProcessSpec a = proc("a", "exec sleep 30"), b = proc("b", "exec sleep 30");
  b.depends_on = {"a"};
  Fixture f({a, b});
  f.sup->up(hpr::monotonic_s());
  EXPECT_EQ(f.st("a").state, ProcessState::kStarting);
  EXPECT_EQ(f.st("b").state, ProcessState::kWaiting) << "b must wait for a's HEALTH";
  EXPECT_TRUE(alive(f.st("a").pid));
  // HEALTH is taken from the process started under the node's name only (its pid).
  EXPECT_TRUE(f.sup->started("a", f.st("a").pid));
  EXPECT_FALSE(f.sup->started("a", f.st("a").pid + 1));
  EXPECT_FALSE(f.sup->started("b", f.st("a").pid)) << "b is not running";
  EXPECT_FALSE(f.sup->started("a", 0));
  f.run_until([] { return false; }, 0.1);
  EXPECT_EQ(f.st("b").state, ProcessState::kWaiting);
  f.sup->on_health("a", 1, 2, 1000.0, 3, {}, hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.st("b").state == ProcessState::kStarting; }, 2.0));
  EXPECT_EQ(f.st("a").state, ProcessState::kReady);
  EXPECT_DOUBLE_EQ(f.st("a").rate_hz, 1000.0);
  EXPECT_EQ(f.st("a").deadline_misses, 3);
  EXPECT_EQ(f.st("a").lifecycle, 2);  // as HEALTH said (running)
  EXPECT_EQ(f.sup->state(), GroupState::kStarting);
  f.sup->on_health("b", 1, 2, 500.0, 0, {}, hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kUp; }, 2.0));
  EXPECT_EQ(f.count(Kind::kGroupUp), 1);
  // A node reporting faults makes the group degraded and says why; its recovery makes it up again.
  f.sup->on_health("b", 2, 2, 500.0, 0, {"sensors: ROBOT_SENSORS stale", "qp: fallback"}, hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kDegraded; }, 2.0));
  EXPECT_EQ(f.st("b").faults, "sensors: ROBOT_SENSORS stale; qp: fallback");
  f.sup->on_health("b", 1, 2, 500.0, 0, {}, hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kUp; }, 2.0));
  EXPECT_EQ(f.st("b").faults, "");
  // Each start is recorded in the process's own log file.
  EXPECT_TRUE(std::filesystem::exists(f.sup->log_file("a")));
}

TEST(Supervisor, RestartsOnFailureWithGrowingBackoffThenGivesUp) {
  ProcessSpec p = proc("flaky", "exit 3");
  p.ready_on = ReadyOn::kStart;
  p.restart = RestartPolicy::kOnFailure;
  p.backoff_s = 0.05;
  p.backoff_max_s = 1.0;
  p.max_restarts = 3;
  Fixture f({p});
  std::vector<double> starts;
  f.sup->up(hpr::monotonic_s());
  int seen_starts = 0;
  ASSERT_TRUE(f.run_until([&] {
    const int n = static_cast<int>(std::count_if(f.events.begin(), f.events.end(), [](const SupervisorEvent& e) { return e.text.rfind("started", 0) == 0; }));
    for (; seen_starts < n; ++seen_starts) starts.push_back(hpr::monotonic_s());
    return f.st("flaky").state == ProcessState::kFailed;
  }, 10.0));
  EXPECT_EQ(f.st("flaky").restarts, 3);
  EXPECT_NE(f.st("flaky").detail.find("exited with status 3"), std::string::npos) << f.st("flaky").detail;
  EXPECT_NE(f.st("flaky").detail.find("no restart left"), std::string::npos) << f.st("flaky").detail;
  // Delays of at least 0.05, 0.1, 0.2 s between the starts (back-off doubles).
  ASSERT_GE(starts.size(), 4U);
  for (std::size_t k = 1; k < 4; ++k) EXPECT_GE(starts[k] - starts[k - 1], 0.05 * std::pow(2.0, static_cast<double>(k - 1)) - 1e-3) << "restart " << k;
}

TEST(Supervisor, CleanExitIsNotRestartedOnFailurePolicyButIsOnAlways) {
  ProcessSpec once = proc("once", "exit 0"), always = proc("always", "exit 0");
  once.ready_on = always.ready_on = ReadyOn::kStart;
  once.restart = RestartPolicy::kOnFailure;
  always.restart = RestartPolicy::kAlways;
  always.backoff_s = 0.01;
  always.max_restarts = 2;
  Fixture f({once, always});
  f.sup->up(hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.st("once").state == ProcessState::kExited && f.st("always").state == ProcessState::kExited; }, 10.0));
  EXPECT_EQ(f.st("once").restarts, 0);
  EXPECT_EQ(f.st("always").restarts, 2);
}

TEST(Supervisor, CriticalDeathIsReportedAtOnce) {
  ProcessSpec c = proc("controller", "exec sleep 30"), n = proc("monitor", "exec sleep 30");
  c.critical = true;
  c.ready_on = n.ready_on = ReadyOn::kStart;
  Fixture f({c, n});
  f.sup->up(hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kUp; }, 2.0));
  ::kill(f.st("monitor").pid, SIGKILL);
  ASSERT_TRUE(f.run_until([&] { return f.st("monitor").state == ProcessState::kFailed; }, 2.0));
  EXPECT_EQ(f.count(Kind::kCriticalDied), 0) << "a non-critical death is not a critical one";
  ::kill(f.st("controller").pid, SIGKILL);
  ASSERT_TRUE(f.run_until([&] { return f.count(Kind::kCriticalDied) == 1; }, 2.0));
  const auto it = std::find_if(f.events.begin(), f.events.end(), [](const SupervisorEvent& e) { return e.kind == Kind::kCriticalDied; });
  EXPECT_EQ(it->process, "controller");
  EXPECT_NE(it->text.find("signal 9"), std::string::npos) << it->text;
  EXPECT_EQ(f.sup->state(), GroupState::kDegraded);
}

/// The supervisor's clock in the caller's hands: `up` at t0, then steps every 10 ms (its loop) and
/// HEALTH arrivals at chosen times after t0.
struct SteppedClock {
  explicit SteppedClock(Supervisor& s) : sup(s), t0(hpr::monotonic_s()), t(t0) { sup.up(t0); }
  /// Steps every 10 ms up to t0 + `until`.
  void advance(double until) {
    while (t + 0.01 < t0 + until) {
      t += 0.01;
      sup.step(t);
    }
    t = t0 + until;
    sup.step(t);
  }
  void health(const std::string& node, double at) { sup.on_health(node, 1, 2, 1000.0, 0, {}, t0 + at); }
  Supervisor& sup;
  double t0, t;
};

TEST(Supervisor, HangsAreJudgedOnceTheGroupIsUpTheSilenceCountedFromThen) {
  // A watched controller ready early, then silent while another process of the group starts (on a
  // machine whose cores the others' start-up holds): no hang before the group is up, and its
  // silence counts from the moment it is. (hung_after 55 ms: the 10 ms steps from an arbitrary t0
  // never land on its boundary, where rounding would decide.)
  ProcessSpec c = proc("controller", "exec sleep 30"), s = proc("simulator", "exec sleep 30");
  c.critical = true;
  c.hung_after_s = 0.055;
  Fixture f({c, s});
  SteppedClock clock(*f.sup);
  clock.health("controller", 0.01);
  clock.advance(0.3);  // 290 ms of silence while the simulator is not ready
  EXPECT_FALSE(f.st("controller").hung) << "judged before the group was up";
  EXPECT_NE(f.sup->state(), GroupState::kUp);
  clock.health("simulator", 0.3);
  clock.advance(0.31);
  ASSERT_EQ(f.sup->state(), GroupState::kUp);
  clock.advance(0.36);  // 50 ms after the group came up
  EXPECT_FALSE(f.st("controller").hung);
  clock.advance(0.37);  // 60 ms
  EXPECT_TRUE(f.st("controller").hung);
  const auto events = f.sup->take_events();
  const auto hung = std::find_if(events.begin(), events.end(), [](const SupervisorEvent& e) { return e.kind == Kind::kCriticalHung; });
  ASSERT_NE(hung, events.end());
  EXPECT_NE(hung->text.find("no HEALTH for 60 ms"), std::string::npos) << hung->text;
}

TEST(Supervisor, AWatchedProcessWhoseHealthStopsIsHungAndACriticalOneIsReported) {
  // The supervisor's clock is the caller's: HEALTH arrivals and steps at chosen times.
  const hpr::test::ScratchDir scratch("supervisor-rate");
  const std::string rate_file = (scratch.path() / "rate").string();
  ProcessSpec c = proc("controller", "echo $HPR_HEALTH_RATE_HZ > " + rate_file + "; exec sleep 30"),
              m = proc("monitor", "exec sleep 30"), u = proc("unwatched", "exec sleep 30");
  c.critical = true;
  c.hung_after_s = 0.05;
  m.hung_after_s = 0.5;
  Fixture f({c, m, u});
  SteppedClock clock(*f.sup);
  for (const char* n : {"controller", "monitor", "unwatched"}) clock.health(n, 0.01);
  clock.advance(0.02);
  ASSERT_EQ(f.sup->state(), GroupState::kUp);
  clock.health("controller", 0.03);
  clock.advance(0.079);  // 49 ms of silence: not yet
  EXPECT_FALSE(f.st("controller").hung);
  clock.advance(0.081);  // 51 ms
  EXPECT_TRUE(f.st("controller").hung);
  EXPECT_FALSE(f.st("monitor").hung);
  auto events = f.sup->take_events();
  const auto hung = std::find_if(events.begin(), events.end(), [](const SupervisorEvent& e) { return e.kind == Kind::kCriticalHung; });
  ASSERT_NE(hung, events.end());
  EXPECT_EQ(hung->process, "controller");
  EXPECT_NE(hung->text.find("no HEALTH for 51 ms"), std::string::npos) << hung->text;
  EXPECT_EQ(f.sup->state(), GroupState::kDegraded);
  // Reported once, not every step.
  clock.advance(0.2);
  events = f.sup->take_events();
  EXPECT_EQ(std::count_if(events.begin(), events.end(), [](const SupervisorEvent& e) { return e.kind == Kind::kCriticalHung; }), 0);
  // A watched process that is not critical: a warning, no damp.
  clock.advance(0.52);
  EXPECT_TRUE(f.st("monitor").hung);
  events = f.sup->take_events();
  EXPECT_EQ(std::count_if(events.begin(), events.end(), [](const SupervisorEvent& e) { return e.kind == Kind::kCriticalHung; }), 0);
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const SupervisorEvent& e) {
    return e.kind == Kind::kWarning && e.process == "monitor" && e.text.find("hung") != std::string::npos;
  }));
  EXPECT_FALSE(f.st("unwatched").hung) << "hung_after 0 is not watched";
  // HEALTH again: no longer hung.
  clock.health("controller", 0.6);
  clock.health("monitor", 0.6);
  clock.advance(0.61);
  EXPECT_FALSE(f.st("controller").hung);
  EXPECT_FALSE(f.st("monitor").hung);
  EXPECT_EQ(f.sup->state(), GroupState::kUp);
  // The supervisor itself was not scheduled for 200 ms: the first step after that does not judge
  // (the HEALTH sent meanwhile is still queued), the next one, after reading it, finds none hung.
  clock.t += 0.2;
  f.sup->step(clock.t);
  EXPECT_FALSE(f.st("controller").hung) << "the supervisor's own gap was taken for the node's silence";
  clock.health("controller", clock.t - clock.t0);
  clock.advance(clock.t - clock.t0 + 0.01);
  EXPECT_FALSE(f.st("controller").hung);
  // The watched node was asked for HEALTH at 4 per hung_after: 80 Hz.
  std::string rate;
  for (int i = 0; i < 200 && rate.empty(); ++i) {
    std::ifstream in(rate_file);
    std::getline(in, rate);
    if (rate.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(rate, "80.0");
  f.sup->down(hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->all_ended(); }, 10.0));
}

TEST(Supervisor, NotReadyBeforeTheDeadlineFailsTheGroupAndStopsTheProcess) {
  ProcessSpec p = proc("silent", "exec sleep 30");
  p.ready_timeout_s = 0.2;
  Fixture f({p});
  f.sup->up(hpr::monotonic_s());
  const pid_t pid = f.st("silent").pid;
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kFailed && f.sup->all_ended(); }, 5.0));
  EXPECT_EQ(f.st("silent").state, ProcessState::kFailed);
  EXPECT_NE(f.st("silent").detail.find("no HEALTH from node 'silent'"), std::string::npos) << f.st("silent").detail;
  EXPECT_EQ(f.count(Kind::kGroupFailed), 1);
  EXPECT_FALSE(alive(pid));
}

TEST(Supervisor, DownStopsLastStartedFirstAndKillsWhatIgnoresTheSignal) {
  // A shell that ignores SIGTERM and waits on a child of its process group (the child inherits
  // the ignored signal): only SIGKILL to the whole group ends both.
  ProcessSpec deaf = proc("deaf", "trap '' TERM; sleep 30 & wait");
  deaf.ready_on = ReadyOn::kStart;
  deaf.stop_timeout_s = 0.3;
  ProcessSpec polite = proc("polite", "exec sleep 30");
  polite.ready_on = ReadyOn::kStart;
  polite.depends_on = {"deaf"};
  polite.stop_signal = SIGINT;
  Fixture f({deaf, polite});
  f.sup->up(hpr::monotonic_s());
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kUp; }, 2.0));
  const pid_t p1 = f.st("deaf").pid, p2 = f.st("polite").pid;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the shell has set its trap
  f.sup->down(hpr::monotonic_s());
  EXPECT_EQ(f.st("polite").state, ProcessState::kStopping);
  EXPECT_EQ(f.st("deaf").state, ProcessState::kReady) << "signalled only after what started after it has ended";
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kStopped; }, 5.0));
  EXPECT_EQ(f.st("polite").state, ProcessState::kStopped);
  EXPECT_NE(f.st("polite").detail.find("signal 2"), std::string::npos) << "its own stop signal: " << f.st("polite").detail;
  EXPECT_NE(f.st("deaf").detail.find("SIGKILL after the grace period"), std::string::npos) << f.st("deaf").detail;
  // Nothing left: neither the processes nor what they started (their process groups).
  EXPECT_FALSE(alive(p1));
  EXPECT_FALSE(alive(p2));
  EXPECT_FALSE(group_alive(p1)) << "the shell's child survived";
  EXPECT_FALSE(group_alive(p2));
}

TEST(Supervisor, RestartCommandStartsANewProcess) {
  ProcessSpec p = proc("node", "exec sleep 30");
  p.ready_on = ReadyOn::kStart;
  Fixture f({p});
  f.sup->up(hpr::monotonic_s());
  const pid_t first = f.st("node").pid;
  ASSERT_TRUE(f.sup->restart("node", hpr::monotonic_s()));
  EXPECT_FALSE(f.sup->restart("other", hpr::monotonic_s()));
  ASSERT_TRUE(f.run_until([&] { return f.st("node").state == ProcessState::kReady && f.st("node").pid != first && f.st("node").pid > 0; }, 5.0));
  EXPECT_EQ(f.st("node").restarts, 1);
  EXPECT_FALSE(alive(first));
}

TEST(Supervisor, RunsOnlyItsHostsShareAndWaitsForRemoteDependencies) {
  ProcessSpec remote = proc("hal", "exec sleep 30"), local = proc("wbc", "exec sleep 30");
  remote.host = "robot";
  local.host = "pc";
  local.depends_on = {"hal"};
  local.ready_on = ReadyOn::kStart;
  Fixture f({remote, local}, "pc");
  ASSERT_EQ(f.sup->processes().size(), 1U);
  f.sup->up(hpr::monotonic_s());
  f.run_until([] { return false; }, 0.05);
  EXPECT_EQ(f.st("wbc").state, ProcessState::kWaiting);
  f.sup->on_remote_ready("hal", true);
  ASSERT_TRUE(f.run_until([&] { return f.sup->state() == GroupState::kUp; }, 2.0));
}

}  // namespace
