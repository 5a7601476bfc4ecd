// Faults injected into a running group, as an operator or an attacker would: forged ticks far in
// the future, a simulator restarted under the running chain, a control process stopped with
// SIGSTOP, optional components killed. The chain must run on, follow the restarted clock, damp
// once a critical process is hung (within 100 ms in the real-time group), and run the wbc's own
// reference at full rate without the optimiser.
//
// Built twice: test_faults runs the sim-lockstep group (label integration: every deadline is a
// tick, so it holds on a loaded machine); test_faults_realtime runs the same checks on the
// real-time sim group and also checks that the robot still stands after the restart (label hil).
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "hpr/graph/data_flow.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::run_command;
using Clock = std::chrono::steady_clock;

#ifdef HPR_FAULTS_REALTIME
constexpr const char* kGroup = "sim";
#else
constexpr const char* kGroup = "sim-lockstep";
#endif

std::string supervisor() { return hpr::test::bin_dir() + "/supervisor"; }

/// The latest message of each channel the tests watch, and when the first damp arrived.
class Watch {
 public:
  explicit Watch(const std::string& url) : lcm_(url) {
    auto& l = lcm_.lcm();
    l.subscribe("ROBOT_SENSORS", &Watch::keep<humanoid::robot_sensors_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    l.subscribe("ROBOT_STATE", &Watch::keep<humanoid::robot_state_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    l.subscribe("JOINT_COMMAND", &Watch::keep<humanoid::joint_command_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    l.subscribe("SIM_TRUTH", &Watch::keep<humanoid::sim_truth_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    l.subscribe("HEALTH", &Watch::keep<humanoid::health_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    l.subscribe("OPERATOR", &Watch::keep<humanoid::operator_t>, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    for (const char* c : {"BALANCE_PLAN", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND"}) {
      l.subscribe(c, &Watch::keep_bytes, this)->setQueueCapacity(hpr::node::kCountingQueueCapacity);
    }
  }
  bool wait_for(const std::function<bool()>& done, std::chrono::milliseconds timeout) { return lcm_.wait_for(done, timeout); }
  /// Handles what has queued up (messages sent while the test started the group) until none is
  /// waiting, so that the latest messages are the chain's present ones.
  void catch_up() {
    for (int n = 0; n < 1'000'000 && lcm_.lcm().handleTimeout(0) > 0; ++n) {
    }
  }
  /// Publishes as the stack does (a signed type with the deployment's key).
  template <class Msg>
  void publish(const std::string& channel, const Msg& m) {
    lcm_.publish(channel, m);
  }
  /// Publishes as a sender without the key does.
  template <class Msg>
  void publish_unsigned(const std::string& channel, const Msg& m) {
    lcm_.publish_unsigned(channel, m);
  }
  [[nodiscard]] const hpr::auth::Key& key() { return lcm_.key(); }
  lcm::LCM& lcm() { return lcm_.lcm(); }

  humanoid::robot_sensors_t sensors{};
  humanoid::robot_state_t state{};
  humanoid::joint_command_t command{};
  humanoid::sim_truth_t truth{};
  std::map<std::string, humanoid::health_t> health;
  std::int64_t commands = 0, truths = 0;
  std::optional<Clock::time_point> first_damp;
  std::string damp_reason;
  std::map<std::string, std::vector<std::uint8_t>> bytes;  ///< the latest signed message of each channel, as received

 private:
  /// What the stack (or the test, with the key) sent: a forged or corrupted copy is not the chain's present.
  bool authentic(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    return hpr::auth::verify(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, channel, key());
  }
  void keep_bytes(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (!authentic(rbuf, channel)) return;
    const auto* data = static_cast<const std::uint8_t*>(rbuf->data);
    bytes[channel].assign(data, data + rbuf->data_size);
  }
  template <class Msg>
  void keep(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if constexpr (hpr::auth::Signed<Msg>) {
      if (!authentic(rbuf, channel)) return;
      keep_bytes(rbuf, channel);
    }
    Msg m;
    if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    if constexpr (std::is_same_v<Msg, humanoid::robot_sensors_t>) sensors = m;
    if constexpr (std::is_same_v<Msg, humanoid::robot_state_t>) state = m;
    if constexpr (std::is_same_v<Msg, humanoid::joint_command_t>) {
      command = m;
      ++commands;
    }
    if constexpr (std::is_same_v<Msg, humanoid::sim_truth_t>) {
      truth = m;
      ++truths;
    }
    if constexpr (std::is_same_v<Msg, humanoid::health_t>) health[m.node] = m;
    if constexpr (std::is_same_v<Msg, humanoid::operator_t>) {
      if (m.command == humanoid::operator_t::COMMAND_DAMP && m.source.rfind("supervisor@", 0) == 0 && !first_damp) {
        first_damp = Clock::now();
        damp_reason = m.reason;
      }
    }
  }
  hpr::test::LcmListener lcm_;
};

/// A group run by the supervisor for one test; down (and nothing left) at the end.
class Group {
 public:
  explicit Group(const std::string& url, const std::string& name = kGroup) : url_(url), runs_(hpr::test::temp_dir("faults-runs")) {
    const auto up = run_command({supervisor(), "up", name, "--lcm-url", url_, "--run-root", runs_});
    up_ = up.exit_code == 0;
    up_text_ = up.out;
    if (!up_) return;
    // A loaded machine may take longer than one status wait to answer: asked up to five times.
    std::string error;
    for (int attempt = 0; attempt < 5 && run_dir_.empty(); ++attempt) {
      const auto st = run_command({supervisor(), "status", "--json", "--lcm-url", url_, "--wait", "1.2"});
      try {
        const nlohmann::json j = nlohmann::json::parse(st.out);
        const nlohmann::json& sup = j.at("supervisors").at(0);
        for (const auto& p : sup.at("processes")) pids_[p.at("name").get<std::string>()] = p.at("pid").get<int>();
        run_dir_ = sup.at("run_dir").get<std::string>();
      } catch (const std::exception& e) {
        error = std::string(e.what()) + "\n" + st.out;
      }
    }
    if (run_dir_.empty()) ADD_FAILURE() << "status --json: " << error;
  }
  ~Group() { run_command({supervisor(), "down", "--lcm-url", url_}); }
  Group(const Group&) = delete;
  Group& operator=(const Group&) = delete;

  [[nodiscard]] bool up() const { return up_; }
  [[nodiscard]] const std::string& up_text() const { return up_text_; }
  /// The process's pid (-1 when unknown: never 0, which kill() would take for this test's own group).
  [[nodiscard]] int pid(const std::string& name) const { return pids_.count(name) != 0 && pids_.at(name) > 0 ? pids_.at(name) : -1; }
  [[nodiscard]] std::string log(const std::string& name) const { return hpr::test::read_file(run_dir_ + "/" + name + ".log"); }
  int restart(const std::string& name) const {
    return run_command({supervisor(), "restart", name, "--lcm-url", url_}).exit_code;
  }

 private:
  std::string url_, runs_, run_dir_, up_text_;
  bool up_ = false;
  std::map<std::string, int> pids_;
};

// The two builds name their suites apart: CTest labels a test by its name, so one name in both
// would put the lockstep test under the real-time build's label.
#ifdef HPR_FAULTS_REALTIME
#define FAULTS_TEST(name) TEST(FaultsRealtime, name)
#else
#define FAULTS_TEST(name) TEST(Faults, name)
#endif

constexpr std::int64_t kForged = 1'000'000'000;

/// A forger with the key who copies a live message's sender: its identity, with a message count
/// far enough ahead of the live one's that the counter rule takes it for new (the tick and time
/// rules are what must hold it).
template <class Msg>
void as_the_sender_ahead(Msg& m) {
  m.source += 1'000'000;
}

/// Waits until the chain answers: a JOINT_COMMAND in run mode at least `ticks` past `from`.
bool chain_runs(Watch& w, std::int64_t from, std::int64_t ticks, std::chrono::milliseconds timeout) {
  return w.wait_for([&] {
    return w.command.tick >= from + ticks && w.command.tick < kForged && w.command.mode == humanoid::joint_command_t::MODE_RUN;
  }, timeout);
}

/// A group up with its chain running (`ticks` commands) and the watch caught up with the present.
struct Running {
  std::string url = hpr::test::unique_lcm_url();
  Watch w{url};
  Group g{url};
  ::testing::AssertionResult started(std::int64_t ticks = 500) {
    if (!g.up()) return ::testing::AssertionFailure() << g.up_text();
    if (!chain_runs(w, 0, ticks, 30s)) return ::testing::AssertionFailure() << "the chain did not start";
    w.catch_up();
    return ::testing::AssertionSuccess();
  }
};

FAULTS_TEST(ForgedFutureTicksAreHeldAndARestartedSimulatorIsFollowed) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s)) << "the chain did not start";

  // Forged copies of live messages, each a billion ticks ahead, on the three clocked channels.
  humanoid::robot_sensors_t s = w.sensors;
  humanoid::robot_state_t e = w.state;
  humanoid::joint_command_t c = w.command;
  s.tick += kForged;
  e.tick += kForged;
  c.tick += kForged;
  as_the_sender_ahead(s);
  as_the_sender_ahead(e);
  as_the_sender_ahead(c);
  w.publish("ROBOT_SENSORS", s);
  w.publish("ROBOT_STATE", e);
  w.publish("JOINT_COMMAND", c);
  const std::int64_t at_forge = w.command.tick;
  EXPECT_TRUE(chain_runs(w, at_forge, 1000, 30s)) << "the chain stalled after a forged tick: last JOINT_COMMAND " << w.command.tick;
  // Counted in HEALTH (as rejected messages) by the nodes that received them.
  ASSERT_TRUE(w.wait_for([&] { return w.health["estimator"].decode_errors >= 1 && w.health["wbc"].decode_errors >= 1; }, 5s));
  EXPECT_NE(g.log("estimator").find("ahead of the last tick"), std::string::npos) << "the held tick is logged";

  // The simulator restarts at tick 0 under the running chain (after 6 s, so that the new clock's
  // first 2 s are told apart from the old one's).
  ASSERT_TRUE(w.wait_for([&] { return w.truth.tick > 6000; }, 60s));
  const std::int64_t before = w.truth.tick;
  ASSERT_EQ(g.restart("sim_bullet"), 0);
  ASSERT_TRUE(w.wait_for([&] { return w.truth.tick < before - 500; }, 30s)) << "the simulator did not restart";
  // The consumers follow the new clock: commands answer the new ticks and the robot is driven
  // (not damped) for two simulated seconds.
  EXPECT_TRUE(w.wait_for([&] {
    return w.truth.tick >= 2000 && w.truth.tick < before && w.command.tick >= 2000 && w.command.tick < before &&
           w.command.mode == humanoid::joint_command_t::MODE_RUN;
  }, 60s)) << "after the restart: SIM_TRUTH tick " << w.truth.tick << ", JOINT_COMMAND tick " << w.command.tick << " mode "
           << int{w.command.mode};
  EXPECT_FALSE(w.truth.fallen) << "the robot fell after the simulator restarted";
  for (const char* n : {"estimator", "planner", "wbc", "reference_gen", "motion_opt"}) {
    EXPECT_NE(g.log(n).find("following tick"), std::string::npos) << n << " did not log that it followed the new clock";
  }
}

// One copy of a live message, 600 ticks ahead (inside lcm.tick_window) with a time 2^58 us ahead, on
// each clocked channel: accepted, it would become the clock the real stream is judged by ("time
// does not advance"), and the robot fell; at the simulator, a command taken as current leaves the
// real ones behind it until the stream has been quiet for lcm.source_quiet_s, and the robot fell.
// Each is held for its time; the chain runs on and the robot stands.
FAULTS_TEST(OneSampleWithAFarTimeInsideTheTickWindowIsHeldAndTheRobotStands) {
  Running r;
  ASSERT_TRUE(r.started());  // copies of the present messages: their ticks 200 ahead are inside the window
  Watch& w = r.w;
  Group& g = r.g;
  constexpr std::int64_t kFar = std::int64_t{1} << 58;
  humanoid::robot_sensors_t s = w.sensors;
  humanoid::robot_state_t e = w.state;
  humanoid::joint_command_t c = w.command;
  ASSERT_GT(c.utime, 0) << "the wbc's commands carry no time: the time rule cannot hold them";
  for (auto* tick : {&s.tick, &e.tick, &c.tick}) *tick += 600;
  for (auto* utime : {&s.utime, &e.utime, &c.utime}) *utime += kFar;
  as_the_sender_ahead(s);
  as_the_sender_ahead(e);
  as_the_sender_ahead(c);
  w.publish("ROBOT_SENSORS", s);
  w.publish("ROBOT_STATE", e);
  w.publish("JOINT_COMMAND", c);
  const std::int64_t at_forge = w.command.tick;
  EXPECT_TRUE(chain_runs(w, at_forge, 2000, 60s)) << "the chain stalled after the forged samples: " << w.command.tick;
  EXPECT_FALSE(w.truth.fallen) << "the robot fell after one forged sample";
  ASSERT_TRUE(w.wait_for([&] {
    return w.health["estimator"].decode_errors >= 1 && w.health["wbc"].decode_errors >= 1 && w.health["sim_bullet"].decode_errors >= 1;
  }, 5s)) << "not counted everywhere";
  for (const char* n : {"estimator", "wbc", "sim_bullet"}) {
    const std::string log = g.log(n);
    EXPECT_NE(log.find("s ahead of"), std::string::npos) << n << " did not say why it held the sample:\n" << log;
    EXPECT_EQ(log.find("following tick"), std::string::npos) << n << " followed the forged sample:\n" << log;
    EXPECT_EQ(log.find("does not advance"), std::string::npos) << n << " refused the real stream:\n" << log;
  }
}

// A second sender on the clocked channels (a stray simulator or controller with its own identity, and
// the key): samples whose ticks and times continue the stream, with every joint at zero, and limp
// commands, each a few ticks ahead of the live ones. Each reader holds them as another source's,
// counts them and says so; the chain runs on with the real streams and the robot stands.
FAULTS_TEST(ASecondSenderInsideTheTickWindowIsHeldAndTheRobotStands) {
  Running r;
  ASSERT_TRUE(r.started());
  Watch& w = r.w;
  Group& g = r.g;
  constexpr std::int64_t kStray = std::int64_t{0x5eed} << 32;  // its identity (the upper 32 bits)
  constexpr int kEach = 50;
  for (int k = 1; k <= kEach; ++k) {
    humanoid::robot_sensors_t s = w.sensors;
    s.source = kStray | k;
    s.tick += 2;
    s.utime += 2000;
    std::fill(s.q.begin(), s.q.end(), 0.0);
    w.publish("ROBOT_SENSORS", s);
    humanoid::joint_command_t c = w.command;
    c.source = kStray | k;
    c.tick += 2;
    std::fill(c.kp.begin(), c.kp.end(), 0.0);
    std::fill(c.kd.begin(), c.kd.end(), 0.0);
    std::fill(c.tau_ff.begin(), c.tau_ff.end(), 0.0);
    w.publish("JOINT_COMMAND", c);  // signed: an insider with the key, but another process
    w.wait_for([] { return false; }, 2ms);
  }
  const std::int64_t at_forge = w.command.tick;
  EXPECT_TRUE(chain_runs(w, at_forge, 2000, 60s)) << "the chain stalled after the second sender: tick " << w.command.tick;
  EXPECT_FALSE(w.truth.fallen) << "the robot fell";
  EXPECT_GT(w.truth.p_WB[2], 0.8) << "the pelvis sank";
  const auto counted = [&] {
    return w.health["estimator"].decode_errors >= kEach && w.health["sim_bullet"].decode_errors >= kEach;
  };
  EXPECT_TRUE(w.wait_for(counted, 5s)) << "estimator " << w.health["estimator"].decode_errors << ", sim_bullet "
                                      << w.health["sim_bullet"].decode_errors;
  for (const char* n : {"estimator", "sim_bullet"}) {
    const std::string log = g.log(n);
    EXPECT_NE(log.find("source 00005eed is not the stream's source"), std::string::npos) << n << " did not say why:\n" << log;
    EXPECT_EQ(log.find("following tick"), std::string::npos) << n << " followed the second sender:\n" << log;
  }
}

// Anyone on the network but the stack: a JOINT_COMMAND that would fell the robot (the chain's own at
// the next ticks, made limp) and OPERATOR damp and stop, sent without the code, with another key's
// code, or with the code of another message. Every one is refused before it acts and counted in the
// HEALTH of each process that reads the channel; the chain runs on and the robot stands.
FAULTS_TEST(CommandsWithoutTheDeploymentsCodeAreRefusedCountedAndTheRobotStands) {
  Running r;
  ASSERT_TRUE(r.started());
  Watch& w = r.w;
  Group& g = r.g;
  hpr::auth::Key other = w.key();
  other.bytes[7] ^= 0x5a;
  constexpr int kEach = 20;
  int commands_sent = 0;
  for (int k = 1; k <= kEach; ++k) {
    humanoid::joint_command_t c = w.command;  // its code is the wbc's, for the message before the change
    c.tick += k;
    for (int j = 0; j < c.num_joints; ++j) {
      c.kp[static_cast<std::size_t>(j)] = 0.0;
      c.kd[static_cast<std::size_t>(j)] = 0.0;
      c.tau_ff[static_cast<std::size_t>(j)] = 0.0;
    }
    w.publish_unsigned("JOINT_COMMAND", c);
    hpr::node::publish_signed(w.lcm(), "JOINT_COMMAND", c, other);
    commands_sent += 2;
    humanoid::operator_t op{};
    op.tick = k;
    op.utime = static_cast<std::int64_t>(k);
    op.source = "intruder";
    op.command = k % 2 == 0 ? humanoid::operator_t::COMMAND_DAMP : humanoid::operator_t::COMMAND_STOP;
    op.reason = "forged";
    w.publish_unsigned("OPERATOR", op);
    hpr::node::publish_signed(w.lcm(), "OPERATOR", op, other);
    w.wait_for([] { return false; }, 5ms);
  }
  const std::int64_t at_forge = w.command.tick;
  EXPECT_TRUE(chain_runs(w, at_forge, 2000, 60s)) << "the chain stopped after the forged commands: tick " << w.command.tick
                                                  << " mode " << int{w.command.mode};
  EXPECT_FALSE(w.truth.fallen) << "the robot fell";
  EXPECT_GT(w.truth.p_WB[2], 0.8) << "the pelvis sank";
  EXPECT_FALSE(w.first_damp.has_value()) << "the supervisor damped: " << w.damp_reason;
  // Each reader of OPERATOR (the wbc has two: its lifecycle and its live parameters) refused all
  // 2 kEach of them; the simulator, which reads no OPERATOR, every forged command.
  const auto counted = [&] {
    for (const char* n : {"estimator", "wbc"}) {
      if (w.health.count(n) == 0 || w.health[n].unauthenticated < 2 * kEach) return false;
    }
    return w.health["sim_bullet"].unauthenticated >= commands_sent;
  };
  EXPECT_TRUE(w.wait_for(counted, 5s)) << "estimator " << w.health["estimator"].unauthenticated << ", wbc "
                                      << w.health["wbc"].unauthenticated << ", sim_bullet " << w.health["sim_bullet"].unauthenticated;
  for (const char* n : {"wbc", "sim_bullet"}) {
    const std::string log = g.log(n);
    EXPECT_NE(log.find("no valid authentication code"), std::string::npos) << n << " did not say why:\n" << log;
    EXPECT_EQ(log.find("intruder"), std::string::npos) << n << " acted on the intruder's OPERATOR:\n" << log;
  }
}

// Bit flips on every clocked channel of the control chain for a second: each 2 ms, a copy of the
// latest message of each channel with one random bit flipped (the fingerprint, a tick, a time, a
// count, a number, the code). Every copy that a reader takes in fails its authentication code and
// is refused before it is decoded, and counted there; the chain runs on with the real streams and
// the robot stands. (Without the codes, a copy whose one changed number still decodes, a pelvis
// height or a contact flag, reaches the controllers: the robot fell in 1 of 2 runs,
// docs/SAFETY.md.) A control node keeps LCM's subscription queue of 30 messages (it wants the
// latest message, not a backlog: hpr/node/lcm_url.hpp), so a reader held up on a loaded machine
// (the simulator, stepping the physics in lockstep) drops part of the flood before reading it; each
// reader must refuse at least half of what was sent to it, which it cannot unless it checks the
// code on that channel. That every single flipped bit fails the code is Auth.EveryFlippedBit*.
FAULTS_TEST(BitFlipsInEveryClockedChannelForASecondAreRefusedAndTheRobotStands) {
  Running r;
  ASSERT_TRUE(r.started());
  Watch& w = r.w;
  Group& g = r.g;
  std::mt19937_64 random(17);
  const std::vector<std::string> channels = {"ROBOT_SENSORS", "ROBOT_STATE", "BALANCE_PLAN", "BALANCE_STATUS", "CAM_REFERENCE",
                                             "WHOLEBODY_COMMAND", "JOINT_COMMAND"};
  for (const auto& c : channels) ASSERT_TRUE(w.wait_for([&] { return w.bytes.count(c) != 0; }, 10s)) << "no " << c;
  // What each process of the group reads of these channels, from the stack's declared data flow.
  const std::vector<std::string> readers = {"estimator", "planner", "reference_gen", "motion_opt", "wbc", "sim_bullet"};
  std::map<std::string, std::int64_t> before;
  for (const auto& n : readers) before[n] = w.health[n].unauthenticated;
  std::map<std::string, int> sent;
  const auto end = Clock::now() + 1s;
  while (Clock::now() < end) {
    for (const auto& c : channels) {
      std::vector<std::uint8_t> b = w.bytes[c];
      b[random() % b.size()] ^= static_cast<std::uint8_t>(1U << (random() % 8));
      w.lcm().publish(c, b.data(), static_cast<unsigned>(b.size()));
      ++sent[c];
    }
    w.wait_for([] { return false; }, 2ms);
  }
  const std::int64_t at_flips = w.command.tick;
  EXPECT_TRUE(chain_runs(w, at_flips, 2000, 60s)) << "the chain stalled after the bit flips: tick " << w.command.tick;
  EXPECT_FALSE(w.truth.fallen) << "the robot fell";
  EXPECT_GT(w.truth.p_WB[2], 0.8) << "the pelvis sank";
  EXPECT_FALSE(w.first_damp.has_value()) << "the supervisor damped: " << w.damp_reason;
  // The flipped copies each reader took in are refused by their code: at least half of them (see above).
  std::map<std::string, std::int64_t> expected;
  for (const auto& n : readers) {
    const hpr::Ports* p = hpr::graph::find_process(n);
    ASSERT_NE(p, nullptr) << n;
    for (const auto& read : p->reads) {
      if (sent.count(std::string(read.channel)) != 0) expected[n] += sent[std::string(read.channel)];
    }
    EXPECT_GT(expected[n], 0) << n << " reads none of the flipped channels";
  }
  const auto counted = [&] {
    for (const auto& n : readers) {
      if (2 * (w.health[n].unauthenticated - before[n]) < expected[n]) return false;
    }
    return true;
  };
  EXPECT_TRUE(w.wait_for(counted, 5s)) << [&] {
    std::string s;
    for (const auto& n : readers) s += n + " refused " + std::to_string(w.health[n].unauthenticated - before[n]) + " of " + std::to_string(expected[n]) + "; ";
    return s;
  }();
  for (const auto& n : readers) EXPECT_LE(w.health[n].unauthenticated - before[n], expected[n]) << n << " counted a copy twice";
  for (const auto& n : readers) {
    const std::string log = g.log(n);
    EXPECT_NE(log.find("no valid authentication code"), std::string::npos) << n << " did not say why:\n" << log;
    EXPECT_EQ(log.find("following tick"), std::string::npos) << n << " followed a flipped copy:\n" << log;
  }
}

// The backend restarted under the standing robot after each kind of probe, again and again: every
// restart resumes standing (the new simulator is a new source, which every reader follows and the
// estimator starts again from, carrying nothing across), and the robot stands 1.5 s after it. 20
// tries in the real-time group (label hil), 4 in lockstep.
#ifdef HPR_FAULTS_REALTIME
constexpr int kRestartTries = 20;
#else
constexpr int kRestartTries = 4;
#endif

FAULTS_TEST(TheBackendRestartedAfterEachProbeResumesStanding) {
  Running r;
  ASSERT_TRUE(r.started(1000));
  Watch& w = r.w;
  Group& g = r.g;
  std::mt19937_64 random(5);
  int resumed = 0;
  std::string failures;
  for (int attempt = 0; attempt < kRestartTries; ++attempt) {
    w.catch_up();
    const int probe = attempt % 4;
    if (probe == 0) {  // one sample 200 ticks and 2^58 us ahead
      humanoid::robot_sensors_t s = w.sensors;
      s.tick += 200;
      s.utime += std::int64_t{1} << 58;
      as_the_sender_ahead(s);
      w.publish("ROBOT_SENSORS", s);
    } else if (probe == 1) {  // a second sender a tick ahead of the live one
      for (int k = 0; k < 20; ++k) {
        humanoid::robot_sensors_t s = w.sensors;
        s.source = (std::int64_t{0x5eed} << 32) | k;
        s.tick += 1;
        w.publish("ROBOT_SENSORS", s);
        w.wait_for([] { return false; }, 2ms);
      }
    } else if (probe == 2) {  // commands without the key
      humanoid::joint_command_t c = w.command;
      c.tick += 1;
      std::fill(c.kp.begin(), c.kp.end(), 0.0);
      w.publish_unsigned("JOINT_COMMAND", c);
      humanoid::operator_t op{};
      op.source = "intruder";
      op.command = humanoid::operator_t::COMMAND_DAMP;
      w.publish_unsigned("OPERATOR", op);
    } else {  // one random bit flipped in each of 100 copies of the live sample
      for (int k = 0; k < 100; ++k) {
        std::vector<std::uint8_t> bytes(static_cast<std::size_t>(w.sensors.getEncodedSize()));
        w.sensors.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        bytes[random() % bytes.size()] ^= static_cast<std::uint8_t>(1U << (random() % 8));
        w.lcm().publish("ROBOT_SENSORS", bytes.data(), static_cast<unsigned>(bytes.size()));
        if (k % 10 == 0) w.wait_for([] { return false; }, 1ms);
      }
    }
    if (!chain_runs(w, w.command.tick, 300, 30s) || w.truth.fallen) {
      failures += "try " + std::to_string(attempt) + ": the probe alone stopped the chain or felled the robot\n";
      break;
    }
    const std::int64_t before = w.truth.tick;
    if (g.restart("sim_bullet") != 0) {
      failures += "try " + std::to_string(attempt) + ": supervisor restart failed\n";
      continue;
    }
    const bool restarted = w.wait_for([&] { return w.truth.tick < before - 100; }, 30s);
    // Then the chain answers the new clock (the command's tick is the sample's) for a simulated second
    // and a half.
    const bool stood = restarted && w.wait_for([&] {
      return w.truth.fallen || (w.truth.tick >= 1500 && std::abs(w.command.tick - w.truth.tick) <= 5 &&
                                w.command.mode == humanoid::joint_command_t::MODE_RUN);
    }, 60s);
    if (stood && !w.truth.fallen && w.truth.p_WB[2] > 0.8) {
      ++resumed;
    } else {
      failures += "try " + std::to_string(attempt) + " (probe " + std::to_string(probe) + "): " +
                  (restarted ? "" : "no restart; ") + "SIM_TRUTH tick " + std::to_string(w.truth.tick) + (w.truth.fallen ? " fallen" : "") +
                  ", JOINT_COMMAND tick " + std::to_string(w.command.tick) + " mode " + std::to_string(int{w.command.mode}) + "\n";
      if (w.truth.fallen) break;  // the next tries would start from a fallen robot
    }
  }
  EXPECT_EQ(resumed, kRestartTries) << failures << "estimator log:\n" << g.log("estimator").substr(0, 4000);
}

// The group's hang watch for the wbc: 0.05 s in the real-time group, 0.5 s in the lockstep group
// (config/groups.yaml), and a watched node sends HEALTH four times per hung_after. A hang is a
// silence longer than hung_after since the last HEALTH, which left up to one period (a quarter of
// hung_after) before the stop, or more when it was late: the damp follows the stop by about 3/4 to
// 1 hung_after, plus the supervisor's reaction.
#ifdef HPR_FAULTS_REALTIME
constexpr double kWbcHungAfterS = 0.05;
#else
constexpr double kWbcHungAfterS = 0.5;
#endif

/// What the chain last said, for a failure message.
std::string chain_said(const Watch& w) {
  return "last JOINT_COMMAND tick " + std::to_string(w.command.tick) + " mode " + std::to_string(int{w.command.mode}) +
         (w.first_damp ? "; damped by the supervisor: " + w.damp_reason : "; no damp");
}

// A SIGSTOPped wbc sends no HEALTH: the supervisor judges it hung after hung_after and damps, not
// before half of hung_after (a premature damp is as wrong as a late one) and within 2 hung_after. The
// lockstep build checks the mechanism end to end on any machine; the real-time build (label hil)
// checks the 100 ms of the real-time group, which needs the chain's two cores to itself.
FAULTS_TEST(AStoppedWbcIsHungAndTheSupervisorDampsWithinTwiceItsHangTime) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s)) << "the chain did not start: " << chain_said(w) << "\nsupervisor log:\n" << g.log("supervisor");
  ASSERT_FALSE(w.first_damp.has_value()) << chain_said(w);
  const int wbc = g.pid("wbc");
  ASSERT_GT(wbc, 0);
  const auto stopped = Clock::now();
  ASSERT_EQ(::kill(wbc, SIGSTOP), 0);
  const bool damped = w.wait_for([&] { return w.first_damp.has_value(); }, 5s);
  ::kill(wbc, SIGCONT);
  ASSERT_TRUE(damped) << "no OPERATOR damp after SIGSTOP of the wbc";
  const double s = std::chrono::duration<double>(*w.first_damp - stopped).count();
  std::cout << "SIGSTOP of the wbc to OPERATOR damp: " << s * 1e3 << " ms (hung_after " << kWbcHungAfterS * 1e3 << " ms)\n";
  EXPECT_GE(s, 0.5 * kWbcHungAfterS);
  EXPECT_LT(s, 2.0 * kWbcHungAfterS);
  EXPECT_NE(w.damp_reason.find("wbc (critical) hung"), std::string::npos) << w.damp_reason;
  // Once running again the wbc obeys the damp: its commands damp, and its lifecycle says so.
  EXPECT_TRUE(w.wait_for([&] { return w.command.mode == humanoid::joint_command_t::MODE_DAMP; }, 10s)) << chain_said(w);
  EXPECT_TRUE(w.wait_for([&] { return w.health["wbc"].lifecycle == humanoid::health_t::LIFECYCLE_DAMPING; }, 5s))
      << "wbc lifecycle " << static_cast<int>(w.health["wbc"].lifecycle);
  EXPECT_EQ(static_cast<int>(w.health["estimator"].lifecycle), int{humanoid::health_t::LIFECYCLE_RUNNING});
}

// The attack on the supervisor: while the wbc is stopped, HEALTH in its name saying "ok, running"
// every 20 ms, without the key and with it but from another process. The supervisor takes neither
// (HEALTH is signed, and taken only from the pid it started under that name) and still damps.
FAULTS_TEST(AForgedHealthForAHungWbcDoesNotKeepTheSupervisorFromDamping) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s)) << "the chain did not start: " << chain_said(w);
  const int wbc = g.pid("wbc");
  ASSERT_GT(wbc, 0);
  humanoid::health_t forged = w.health["wbc"];
  ASSERT_EQ(forged.node, "wbc");
  forged.state = humanoid::health_t::STATE_OK;
  forged.lifecycle = humanoid::health_t::LIFECYCLE_RUNNING;
  forged.pid = static_cast<std::int32_t>(::getpid());
  humanoid::health_t unsigned_copy = forged;
  unsigned_copy.pid = wbc;  // the right pid, but no code
  const auto stopped = Clock::now();
  ASSERT_EQ(::kill(wbc, SIGSTOP), 0);
  auto next = Clock::now();
  const bool damped = w.wait_for(
      [&] {
        if (Clock::now() >= next) {  // every 20 ms, as often as a node sends HEALTH and more
          next += 20ms;
          forged.utime = hpr::wall_us();
          unsigned_copy.utime = forged.utime;
          w.publish("HEALTH", forged);
          w.publish_unsigned("HEALTH", unsigned_copy);
        }
        return w.first_damp.has_value();
      },
      5s);
  ::kill(wbc, SIGCONT);
  ASSERT_TRUE(damped) << "the forged HEALTH kept the supervisor from damping";
  const double s = std::chrono::duration<double>(*w.first_damp - stopped).count();
  EXPECT_LT(s, 2.0 * kWbcHungAfterS);
  EXPECT_NE(w.damp_reason.find("wbc (critical) hung"), std::string::npos) << w.damp_reason;
  EXPECT_NE(g.log("supervisor").find("HEALTH of wbc from pid " + std::to_string(::getpid()) + " ignored"), std::string::npos)
      << g.log("supervisor");
}

