// The node runtime over real LCM between separate processes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <csignal>
#include <cstdio>
#include <map>
#include <set>
#include <fstream>
#include <sstream>
#include <thread>

#include "all_types.hpp"
#include "shell.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;

// Starts the echo node and waits until its HEALTH is seen.
pid_t start_echo(ProcessGroup& group, LcmListener& lcm, const std::string& log = "") {
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  const pid_t pid = group.start("lcm_echo_node", {"--name", "echo"}, {}, log);
  EXPECT_TRUE(lcm.wait_for([&] { return !health->empty(); }, 10s)) << "no HEALTH from lcm_echo_node";
  return pid;
}

TEST(Transport, EveryTypeRoundTripsBetweenProcesses) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  ASSERT_TRUE(lcm.good());
  start_echo(group, lcm);
  int checked = 0;
  hpr::test::Filler filler(42);
  hpr::test::for_each_type([&]<class Msg>(const std::string& channel) {
    if (channel == "HEALTH") return;  // the node publishes its own HEALTH on that channel
    Msg sent;
    filler.fill(sent);
    if constexpr (hpr::node::Command<Msg>) sent.utime = hpr::wall_us();  // a command is taken only while fresh
    auto echoed = lcm.collect<Msg>(channel + "_ECHO");
    const bool got = lcm.wait_for(
        [&] {
          if (echoed->empty()) lcm.publish(channel, sent);
          return !echoed->empty();
        },
        5s);
    ASSERT_TRUE(got) << channel << " was not echoed";
    // The echo publishes under its own identity and signs with the deployment's key: those fields are
    // its own, every other byte is what was sent.
    Msg expected = sent;
    const Msg& back = echoed->front();
    if constexpr (hpr::node::Sourced<Msg>) {
      EXPECT_NE(back.source, 0) << channel << ": not stamped";
      EXPECT_NE(back.source, sent.source) << channel << ": not stamped";
      expected.source = back.source;
    }
    if constexpr (hpr::auth::Signed<Msg>) {
      const auto bytes = hpr::test::encode(back);
      EXPECT_TRUE(hpr::auth::verify(bytes.data(), bytes.size(), channel + "_ECHO", lcm.key())) << channel << ": the echo's code does not verify";
      std::copy(std::begin(back.mac), std::end(back.mac), std::begin(expected.mac));
    }
    EXPECT_EQ(hpr::test::encode(back), hpr::test::encode(expected)) << channel << " changed in transit";
    ++checked;
  });
  // HEALTH round trip: a health_t with random content on another channel name.
  {
    humanoid::health_t sent;
    filler.fill(sent);
    auto echoed = lcm.collect<humanoid::health_t>("HEALTH_ECHO");
    ASSERT_TRUE(lcm.wait_for([&] {
      if (echoed->empty()) lcm.publish("HEALTH", sent);
      for (const auto& m : *echoed) {
        if (m.node == sent.node && m.pid == sent.pid) return true;
      }
      return false;
    }, 5s));
    ++checked;
  }
  EXPECT_EQ(checked, HPR_LCM_TYPE_COUNT) << "every .lcm type of lcmtypes/ is in for_each_type (tests/support/all_types.hpp)";
}

