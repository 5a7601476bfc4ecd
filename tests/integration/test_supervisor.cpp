// The supervisor, recording and replay as a user runs them: `up sim-lockstep` then `status` shows
// every process running and ticking (the lockstep group: a loaded machine slows it down but cannot
// make the robot fall; the real-time `sim` group is checked under the label hil); killing a critical process makes the supervisor send OPERATOR
// damp; tools/record writes into the run folder; `down` leaves no process behind; a recorded push
// experiment replays exactly; two hosts (network namespaces) share one group and one status: the hil
// group split, drive emulator and hal on one, the control processes on the other.
#include <gtest/gtest.h>

#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <thread>

#include "all_types.hpp"
#include "hal_enable.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using hpr::test::run_command;

std::string supervisor() { return hpr::test::bin_dir() + "/supervisor"; }
std::string groups_file() { return hpr::test::source_dir() + "/config/groups.yaml"; }

bool alive(int pid) { return pid > 0 && ::kill(pid, 0) == 0; }

/// `status --json` as a JSON object (null when it did not parse).
json status(const std::string& url, const std::string& prefix = "") {
  const auto r = run_command({supervisor(), "status", "--json", "--lcm-url", url, "--wait", "1.2"}, prefix);
  try {
    return json::parse(r.out);
  } catch (const json::exception&) {
    ADD_FAILURE() << "status did not print JSON:\n" << r.out;
    return json();
  }
}