// A node reports what it does: with the estimator killed, the wbc (stepped by ROBOT_STATE) says
// within seconds that it is not stepping and waits, instead of "ok, running".
FAULTS_TEST(AKilledEstimatorLeavesTheWbcReportingThatItWaits) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s)) << "the chain did not start: " << chain_said(w);
  ASSERT_EQ(static_cast<int>(w.health["wbc"].lifecycle), int{humanoid::health_t::LIFECYCLE_RUNNING});
  const int estimator = g.pid("estimator");
  ASSERT_GT(estimator, 0);
  ASSERT_EQ(::kill(estimator, SIGKILL), 0);
  const auto said = [&] {
    const humanoid::health_t& h = w.health["wbc"];
    const bool not_stepping = std::any_of(h.faults.begin(), h.faults.end(), [](const std::string& f) { return f.find("not stepping") == 0; });
    return h.lifecycle == humanoid::health_t::LIFECYCLE_WAITING && h.state == humanoid::health_t::STATE_DEGRADED && not_stepping;
  };
  EXPECT_TRUE(w.wait_for(said, 5s)) << "wbc lifecycle " << static_cast<int>(w.health["wbc"].lifecycle) << ", state "
                                    << static_cast<int>(w.health["wbc"].state);
}

// The planner is critical (config/groups.yaml): the wbc has no plan to follow without it. Killed,
// the supervisor damps the robot at once, and the wbc's commands damp.
FAULTS_TEST(AKilledPlannerDampsTheRobot) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s)) << "the chain did not start: " << chain_said(w);
  ASSERT_FALSE(w.first_damp.has_value()) << chain_said(w);
  const int planner = g.pid("planner");
  ASSERT_GT(planner, 0);
  ASSERT_EQ(::kill(planner, SIGKILL), 0);
  ASSERT_TRUE(w.wait_for([&] { return w.first_damp.has_value(); }, 5s)) << "no OPERATOR damp after the planner died: " << chain_said(w);
  EXPECT_NE(w.damp_reason.find("planner (critical)"), std::string::npos) << w.damp_reason;
  EXPECT_TRUE(w.wait_for([&] { return w.command.mode == humanoid::joint_command_t::MODE_DAMP; }, 20s)) << chain_said(w);
  EXPECT_TRUE(w.wait_for([&] { return w.health["wbc"].lifecycle == humanoid::health_t::LIFECYCLE_DAMPING; }, 5s))
      << "wbc lifecycle " << static_cast<int>(w.health["wbc"].lifecycle);
}