TEST(Transport, GarbageIsCountedInHealthAndTheNodeKeepsRunning) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  const pid_t pid = start_echo(group, lcm);
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  const std::string garbage = "this is not an LCM message at all";
  for (int i = 0; i < 3; ++i) {
    lcm.lcm().publish("ROBOT_SENSORS", garbage.data(), static_cast<unsigned>(garbage.size()));
  }
  // A message with the right fingerprint but truncated.
  humanoid::robot_sensors_t m;
  hpr::test::Filler(1).fill(m);
  auto bytes = hpr::test::encode(m);
  lcm.lcm().publish("ROBOT_SENSORS", bytes.data(), static_cast<unsigned>(bytes.size() / 2));
  ASSERT_TRUE(lcm.wait_for([&] { return !health->empty() && health->back().decode_errors >= 4; }, 5s))
      << "decode errors not reported in HEALTH";
  const auto& h = health->back();
  EXPECT_EQ(h.node, "echo");
  ASSERT_GE(h.num_faults, 1);
  EXPECT_NE(h.faults[0].find("ROBOT_SENSORS"), std::string::npos) << h.faults[0];
  EXPECT_EQ(h.state, int{humanoid::health_t::STATE_DEGRADED});
  EXPECT_TRUE(group.running(pid));
  // Quiet again: the fault clears after lcm's decode_fault_quiet_s (2 s); the count stays.
  EXPECT_TRUE(lcm.wait_for([&] { return health->back().num_faults == 0 && health->back().state == humanoid::health_t::STATE_OK; },
                           6s))
      << "the decode fault never cleared";
  EXPECT_GE(health->back().decode_errors, 4);
  // Still works.
  auto echoed = lcm.collect<humanoid::robot_sensors_t>("ROBOT_SENSORS_ECHO");
  EXPECT_TRUE(lcm.wait_for([&] {
    lcm.publish("ROBOT_SENSORS", m);
    return !echoed->empty();
  }, 5s));
}

TEST(Transport, SigtermExitsZeroWithinOneSecond) {
  for (int sig : {SIGTERM, SIGINT}) {
    ProcessGroup group;
    LcmListener lcm(group.lcm_url());
    const pid_t pid = start_echo(group, lcm);
    const auto t0 = std::chrono::steady_clock::now();
    group.signal(pid, sig);
    const auto r = group.wait(pid, 1000ms);
    const auto dt = std::chrono::steady_clock::now() - t0;
    EXPECT_TRUE(r.exited) << "signal " << sig << ": did not exit within 1 s";
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_LT(dt, 1s);
  }
}