TEST(Supervisor, UpStatusCriticalDeathRecordAndDownLeaveNothingBehind) {
  const std::string url = hpr::test::unique_lcm_url();
  const std::string runs = hpr::test::temp_dir("supervisor-runs");
  hpr::test::LcmListener lcm(url);
  ASSERT_TRUE(lcm.good());
  auto ops = lcm.collect<humanoid::operator_t>("OPERATOR");

  const auto up = run_command({supervisor(), "up", "sim-lockstep", "--groups", groups_file(), "--lcm-url", url, "--run-root", runs});
  ASSERT_EQ(up.exit_code, 0) << up.out;
  // Whatever fails below, the group does not outlive the test: a lockstep chain left running
  // would load the machine under every later test.
  hpr::test::GroupDown group_down(supervisor(), url);
  EXPECT_NE(up.out.find("is up"), std::string::npos) << up.out;
  std::this_thread::sleep_for(2s);  // HEALTH rates cover a whole report period

  json st = status(url);
  ASSERT_EQ(st["supervisors"].size(), 1U) << st.dump(2);
  const json& sup = st["supervisors"][0];
  EXPECT_EQ(sup["group"], "sim-lockstep");
  EXPECT_EQ(sup["state"], "up") << st.dump(2);
  std::map<std::string, int> pids;
  std::map<std::string, double> rate;
  for (const auto& p : sup["processes"]) {
    pids[p["name"]] = p["pid"];
    rate[p["name"]] = p["rate_hz"];
    EXPECT_EQ(p["state"], "running") << p.dump();
    EXPECT_TRUE(alive(p["pid"])) << p.dump();
    // Each node's lifecycle from its HEALTH: the standing robot's controllers act.
    EXPECT_EQ(p["lifecycle"], "running") << p.dump();
  }
  // Ticking: the step rate of HEALTH's last 0.1 s window; a second look one second later in case a
  // scheduling stall of this shared machine fell into the first window.
  std::this_thread::sleep_for(1s);
  for (const auto& s : status(url)["supervisors"]) {
    for (const auto& p : s["processes"]) rate[p["name"]] = std::max(rate[p["name"]], p["rate_hz"].get<double>());
  }
  for (const auto& [name, hz] : rate) EXPECT_GT(hz, 100.0) << name << " is not ticking";
  for (const char* n : {"sim_bullet", "estimator", "planner", "wbc", "reference_gen", "motion_opt"}) EXPECT_EQ(pids.count(n), 1U) << n;
  const std::string run_dir = sup["run_dir"];
  for (const char* n : {"sim_bullet", "wbc", "supervisor"}) EXPECT_TRUE(std::filesystem::exists(run_dir + "/" + n + ".log")) << n;

  // tools/record: a log named by date and group in the run folder.
  hpr::test::ProcessGroup rec(url);
  const pid_t recorder = rec.start(hpr::test::source_dir() + "/tools/record", {"--run-root", runs, "--lcm-url", url});
  auto logs_in_run_dir = [&] {
    std::vector<std::filesystem::path> found;
    for (const auto& e : std::filesystem::directory_iterator(run_dir)) {
      if (e.path().extension() == ".lcm") found.push_back(e.path());
    }
    return found;
  };
  // Recording for at least 1.5 s once its log exists (a loaded machine may take seconds to start
  // the recorder), up to 20 s.
  const auto record_deadline = std::chrono::steady_clock::now() + 20s;
  while (logs_in_run_dir().empty() && rec.running(recorder) && std::chrono::steady_clock::now() < record_deadline) {
    std::this_thread::sleep_for(50ms);
  }
  std::this_thread::sleep_for(1500ms);
  rec.signal(recorder, SIGINT);
  rec.wait(recorder, 5000ms);
  const std::vector<std::filesystem::path> logs = logs_in_run_dir();
  ASSERT_EQ(logs.size(), 1U) << "tools/record wrote no log into " << run_dir;
  EXPECT_NE(logs[0].filename().string().find("-sim-lockstep.lcm"), std::string::npos) << logs[0];
  EXPECT_GT(std::filesystem::file_size(logs[0]), 100000U) << "1.5 s of a 1 kHz stack is more than 100 kB";

  // lcm-spy: under Xvfb the window starts with every type of the stack found, and every live
  // message decodes the way lcm-spy decodes it.
  if (std::system("command -v xvfb-run > /dev/null 2>&1") == 0) {
    const std::string spy_out = run_dir + "/lcm-spy.out";
    hpr::test::ProcessGroup gui(url);
    const pid_t spy = gui.start("/usr/bin/xvfb-run", {"-a", hpr::test::source_dir() + "/tools/lcm-spy", "--lcm-url", url}, {}, spy_out);
    // The window is up once it has listed the types (a cold JVM may take a while): wait for that,
    // then for a few seconds of live traffic.
    const std::string found = "Found " + std::to_string(HPR_LCM_TYPE_COUNT) + " LCM types";
    for (int i = 0; i < 300 && gui.running(spy) && hpr::test::read_file(spy_out).find(found) == std::string::npos; ++i) {
      std::this_thread::sleep_for(100ms);
    }
    std::this_thread::sleep_for(3s);
    EXPECT_TRUE(gui.running(spy)) << "lcm-spy ended:\n" << hpr::test::read_file(spy_out);
    gui.stop_all();
    const std::string text = hpr::test::read_file(spy_out);
    EXPECT_NE(text.find(found), std::string::npos) << text;
    EXPECT_EQ(text.find("Exception"), std::string::npos) << text;
  } else {
    ADD_FAILURE() << "xvfb-run is missing (tools/install-deps installs it): the lcm-spy window is not checked";
  }
  // Listens 5 s, then on until every channel below has been seen (a loaded machine's JVM may deliver
  // the first seconds late); a channel that never comes fails the check.
  const std::string channels = "ROBOT_SENSORS,ROBOT_STATE,BALANCE_PLAN,BALANCE_STATUS,CAM_REFERENCE,WHOLEBODY_COMMAND,JOINT_COMMAND,SIM_TRUTH,HEALTH,SUPERVISOR_STATUS";
  const auto spy = run_command({hpr::test::source_dir() + "/tools/lcm-spy", "--check", "5", "--lcm-url", url, "--expect", channels});
  EXPECT_EQ(spy.exit_code, 0) << spy.out;
  EXPECT_NE(spy.out.find("every message decoded"), std::string::npos) << spy.out;
  for (const char* c : {"ROBOT_SENSORS", "ROBOT_STATE", "BALANCE_PLAN", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND",
                        "JOINT_COMMAND", "SIM_TRUTH", "HEALTH", "SUPERVISOR_STATUS"}) {
    EXPECT_NE(spy.out.find(std::string("\n") + c + " "), std::string::npos) << c << " not seen by lcm-spy:\n" << spy.out;
  }

  // 300 messages on HEALTH that are not the stack's (no code: HEALTH is signed): the supervisor
  // counts them and says so a few times a second with the count (not LCM's own line per message),
  // and its group stays up.
  for (int k = 0; k < 300; ++k) {
    const std::uint8_t junk[3] = {1, 2, static_cast<std::uint8_t>(k)};
    lcm.lcm().publish("HEALTH", junk, sizeof(junk));
  }
  std::this_thread::sleep_for(2500ms);
  {
    const std::string text = hpr::test::read_file(run_dir + "/supervisor.log");
    int lines = 0;
    for (auto p = text.find("HEALTH: a message of 3 bytes refused: no valid authentication code"); p != std::string::npos;
         p = text.find("HEALTH: a message of 3 bytes refused: no valid authentication code", p + 1)) {
      ++lines;
    }
    EXPECT_GE(lines, 2) << text;
    EXPECT_LE(lines, 12) << "one line per bad message:\n" << text;
    EXPECT_NE(text.find("more like this in the last second"), std::string::npos) << text;
    EXPECT_EQ(text.find("error -1 decoding"), std::string::npos) << text;
    EXPECT_EQ(status(url)["supervisors"][0]["state"], "up");
  }

  // A critical process dies: OPERATOR damp from the supervisor.
  ASSERT_TRUE(alive(pids["wbc"]));
  ::kill(pids["wbc"], SIGKILL);
  const bool damped = lcm.wait_for([&] {
    for (const auto& o : *ops) {
      if (o.command == humanoid::operator_t::COMMAND_DAMP && o.source.rfind("supervisor@", 0) == 0) return true;
    }
    return false;
  }, 5s);
  EXPECT_TRUE(damped) << "no OPERATOR damp after wbc was killed";
  if (damped) {
    EXPECT_NE(ops->back().reason.find("wbc"), std::string::npos) << ops->back().reason;
  }
  st = status(url);
  ASSERT_EQ(st["supervisors"].size(), 1U);
  EXPECT_EQ(st["supervisors"][0]["state"], "degraded");

  // logs NAME prints the process's log.
  const auto log = run_command({supervisor(), "logs", "sim_bullet", "--lcm-url", url, "--run-root", runs});
  EXPECT_EQ(log.exit_code, 0);
  EXPECT_NE(log.out.find("supervisor: start 1 of 'sim_bullet'"), std::string::npos) << log.out;

  const int supervisor_pid = st["supervisors"][0]["pid"];
  const auto down = run_command({supervisor(), "down", "--lcm-url", url});
  group_down.dismiss();
  EXPECT_EQ(down.exit_code, 0) << down.out;
  EXPECT_NE(down.out.find("stopped"), std::string::npos) << down.out;
  // down returns once the supervisor's pid is gone (or 10 s after its goodbye); a loaded machine
  // may take a moment to reap it.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (alive(supervisor_pid) && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(50ms);
  for (const auto& [name, pid] : pids) EXPECT_FALSE(alive(pid)) << name << " (pid " << pid << ") is still running after down";
  EXPECT_FALSE(alive(supervisor_pid)) << "the supervisor is still running 10 s after down";
  EXPECT_EQ(status(url)["supervisors"].size(), 0U);
}