FAULTS_TEST(WithoutItsOptionalComponentsTheChainRunsOnAtFullRate) {
  const std::string url = hpr::test::unique_lcm_url();
  Watch w(url);
  Group g(url);
  ASSERT_TRUE(g.up()) << g.up_text();
  ASSERT_TRUE(chain_runs(w, 0, 500, 30s));
  // reference_gen dies: motion_opt runs on without CAM_REFERENCE.
  ASSERT_EQ(::kill(g.pid("reference_gen"), SIGKILL), 0);
  std::int64_t from = w.command.tick;
  EXPECT_TRUE(chain_runs(w, from, 1000, 15s)) << "the chain crawls without reference_gen: tick " << w.command.tick;
  // motion_opt dies too: the wbc follows the balance plan itself (the ankle strategy).
  ASSERT_EQ(::kill(g.pid("motion_opt"), SIGKILL), 0);
  from = w.command.tick;
  EXPECT_TRUE(chain_runs(w, from, 1000, 15s)) << "the chain crawls without motion_opt: tick " << w.command.tick;
  // Full rate: HEALTH's step rate, and the wbc says what it runs without.
  ASSERT_TRUE(w.wait_for([&] { return w.health["wbc"].rate_hz > 100.0; }, 5s)) << "wbc at " << w.health["wbc"].rate_hz << " Hz";
  // Its component says so once the command is stale (wholebody_stale_ticks), its runtime once the
  // input has been silent for its timeout; HEALTH goes out at its own rate: waited for.
  const auto says = [&] {
    const auto& faults = w.health["wbc"].faults;
    return std::any_of(faults.begin(), faults.end(), [](const std::string& f) { return f.find("WHOLEBODY_COMMAND stale") != std::string::npos; }) &&
           std::any_of(faults.begin(), faults.end(), [](const std::string& f) { return f.find("WHOLEBODY_COMMAND absent") != std::string::npos; });
  };
  EXPECT_TRUE(w.wait_for(says, 5s)) << "wbc HEALTH does not say that WHOLEBODY_COMMAND is stale and absent";
  EXPECT_EQ(int{w.health["wbc"].state}, int{humanoid::health_t::STATE_DEGRADED});
  EXPECT_FALSE(w.truth.fallen);
}

}  // namespace