TEST(Transport, MissingMulticastRouteGivesOneMessageWithTheFix) {
  // A network namespace of its own has a loopback without multicast and no route at all.
  if (std::system("unshare --net true 2>/dev/null") != 0) {
    GTEST_SKIP() << "cannot create a network namespace here (unshare --net needs CAP_SYS_ADMIN)";
  }
  const std::string log = hpr::test::temp_dir("noroute") + "/out.txt";
  const std::string cmd = "unshare --net env LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=0 " +
                          hpr::test::bin_dir() + "/lcm_echo_node > " + log + " 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 3);
  std::ifstream f(log);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string out = ss.str();
  EXPECT_NE(out.find("no multicast route"), std::string::npos) << out;
  EXPECT_NE(out.find("ip route add 239.0.0.0/8 dev lo"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << "expected exactly one line:\n" << out;
}

// A misspelt option stops a node before it joins any LCM group: `--lcm_url` for `--lcm-url` must not
// run it on the default URL, among another robot's traffic.
TEST(NodeCommandLine, AnUnknownOptionStopsTheNodeNamingTheNearestOne) {
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  for (const char* node : {"estimator", "wbc", "sim_bullet"}) {
    const auto r = hpr::test::run_command({hpr::test::bin_dir() + "/" + node, "--config", cfg, "--lcm_url",
                                           "udpm://239.255.76.99:7699?ttl=0"},
                                          "2>&1");
    EXPECT_EQ(r.exit_code, 2) << node << ": " << r.out;
    EXPECT_NE(r.out.find("unknown option --lcm_url (did you mean '--lcm-url'?)"), std::string::npos) << node << ": " << r.out;
    const auto eq = hpr::test::run_command({hpr::test::bin_dir() + "/" + node, "--config=" + cfg, "--lcm_url=udpm://x"}, "2>&1");
    EXPECT_NE(eq.out.find("unknown option --lcm_url=udpm://x (did you mean '--lcm-url'?)"), std::string::npos) << eq.out;
    const auto p = hpr::test::run_command({hpr::test::bin_dir() + "/" + node, "--config", cfg, "stray"}, "2>&1");
    EXPECT_EQ(p.exit_code, 2) << node << ": " << p.out;
    EXPECT_NE(p.out.find("unexpected argument 'stray'"), std::string::npos) << node << ": " << p.out;
  }
  // The tools too: push_trial (which takes --lcm-url for the processes of its trial) and the
  // operator command, whose verbs are suggested as well.
  for (const std::string tool : {"push_trial", "hpr_operator"}) {
    std::vector<std::string> cmd{hpr::test::bin_dir() + "/" + tool};
    if (tool == "hpr_operator") cmd.emplace_back("damp");
    cmd.insert(cmd.end(), {"--lcm_url", "udpm://239.255.76.99:7699?ttl=0"});
    const auto r = hpr::test::run_command(cmd, "2>&1");
    EXPECT_EQ(r.exit_code, 2) << tool << ": " << r.out;
    EXPECT_NE(r.out.find("unknown option --lcm_url (did you mean '--lcm-url'?)"), std::string::npos) << tool << ": " << r.out;
  }
  const auto verb = hpr::test::run_command({hpr::test::bin_dir() + "/hpr_operator", "enabel"}, "2>&1");
  EXPECT_EQ(verb.exit_code, 2) << verb.out;
  EXPECT_NE(verb.out.find("unknown command 'enabel' (did you mean 'enable'?)"), std::string::npos) << verb.out;
}

TEST(NodeConfiguration, AKeyTheNodeDoesNotReadStopsItNamingTheNearestOne) {
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  const std::string url = "udpm://239.255.76.98:7698?ttl=0";
  // A misspelt override of each node's own section: exit 2 before the node runs, naming the key meant.
  const std::vector<std::array<std::string, 3>> cases = {{"estimator", "estimator.sensor_timout=0.02", "sensor_timeout"},
                                                         {"wbc", "wbc.wholebody_timout=0.5", "wholebody_timeout"},
                                                         {"reference_gen", "reference_gen.balance_timout=0.5", "balance_timeout"},
                                                         {"motion_opt", "motion_opt.reference_timout=0.5", "reference_timeout"},
                                                         {"sim_bullet", "sim.lockstep_timout=1", "lockstep_timeout"}};
  for (const auto& [node, set, meant] : cases) {
    const auto r = hpr::test::run_command({"timeout", "20", hpr::test::bin_dir() + "/" + node, "--config", cfg, "--lcm-url", url, "--set", set},
                                          "2>&1");
    EXPECT_EQ(r.exit_code, 2) << node << ": " << r.out;
    EXPECT_NE(r.out.find("unknown key"), std::string::npos) << node << ": " << r.out;
    EXPECT_NE(r.out.find("did you mean '" + meant + "'"), std::string::npos) << node << ": " << r.out;
  }
  // The same typo in a file names the file and line.
  const std::string dir = hpr::test::temp_dir("config-typo");
  std::string text = hpr::test::read_file(cfg);
  const std::string key = "  wholebody_timeout:";
  ASSERT_NE(text.find(key), std::string::npos);
  const std::size_t line = static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(text.find(key)), '\n')) + 1;
  text.replace(text.find(key), key.size(), "  wholebody_timout:");
  for (std::size_t at = text.find("../models"); at != std::string::npos; at = text.find("../models")) {
    text.replace(at, 9, hpr::test::source_dir() + "/models");
  }
  std::ofstream(dir + "/typo.yaml") << text;
  const auto r = hpr::test::run_command({"timeout", "20", hpr::test::bin_dir() + "/wbc", "--config", dir + "/typo.yaml", "--lcm-url", url}, "2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("typo.yaml:" + std::to_string(line) + ": wbc.wholebody_timout: unknown key (did you mean 'wholebody_timeout'?)"),
            std::string::npos)
      << r.out;
}