TEST(Supervisor, ABadGroupIsRefusedWithTheFileKeyAndValue) {
  const std::string dir = hpr::test::temp_dir("supervisor-bad");
  const std::string file = dir + "/groups.yaml";
  std::ofstream(file) << "groups:\n  g:\n    processes:\n      a: {command: estimator, restart: sometimes}\n";
  const auto r = run_command({supervisor(), "up", "g", "--groups", file, "--run-root", dir});
  EXPECT_EQ(r.exit_code, 2);
  const auto unknown = run_command({supervisor(), "up", "nonexistent", "--groups", groups_file(), "--run-root", dir});
  EXPECT_EQ(unknown.exit_code, 2);
}

TEST(Replay, RecordedPushExperimentReproducesExactlyAndADifferentGainDoesNot) {
  const std::string dir = hpr::test::temp_dir("replay");
  const std::string log = dir + "/push.lcm";
  const auto trial = run_command({hpr::test::bin_dir() + "/push_trial", "--impulse", "12", "--after", "1", "--log", log, "--quiet"});
  ASSERT_EQ(trial.exit_code, 3) << trial.out;  // inconclusive: 1 s after the push is too short to judge
  ASSERT_TRUE(std::filesystem::exists(log));
  const std::string tool = hpr::test::source_dir() + "/tools/replay";
  const auto same = run_command({tool, log, "--rerun", "estimator,planner,wbc,reference_gen,motion_opt", "--set", "balance.support=double",
                                 "--json", dir + "/same.json", "--work-dir", dir + "/same"});
  EXPECT_EQ(same.exit_code, 0) << same.out;
  const json s = json::parse(std::ifstream(dir + "/same.json"));
  EXPECT_TRUE(s["complete"].get<bool>()) << "the recorder lost messages: " << s["lacking"].dump();
  EXPECT_TRUE(s["match"].get<bool>()) << s.dump(2);
  for (const char* c : {"ROBOT_STATE", "BALANCE_PLAN", "JOINT_COMMAND", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND"}) {
    EXPECT_GT(s["channels"][c]["compared"].get<int>(), 2500) << c;  // 3.3 s at 1 kHz
    EXPECT_EQ(s["channels"][c]["different"].get<int>(), 0) << c;
  }
  // The five controllers composed in one process answer the same inputs with the same messages,
  // bit for bit, on every channel the five processes published; re-run on another machine (another
  // deployment key, which the re-run nodes check: replay_check signs the played inputs with it).
  const std::string another_key = dir + "/another-machine/lcm.key";
  const auto composed = run_command({tool, log, "--rerun", "controllers", "--set", "balance.support=double", "--json",
                                     dir + "/composed.json", "--work-dir", dir + "/composed"},
                                    "HPR_LCM_KEY_FILE=" + hpr::test::quote(another_key));
  ASSERT_TRUE(std::filesystem::exists(another_key)) << "the re-run did not use its own key";
  EXPECT_EQ(composed.exit_code, 0) << composed.out;
  const json c = json::parse(std::ifstream(dir + "/composed.json"));
  EXPECT_TRUE(c["match"].get<bool>()) << c.dump(2);
  for (const char* ch : {"ROBOT_STATE", "BALANCE_PLAN", "JOINT_COMMAND", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND"}) {
    EXPECT_GT(c["channels"][ch]["compared"].get<int>(), 2500) << ch;
    EXPECT_EQ(c["channels"][ch]["different"].get<int>(), 0) << ch;
  }
  // The comparison can fail: a 0.03 % change of one CoM stiffness shows on the wbc's outputs.
  const auto other = run_command({tool, log, "--rerun", "wbc", "--set", "balance.support=double", "--set",
                                  "wbc.com.stiffness=[1500, 1500, 3001]", "--json", dir + "/other.json", "--work-dir", dir + "/other"});
  EXPECT_EQ(other.exit_code, 1) << other.out;
  const json o = json::parse(std::ifstream(dir + "/other.json"));
  EXPECT_FALSE(o["match"].get<bool>());
  EXPECT_GT(o["channels"]["JOINT_COMMAND"]["different"].get<int>(), 1000) << o.dump(2);

  // A log that lost one ROBOT_SENSORS message: the check names the tick, compares what comes
  // before it (which matches) and says the log is incomplete.
  const std::string holed = dir + "/holed.lcm";
  {
    lcm::LogFile in(log, "r"), out(holed, "w");
    ASSERT_TRUE(in.good() && out.good());
    int sensors = 0;
    for (const lcm::LogEvent* ev = in.readNextEvent(); ev != nullptr; ev = in.readNextEvent()) {
      if (std::string(ev->channel) == "ROBOT_SENSORS" && ++sensors == 1501) continue;
      out.writeEvent(const_cast<lcm::LogEvent*>(ev));
    }
  }
  const auto gap = run_command({tool, holed, "--rerun", "estimator", "--set", "balance.support=double", "--json", dir + "/holed.json",
                                "--work-dir", dir + "/holed"});
  EXPECT_EQ(gap.exit_code, 3) << gap.out;
  const json h = json::parse(std::ifstream(dir + "/holed.json"));
  EXPECT_FALSE(h["complete"].get<bool>());
  ASSERT_EQ(h["lacking"]["ROBOT_SENSORS"].size(), 1U) << h.dump(2);
  const std::int64_t hole = h["lacking"]["ROBOT_SENSORS"][0];
  EXPECT_EQ(h["compared_before_tick"].get<std::int64_t>(), hole);
  EXPECT_TRUE(h["match"].get<bool>()) << h.dump(2);
  EXPECT_GT(h["channels"]["ROBOT_STATE"]["compared"].get<std::int64_t>(), hole - 5);
  EXPECT_NE(gap.out.find("the log lacks ROBOT_SENSORS of 1 tick (" + std::to_string(hole) + ")"), std::string::npos) << gap.out;

  // A channel the log has none of agrees only when the re-run publishes none either: without
  // CAM_REFERENCE in the log, re-run reference_gen's CAM_REFERENCE is counted against the match
  // (motion_opt's WHOLEBODY_COMMAND, which it feeds, still matches).
  const std::string no_cam = dir + "/no-cam.lcm";
  {
    lcm::LogFile in(log, "r"), out(no_cam, "w");
    ASSERT_TRUE(in.good() && out.good());
    for (const lcm::LogEvent* ev = in.readNextEvent(); ev != nullptr; ev = in.readNextEvent()) {
      if (std::string(ev->channel) != "CAM_REFERENCE") out.writeEvent(const_cast<lcm::LogEvent*>(ev));
    }
  }
  const auto extra = run_command({tool, no_cam, "--rerun", "reference_gen,motion_opt", "--set", "balance.support=double", "--json",
                                  dir + "/no-cam.json", "--work-dir", dir + "/no-cam"});
  EXPECT_EQ(extra.exit_code, 1) << extra.out;
  const json x = json::parse(std::ifstream(dir + "/no-cam.json"));
  EXPECT_FALSE(x["match"].get<bool>());
  EXPECT_GT(x["channels"]["CAM_REFERENCE"]["unrecorded"].get<int>(), 2500) << x.dump(2);
  EXPECT_GT(x["channels"]["WHOLEBODY_COMMAND"]["compared"].get<int>(), 2500);
  EXPECT_EQ(x["channels"]["WHOLEBODY_COMMAND"]["different"].get<int>(), 0);
}

// The ankle strategy composed: the controllers process publishes neither CAM_REFERENCE nor
// WHOLEBODY_COMMAND, as the recorded processes did not; everything else matches bit for bit.
TEST(Replay, TheAnkleStrategyComposedAnswersAsItsProcessesDid) {
  const std::string dir = hpr::test::temp_dir("replay-ankle");
  const std::string log = dir + "/ankle.lcm";
  const auto trial = run_command(
      {hpr::test::bin_dir() + "/push_trial", "--strategy", "ankle", "--impulse", "12", "--after", "1", "--log", log, "--quiet"});
  ASSERT_EQ(trial.exit_code, 3) << trial.out;
  const auto composed = run_command({hpr::test::source_dir() + "/tools/replay", log, "--rerun", "controllers", "--set",
                                     "balance.support=double", "--set", "wbc.wait_for_wholebody=false", "--json", dir + "/composed.json",
                                     "--work-dir", dir + "/composed"});
  EXPECT_EQ(composed.exit_code, 0) << composed.out;
  const json c = json::parse(std::ifstream(dir + "/composed.json"));
  EXPECT_TRUE(c["match"].get<bool>()) << c.dump(2);
  for (const char* ch : {"ROBOT_STATE", "JOINT_COMMAND", "BALANCE_STATUS"}) {
    EXPECT_GT(c["channels"][ch]["compared"].get<int>(), 2500) << ch;
    EXPECT_EQ(c["channels"][ch]["different"].get<int>(), 0) << ch;
  }
  for (const char* ch : {"CAM_REFERENCE", "WHOLEBODY_COMMAND"}) {
    EXPECT_EQ(c["channels"][ch]["compared"].get<int>(), 0) << ch;
    EXPECT_EQ(c["channels"][ch]["unrecorded"].get<int>(), 0) << ch;
  }
}

TEST(Supervisor, TwoHostsRunOneGroupWithOneStatusAndStand) {
  hpr::test::NetnsPair hosts;
  if (!hosts.ok) GTEST_SKIP() << hosts.why;
  const std::string url = "udpm://239.255.76.67:7667?ttl=1";  // leaves the host: each namespace is a host
  const std::string dir = hpr::test::temp_dir("supervisor-hosts");
  const std::string file = dir + "/groups.yaml";
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  // The hil group (on the drive emulator's clock, hal.clock=lockstep): the drives' side, emulator
  // and hal talking cannelloni over the robot's loopback, on "plant"; the control processes on "brain".
  const std::string lockstep = "--set, hal.clock=lockstep";
  std::ofstream(file) << "vars: {cfg: " << cfg << "}\n"
                      << "groups:\n  split:\n    description: the robot's drives and hal on one host, its controllers on another\n"
                      << "    processes:\n"
                      << "      drive_emulator: {command: drive_emulator, host: plant, args: [--config, '${cfg}', " << lockstep << "]}\n"
                      << "      hal: {command: hal, host: plant, depends_on: [drive_emulator], args: [--config, '${cfg}', " << lockstep << "]}\n"
                      << hpr::test::control_processes_yaml("brain");
  // This test listens from host "plant" (LCM opens its receive socket lazily, so the thread stays there).
  ASSERT_TRUE(hosts.enter(hosts.a));
  hpr::test::LcmListener lcm(url);
  ASSERT_TRUE(lcm.good());
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  auto commands = lcm.collect<humanoid::joint_command_t>("JOINT_COMMAND");
  auto hal_status = lcm.collect<humanoid::hal_status_t>("HAL_STATUS");

  hpr::test::GroupDown group_down(supervisor(), url, hosts.exec(hosts.b));  // both hosts, whatever fails below
  const auto brain = run_command({supervisor(), "up", "split", "--groups", file, "--host", "brain", "--lcm-url", url, "--run-root", dir + "/brain"}, hosts.exec(hosts.b));
  ASSERT_EQ(brain.exit_code, 0) << brain.out;
  const auto plant = run_command({supervisor(), "up", "split", "--groups", file, "--host", "plant", "--lcm-url", url, "--run-root", dir + "/plant"}, hosts.exec(hosts.a));
  ASSERT_EQ(plant.exit_code, 0) << plant.out;

  // One status, asked on either host, shows both hosts' processes.
  const json st = status(url, hosts.exec(hosts.a));
  std::map<std::string, std::string> where;
  for (const auto& s : st["supervisors"]) {
    for (const auto& p : s["processes"]) where[p["name"]] = s["host"];
  }
  EXPECT_EQ(where["drive_emulator"], "plant") << st.dump(2);
  EXPECT_EQ(where["hal"], "plant") << st.dump(2);
  for (const char* n : {"estimator", "planner", "wbc", "reference_gen", "motion_opt"}) EXPECT_EQ(where[n], "brain") << n << "\n" << st.dump(2);

  // Commands come from the other host; the operator enables the drives; the robot stands 10 s
  // (simulated) with its controllers on the other host.
  ASSERT_EQ(hpr::test::enable_drives(lcm, commands, hal_status, 60s, 10s), "") << "with the control processes on host 'brain'";
  const auto hal_state = [&] { return hal_status->empty() ? -1 : int{hal_status->back().state}; };
  const bool ran = lcm.wait_for([&] { return !truth->empty() && (truth->back().sim_time >= 10.0 || truth->back().fallen); }, 180s);
  ASSERT_TRUE(ran) << "SIM_TRUTH did not reach 10 s: " << (truth->empty() ? 0.0 : truth->back().sim_time);
  EXPECT_FALSE(truth->back().fallen);
  EXPECT_GE(truth->back().sim_time, 10.0);
  EXPECT_EQ(hal_state(), int{humanoid::hal_status_t::STATE_ENABLED}) << hal_status->back().state_reason;

  // down from one host stops both.
  const auto down = run_command({supervisor(), "down", "--lcm-url", url}, hosts.exec(hosts.b));
  group_down.dismiss();
  EXPECT_EQ(down.exit_code, 0) << down.out;
  EXPECT_NE(down.out.find("'plant': stopped"), std::string::npos) << down.out;
  EXPECT_NE(down.out.find("'brain': stopped"), std::string::npos) << down.out;
}

}  // namespace