TEST(NodeConfiguration, TheInProcessPipelineRefusesAKeyNoComponentReadsAsTheNodesDo) {
  // push_trial --in-process loads the same configuration once for every component: a misspelt
  // override stops it (exit 2) naming the key meant, for a component's own key and for the options
  // only the processes use (validated, not applied); the correctly spelt ones run.
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  const std::vector<std::pair<std::string, std::string>> cases = {{"reference_gen.y.lean_budget_positve=3", "lean_budget_positive"},
                                                                  {"wbc.wholebody_timout=0.5", "wholebody_timeout"},
                                                                  {"sim.lockstep_timout=1", "lockstep_timeout"},
                                                                  {"estimator.sensor_timout=0.02", "sensor_timeout"}};
  const std::vector<std::string> trial = {"timeout", "60", hpr::test::bin_dir() + "/push_trial", "--quiet", "--in-process", "--robot", cfg,
                                          "--impulse", "5"};
  for (const auto& [set, meant] : cases) {
    std::vector<std::string> args = trial;
    args.insert(args.end(), {"--set", set});
    const auto r = hpr::test::run_command(args, "2>&1");
    EXPECT_EQ(r.exit_code, 2) << set << ": " << r.out;
    EXPECT_NE(r.out.find("unknown key"), std::string::npos) << set << ": " << r.out;
    EXPECT_NE(r.out.find("did you mean '" + meant + "'"), std::string::npos) << set << ": " << r.out;
  }
  std::vector<std::string> args = trial;
  args.insert(args.end(), {"--set", "reference_gen.y.lean_budget_positive=3", "--set", "wbc.wholebody_timeout=0.5", "--set",
                           "sim.lockstep_timeout=1", "--set", "estimator.sensor_timeout=0.02"});
  const auto r = hpr::test::run_command(args, "2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.out;
}

/// Resident memory of `pid` [kB] (VmRSS), -1 when unreadable.
long rss_kb(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

TEST(Transport, ForgedArrayCountsOnEveryChannelLeaveEveryNodesMemoryUnchanged) {
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  hpr::test::ProcessGroup group;
  std::map<std::string, int> pids;
  // sim_bullet in lockstep waits for its first command: it only listens, as the control nodes do.
  pids["sim_bullet"] = group.start("sim_bullet", {"--config", cfg, "--set", "sim.mode=lockstep"});
  for (const char* n : {"estimator", "planner", "wbc", "reference_gen", "motion_opt"}) pids[n] = group.start(n, {"--config", cfg});
  hpr::test::LcmListener lcm(group.lcm_url());
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  auto seen_all = [&] {
    std::set<std::string> nodes;
    for (const auto& h : *health) nodes.insert(h.node);
    return nodes.size() >= pids.size();
  };
  ASSERT_TRUE(lcm.wait_for(seen_all, 20s));
  lcm.spin_for(1s);
  std::map<std::string, long> before;
  for (const auto& [n, pid] : pids) before[n] = rss_kb(pid);
  // Every type, on its channel: its default message with 20 000 000 written at each 4-byte offset
  // in turn (one of them is each array count or string length).
  int sent = 0;
  hpr::test::for_each_type([&]<class Msg>(const char* channel) {
    Msg m{};
    const int size = m.getEncodedSize();
    std::vector<std::uint8_t> good(static_cast<std::size_t>(size));
    ASSERT_EQ(m.encode(good.data(), 0, size), size);
    for (int at = 8; at + 4 <= size; ++at) {
      std::vector<std::uint8_t> bad = good;
      const std::uint32_t n = 20'000'000;
      for (int k = 0; k < 4; ++k) bad[static_cast<std::size_t>(at + k)] = static_cast<std::uint8_t>(n >> (24 - 8 * k));
      lcm.lcm().publish(channel, bad.data(), static_cast<unsigned>(bad.size()));
      ++sent;
      if (sent % 50 == 0) lcm.spin_for(5ms);  // do not overrun the receivers' socket buffers
    }
  });
  lcm.spin_for(2s);
  for (const auto& [n, pid] : pids) {
    const long after = rss_kb(pid);
    std::cout << n << ": resident " << before[n] << " kB before, " << after << " kB after " << sent << " forged messages\n";
    EXPECT_TRUE(group.running(pid)) << n << " died";
    EXPECT_LT(after - before[n], 4096) << n << " grew by " << (after - before[n]) << " kB";
  }
  group.stop_all();
}

TEST(LogTools, ExportAndCheckAgreeOnTheBadMessagesOfALogAndNameTheirOffsets) {
  const std::string dir = hpr::test::temp_dir("log-tools");
  const std::string file = dir + "/mixed.lcm";
  {
    lcm::LogFile log(file, "w");
    ASSERT_TRUE(log.good());
    auto put = [&](const std::string& channel, const std::vector<std::uint8_t>& bytes) {
      lcm::LogEvent ev{};
      ev.timestamp = 1000;
      ev.channel = channel;
      ev.datalen = static_cast<int32_t>(bytes.size());
      ev.data = const_cast<std::uint8_t*>(bytes.data());
      ASSERT_EQ(log.writeEvent(&ev), 0);
    };
    auto encoded = [](const auto& m) {
      std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
      m.encode(b.data(), 0, static_cast<int>(b.size()));
      return b;
    };
    humanoid::robot_state_t st{};
    humanoid::health_t h{};
    h.node = "wbc";
    h.host = "robot";
    put("ROBOT_STATE", encoded(st));                       // event 0
    // Event 1: a forged count (20 000 000 at the first offset where it makes the message malformed).
    std::vector<std::uint8_t> forged;
    for (std::size_t at = 8; forged.empty() && at + 4 <= encoded(st).size(); ++at) {
      std::vector<std::uint8_t> b = encoded(st);
      for (std::size_t k = 0; k < 4; ++k) b[at + k] = static_cast<std::uint8_t>(20'000'000U >> (24 - 8 * k));
      humanoid::robot_state_t out{};
      if (out.decode(b.data(), 0, static_cast<int>(b.size())) < 0) forged = b;
    }
    ASSERT_FALSE(forged.empty());
    put("ROBOT_STATE", forged);
    put("HEALTH", encoded(st));                            // event 2: another type's bytes
    put("SOMEONE_ELSES", {1, 2, 3});                       // event 3: not the stack's channel
    put("HEALTH", encoded(h));                             // event 4
  }
  const auto check = hpr::test::run_command({hpr::test::bin_dir() + "/lcm_recorder", "--check", file}, "2>&1");
  const auto exp = hpr::test::run_command({hpr::test::bin_dir() + "/lcm_export", file, dir + "/csv"}, "2>&1");
  EXPECT_EQ(check.exit_code, 4) << check.out;
  EXPECT_EQ(exp.exit_code, 1) << exp.out;
  // Both name events 1 and 2, with the same byte offsets, and nothing else.
  auto named = [](const std::string& out) {
    std::vector<std::string> v;
    for (std::size_t at = out.find("event "); at != std::string::npos; at = out.find("event ", at + 1)) {
      const std::size_t end = out.find(':', out.find(" on ", at));
      v.push_back(out.substr(at, end - at));
    }
    return v;
  };
  const auto a = named(check.out), b = named(exp.out);
  ASSERT_EQ(a.size(), 2U) << check.out;
  EXPECT_EQ(a, b) << check.out << "\n---\n" << exp.out;
  EXPECT_NE(a[0].find("event 1 at byte "), std::string::npos) << a[0];
  EXPECT_NE(a[1].find("event 2 at byte "), std::string::npos) << a[1];
  EXPECT_NE(check.out.find("does not decode as humanoid.health_t"), std::string::npos) << check.out;
  EXPECT_NE(exp.out.find("5 events read, 2 undecodable"), std::string::npos) << exp.out;
}

// lcm_export's CSV: the union of the layouts as columns, a cell left empty where a message lacks the
// column, the log time exact to the microsecond, values as "%.9g" (printf's own text, compared here).
TEST(LogTools, ExportWritesEveryLayoutTheExactLogTimeAndValuesAsPrintfWould) {
  const std::string dir = hpr::test::temp_dir("log-export");
  const std::string file = dir + "/two-layouts.lcm";
  const double v1 = 1.0 / 3.0, v2 = -2.5e-7, v3 = 123456789.123;
  {
    lcm::LogFile log(file, "w");
    ASSERT_TRUE(log.good());
    auto put = [&](int64_t timestamp, const humanoid::robot_state_t& m) {
      std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
      m.encode(b.data(), 0, static_cast<int>(b.size()));
      lcm::LogEvent ev{};
      ev.timestamp = timestamp;
      ev.channel = "ROBOT_STATE";
      ev.datalen = static_cast<int32_t>(b.size());
      ev.data = b.data();
      ASSERT_EQ(log.writeEvent(&ev), 0);
    };
    humanoid::robot_state_t a{};
    a.num_joints = 1;
    a.joint_name = {"knee"};
    a.q = {v1};
    a.qd = {0.0};
    a.tau = {0.0};
    humanoid::robot_state_t b = a;
    b.num_joints = 2;
    b.joint_name = {"hip", "knee"};
    b.q = {v2, v3};
    b.qd = {0.0, 0.0};
    b.tau = {0.0, 0.0};
    const int64_t t0 = 1'000'000'123;
    put(t0, a);
    put(t0 + 1'234'567'890, b);  // 1234.56789 s later, another layout
    put(t0 + 1'234'567'891, a);  // the first layout again
  }
  const auto exp = hpr::test::run_command({hpr::test::bin_dir() + "/lcm_export", file, dir + "/csv"}, "2>&1");
  ASSERT_EQ(exp.exit_code, 0) << exp.out;
  std::vector<std::vector<std::string>> rows;
  {
    std::istringstream in(hpr::test::read_file(dir + "/csv/ROBOT_STATE.csv"));
    for (std::string line; std::getline(in, line);) {
      rows.emplace_back();
      std::istringstream cells(line);
      for (std::string c; std::getline(cells, c, ',');) rows.back().push_back(c);
      if (!line.empty() && line.back() == ',') rows.back().emplace_back();
    }
  }
  ASSERT_EQ(rows.size(), 4U);
  const auto column = [&](const std::string& name) {
    const auto at = std::find(rows[0].begin(), rows[0].end(), name);
    EXPECT_NE(at, rows[0].end()) << name;
    return static_cast<std::size_t>(at - rows[0].begin());
  };
  const auto printf9 = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof(buf), "%.9g", v);
    return std::string(buf);
  };
  const std::size_t knee = column("q_knee"), hip = column("q_hip");
  EXPECT_EQ(rows[0][0], "log_time");
  for (std::size_t r = 1; r < rows.size(); ++r) ASSERT_EQ(rows[r].size(), rows[0].size()) << "row " << r;
  EXPECT_EQ(rows[1][0], "0");
  EXPECT_EQ(rows[2][0], "1234.56789");
  EXPECT_EQ(rows[3][0], "1234.567891");
  EXPECT_EQ(rows[1][knee], printf9(v1));
  EXPECT_EQ(rows[1][hip], "") << "the first layout has no hip";
  EXPECT_EQ(rows[2][hip], printf9(v2));
  EXPECT_EQ(rows[2][knee], printf9(v3));
  EXPECT_EQ(rows[3][knee], printf9(v1));
  EXPECT_EQ(rows[3][hip], "");
}

}  // namespace
