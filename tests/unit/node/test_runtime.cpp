// The node runtime's tick streams, in one process over LCM's in-memory provider: a forged tick is
// held back and counted, a restarted source is followed after the quiet time, and a trigger then
// steps the new stream.
#include <gtest/gtest.h>

#include <humanoid/balance_status_t.hpp>
#include <humanoid/health_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <optional>
#include <thread>
#include <vector>

#include "all_types.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/node/runtime.hpp"

namespace {

using hpr::node::Runtime;
using hpr::node::RuntimeOptions;

// The channels these tests read and write, all declared by one test process.
constexpr hpr::Channel<humanoid::robot_sensors_t> kSensors{"SENSORS"}, kState{"STATE"}, kOperatorLike{"OPERATOR_LIKE"}, kS{"S"};
constexpr hpr::Channel<humanoid::balance_status_t> kBalance{"BALANCE"}, kMarked{"MARKED"};
constexpr hpr::Channel<humanoid::operator_t> kOperator{"OPERATOR"};
constexpr hpr::Channel<humanoid::health_t> kHealth{"HEALTH"};
constexpr hpr::Read test_read(std::string_view channel) { return {channel, 0, false, false, "a test's input"}; }
constexpr hpr::Read kTestReads[] = {test_read("SENSORS"), test_read("STATE"),  test_read("OPERATOR_LIKE"), test_read("S"),
                                    test_read("BALANCE"), test_read("MARKED"), test_read("OPERATOR"),      test_read("HEALTH")};
constexpr std::string_view kTestWrites[] = {"SENSORS", "STATE", "OPERATOR_LIKE", "S", "BALANCE", "MARKED", "OPERATOR"};
constexpr hpr::Ports kTestPorts{.name = "test", .reads = kTestReads, .writes = kTestWrites};

/// Publishes `m` as it is (its own source, unsigned or signed with `key`): another sender on `channel`.
template <class Msg>
void inject(Runtime& rt, std::string_view channel, const Msg& m, const hpr::auth::Key* key = nullptr) {
  std::vector<std::uint8_t> bytes;
  const int n = hpr::node::encode_message(m, bytes, rt.transport().channel(channel), key);
  ASSERT_GT(n, 0);
  rt.transport().publish_bytes(channel, bytes.data(), static_cast<std::size_t>(n));
}

class TickStream : public ::testing::Test {
 protected:
  static RuntimeOptions options() {
    RuntimeOptions o;
    o.tick_window = 100;
    o.source_quiet_s = 0.05;
    o.health_period_s = 10.0;
    o.authenticate = false;  // the stream rules, with unsigned samples (Authentication.* covers the codes)
    return o;
  }

  /// A sample of `tick` at 1 ms per tick, or at `utime` [us], from publisher `source` (its identity,
  /// the upper 32 bits; a stamped one gets the next message count in the lower 32, as a publisher's
  /// Output stamps it). Returns the source sent.
  std::int64_t send(std::int64_t tick, const std::string& channel = "SENSORS", std::optional<std::int64_t> utime = {},
                    std::int64_t source = 0) {
    humanoid::robot_sensors_t m{};
    m.tick = tick;
    m.utime = utime.value_or(tick * 1000);
    m.source = hpr::node::source_identity(source) == 0 ? source : static_cast<std::int64_t>((static_cast<std::uint64_t>(source) >> 32 << 32) | ++counter);
    inject(rt, channel, m);
    rt.spin_once(0.0);
    return m.source;
  }
  /// A sample sent with `source` exactly as it is (a recording played back).
  void send_exactly(std::int64_t tick, std::int64_t source) {
    humanoid::robot_sensors_t m{};
    m.tick = tick;
    m.utime = tick * 1000;
    m.source = source;
    inject(rt, "SENSORS", m);
    rt.spin_once(0.0);
  }
  void send_balance(std::int64_t tick) {
    humanoid::balance_status_t m{};
    m.tick = tick;
    inject(rt, "BALANCE", m);
    rt.spin_once(0.0);
  }

  Runtime rt{kTestPorts, "test", "memq://", options()};
  hpr::node::Input<humanoid::robot_sensors_t>& sensors = rt.subscribe(kSensors);
  std::vector<std::int64_t> stepped;
  std::uint32_t counter = 0;
};

TEST_F(TickStream, AForgedFutureTickIsHeldCountedAndNeverStepped) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 10; ++k) send(k);
  send(1'000'000'000);
  for (int k = 11; k <= 20; ++k) send(k);
  ASSERT_EQ(stepped.size(), 20U);
  for (int k = 1; k <= 20; ++k) EXPECT_EQ(stepped[static_cast<std::size_t>(k - 1)], k);
  EXPECT_EQ(sensors.out_of_window(), 1);
  EXPECT_EQ(sensors.errors(), 1);
  EXPECT_EQ(rt.decode_errors(), 1);
  EXPECT_NE(sensors.last_error().find("tick 1000000000 is 999999990 ahead of the last tick 10"), std::string::npos)
      << sensors.last_error();
  EXPECT_EQ(sensors.latest().tick, 20);
  // The live stream kept arriving, so the forged tick is never followed, however long we wait.
  rt.spin_until([] { return false; }, 0.2);
  EXPECT_EQ(sensors.follows(), 0);
  EXPECT_EQ(stepped.back(), 20);
}

// The probe that felled the robot: one sample 200 ticks ahead (inside the window) whose time is
// 2^58 us ahead. Were it accepted, every real sample after it would be "time does not advance".
TEST_F(TickStream, ASampleWhoseTimeIsImplausibleForItsTickIsHeldAndTheRealStreamRunsOn) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 10; ++k) send(k);
  send(60, "SENSORS", std::int64_t{1} << 58);
  for (int k = 11; k <= 20; ++k) send(k);
  ASSERT_EQ(stepped.size(), 20U);
  EXPECT_EQ(stepped.back(), 20);
  EXPECT_EQ(sensors.latest().utime, 20'000);
  EXPECT_EQ(sensors.implausible_times(), 1);
  EXPECT_EQ(sensors.out_of_window(), 1);
  EXPECT_EQ(rt.decode_errors(), 1);
  EXPECT_NE(sensors.last_error().find("at tick 60 is 2.8823e+11 s ahead of 0.010000 s at tick 10"), std::string::npos)
      << sensors.last_error();
  rt.spin_until([] { return false; }, 0.2);
  EXPECT_EQ(sensors.follows(), 0) << "the live stream ran: the forged sample is never followed";
}

TEST_F(TickStream, ATimeThatGoesBackIsHeldAsIsOneTooFarAheadForItsTicks) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  send(100);
  send(101, "SENSORS", 99'000);  // 2 ms back
  // 0.5 s ahead in 5 ticks: more than 5 x 10 ms + the wall time since tick 100 + 50 ms.
  send(105, "SENSORS", 100'000 + 500'000);
  EXPECT_EQ(stepped, (std::vector<std::int64_t>{100}));
  EXPECT_EQ(sensors.implausible_times(), 2);
  EXPECT_NE(sensors.last_error().find("ahead of 0.100000 s at tick 100"), std::string::npos) << sensors.last_error();
  // What a lockstep source does (1 ms per tick, whatever the wall clock) and what a real-time one
  // does after a stall (its clock ran with the wall clock) are both followed at once.
  for (int k = 102; k <= 110; ++k) send(k);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  send(111, "SENSORS", 110'000 + 300'000);
  send(112, "SENSORS", 110'000 + 301'000);
  EXPECT_EQ(stepped.back(), 112);
  EXPECT_EQ(sensors.implausible_times(), 2);
}

TEST_F(TickStream, ATickWithinTheWindowIsAcceptedOneBeyondIsNot) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  send(1);
  send(101);  // exactly the window ahead
  send(202);  // one beyond
  EXPECT_EQ(stepped, (std::vector<std::int64_t>{1, 101}));
  EXPECT_EQ(sensors.out_of_window(), 1);
}

TEST_F(TickStream, ARestartedSourceIsFollowedAfterTheQuietTime) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 500; ++k) send(k);
  ASSERT_EQ(stepped.back(), 500);
  // The source restarts at tick 0 and publishes once (a lockstep source then waits for its answer).
  send(0);
  EXPECT_EQ(stepped.back(), 500) << "followed before the old stream was quiet";
  EXPECT_EQ(sensors.out_of_window(), 1);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  EXPECT_EQ(stepped.back(), 0);
  for (int k = 1; k <= 5; ++k) send(k);
  EXPECT_EQ(stepped.back(), 5);
  EXPECT_EQ(sensors.out_of_window(), 1);
}

// A second sender on the channel (a stray simulator, a forger with its own identity) whose ticks and
// times continue the stream plausibly: held and counted, never stepped while the followed source
// lives; once that one has been quiet for source_quiet_s, the new source is followed (a restart).
TEST_F(TickStream, ASecondSourceInsideTheWindowIsHeldUntilTheFollowedOneIsQuiet) {
  constexpr std::int64_t kReal = 0x1234, kOther = -77;
  int restarts = 0;
  rt.on_restart(sensors, [&] { ++restarts; });
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 100; ++k) send(k, "SENSORS", {}, kReal);
  EXPECT_EQ(sensors.source(), kReal);  // unstamped: no counter
  for (int k = 101; k <= 200; ++k) {
    send(k + 1, "SENSORS", {}, kOther);  // one tick ahead of the real one: in the window, a plausible time
    send(k, "SENSORS", {}, kReal);
  }
  ASSERT_EQ(stepped.size(), 200U);
  for (int k = 1; k <= 200; ++k) ASSERT_EQ(stepped[static_cast<std::size_t>(k - 1)], k);
  EXPECT_EQ(sensors.second_sources(), 100);
  EXPECT_EQ(sensors.out_of_window(), 100);
  EXPECT_EQ(sensors.follows(), 0);
  EXPECT_NE(sensors.last_error().find("source ffffffff is not the stream's source 00000000"), std::string::npos)
      << sensors.last_error();
  EXPECT_TRUE(rt.has_fault("decode:SENSORS"));
  // The real source stops and the other goes on: it is followed once the stream has been quiet long enough.
  send(202, "SENSORS", {}, kOther);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  EXPECT_EQ(hpr::node::source_identity(sensors.source()), hpr::node::source_identity(kOther));
  EXPECT_EQ(restarts, 1);
  EXPECT_EQ(stepped.back(), 202);
  send(203, "SENSORS", {}, kOther);
  EXPECT_EQ(stepped.back(), 203);
}

// The attack: the stream recorded (signed, with its sources and consistent ticks and times), then
// played back while the real source is stopped for 0.5 s: the live source's own past (its counter is
// behind the latest taken) and the process before its restart (a source the input left). Never
// followed, each message counted; the real source, back, runs on.
TEST_F(TickStream, ARecordedStreamPlayedWhileTheSourceIsStoppedIsNeverFollowed) {
  constexpr std::int64_t kBefore = std::int64_t{0x0badc0de} << 32, kLive = std::int64_t{0x5eed} << 32;
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  std::vector<std::pair<std::int64_t, std::int64_t>> recording;  // (tick, source) as sent
  for (int k = 1; k <= 300; ++k) recording.emplace_back(k, send(k, "SENSORS", {}, kBefore));
  // The source restarts (a new identity) and is followed.
  send(0, "SENSORS", {}, kLive);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  for (int k = 1; k <= 300; ++k) recording.emplace_back(k, send(k, "SENSORS", {}, kLive));
  ASSERT_EQ(stepped.back(), 300);
  // Stopped for 0.5 s; meanwhile the recording is played, message by message, both sources.
  const double end = hpr::monotonic_s() + 0.5;
  std::int64_t played = 0;
  for (std::size_t k = 0; hpr::monotonic_s() < end; k = (k + 7) % recording.size()) {
    send_exactly(recording[k].first, recording[k].second);
    ++played;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  EXPECT_EQ(stepped.back(), 300) << "a replayed tick was stepped";
  EXPECT_EQ(sensors.follows(), 1) << "the recording was followed";
  EXPECT_EQ(hpr::node::source_identity(sensors.source()), hpr::node::source_identity(kLive));
  EXPECT_EQ(sensors.replays(), played);
  EXPECT_NE(sensors.last_error().find("a replay, never followed"), std::string::npos) << sensors.last_error();
  send(301, "SENSORS", {}, kLive);
  EXPECT_EQ(stepped.back(), 301);
}

// A process whose upstream restarted goes on with its own identity and counter while its ticks go
// back: followed, not taken for a replay.
TEST_F(TickStream, TheSameSourceWhoseTicksGoBackWithItsCounterAheadIsFollowed) {
  constexpr std::int64_t kEstimator = std::int64_t{0x0e57} << 32;
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 500; ++k) send(k, "SENSORS", {}, kEstimator);
  send(0, "SENSORS", {}, kEstimator);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  EXPECT_EQ(stepped.back(), 0);
  EXPECT_EQ(sensors.replays(), 0);
}

// What a process publishes carries its identity, at the offset the readers' rule assumes, for every
// clocked type; the other types have no source.
TEST(SourceIdentity, OutputsStampTheProcessIdentityOnEveryClockedType) {
  Runtime a{kTestPorts, "a", "memq://", RuntimeOptions{}};
  Runtime b{kTestPorts, "b", "memq://", RuntimeOptions{}};
  EXPECT_NE(a.source_id(), 0);
  EXPECT_NE(a.source_id(), b.source_id());
  auto out = a.advertise(kS);
  auto& in = a.subscribe(kS);
  humanoid::robot_sensors_t m{};
  m.tick = 3;
  m.source = 99;  // whatever the message holds, the process's identity goes out
  out.publish(m);
  a.spin_once(0.0);
  ASSERT_EQ(in.count(), 1);
  // The identity in the upper 32 bits, the process's message count (its first message) in the lower.
  EXPECT_EQ(in.latest().source, a.source_id() | 1);
  EXPECT_EQ(hpr::node::source_counter(a.source_id()), 0U);
  out.publish(m);
  a.spin_once(0.0);
  ASSERT_EQ(in.count(), 2);
  EXPECT_EQ(in.latest().source, a.source_id() | 2) << "the next message, the next count";
  // Every type: a Sourced one decodes the stamped identity (bytes 24-31), with every other field as
  // it was; the list of Sourced types is the clocked channels.
  std::vector<std::string> sourced;
  hpr::test::for_each_type([&]<class Msg>(const std::string& name) {
    hpr::test::Filler filler(11);
    Msg original;
    filler.fill(original);
    std::vector<std::uint8_t> bytes;
    const int n = hpr::node::encode_message(original, bytes, {}, nullptr, std::int64_t{-0x0123456789abcdef});
    ASSERT_GT(n, 0) << name;
    Msg decoded;
    ASSERT_EQ(decoded.decode(bytes.data(), 0, n), n) << name;
    if constexpr (hpr::node::Sourced<Msg>) {
      sourced.push_back(name);
      EXPECT_EQ(decoded.source, -0x0123456789abcdef) << name;
      decoded.source = original.source;
    }
    EXPECT_EQ(hpr::test::encode(decoded), hpr::test::encode(original)) << name << ": another field changed";
  });
  EXPECT_EQ(sourced, (std::vector<std::string>{"ROBOT_SENSORS", "ROBOT_STATE", "BALANCE_STATUS", "CAM_REFERENCE", "WHOLEBODY_COMMAND",
                                               "JOINT_COMMAND", "SIM_TRUTH", "HAL_STATUS", "BALANCE_PLAN"}));
}

TEST_F(TickStream, ASourceThatJumpedAheadIsFollowedOnceTheOldStreamIsQuiet) {
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  for (int k = 1; k <= 10; ++k) send(k);
  // A node stopped for seconds sees its source far ahead: each tick is held until the old stream
  // has been quiet for the quiet time, then the new one is stepped.
  for (int k = 5000; k < 5010; ++k) send(k);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  EXPECT_EQ(stepped.back(), 5009);
  send(5010);
  EXPECT_EQ(stepped.back(), 5010);
}

TEST_F(TickStream, ASyncedInputFromBeforeTheRestartIsNotTakenAsCurrent) {
  auto& balance = rt.subscribe(kBalance);
  std::vector<bool> timed_out;
  rt.on_tick(sensors, {{&balance, 0, {}}}, 0.02, [&](const hpr::node::TickInfo& info) {
    stepped.push_back(info.tick);
    timed_out.push_back(info.timed_out);
  });
  for (int k = 1; k <= 300; ++k) {
    send_balance(k);
    send(k);
  }
  ASSERT_EQ(stepped.size(), 300U);
  EXPECT_FALSE(timed_out.back());
  // Both sources restart. Once the sensor stream is followed, BALANCE's tick 300 (the old stream)
  // must not count as having reached the new tick 0.
  send(0);
  ASSERT_TRUE(rt.spin_until([&] { return sensors.follows() == 1; }, 5.0));
  ASSERT_TRUE(rt.spin_until([&] { return stepped.back() == 0; }, 5.0));
  EXPECT_TRUE(timed_out.back()) << "the old BALANCE tick was taken for the new stream's";
  send_balance(1);
  send(1);
  EXPECT_EQ(stepped.back(), 1);
  EXPECT_FALSE(timed_out.back());
  EXPECT_EQ(balance.tick(), 1);
}

TEST_F(TickStream, AnOptionalInputThatMissedItsTimeoutIsNotWaitedForUntilItIsBack) {
  auto& balance = rt.subscribe(kBalance);
  rt.on_tick(sensors, {{&balance, 0, {}, true}}, 0.2, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  send_balance(1);
  send(1);
  ASSERT_EQ(stepped.back(), 1);
  // BALANCE's source dies: tick 2 waits out the timeout once...
  send(2);
  EXPECT_EQ(stepped.back(), 1) << "stepped without waiting for a live optional input";
  ASSERT_TRUE(rt.spin_until([&] { return stepped.back() == 2; }, 5.0));
  EXPECT_TRUE(rt.has_fault("absent:BALANCE"));
  // ...and later ticks step at once, without it.
  for (int k = 3; k <= 50; ++k) {
    send(k);
    ASSERT_EQ(stepped.back(), k) << "waited for an absent input";
  }
  // It is back: waited for again.
  send_balance(51);
  EXPECT_FALSE(rt.has_fault("absent:BALANCE"));
  send(52);
  EXPECT_EQ(stepped.back(), 50) << "did not wait for tick 52's BALANCE";
  send_balance(52);
  EXPECT_EQ(stepped.back(), 52);
}

TEST_F(TickStream, AnInputThatIsNotOptionalIsWaitedForEveryTick) {
  auto& balance = rt.subscribe(kBalance);
  rt.on_tick(sensors, {{&balance, 0, {}}}, 0.3, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  send_balance(1);
  send(1);
  for (int k = 2; k <= 4; ++k) {
    send(k);
    EXPECT_EQ(stepped.back(), k - 1);
    ASSERT_TRUE(rt.spin_until([&] { return stepped.back() == k; }, 5.0));
  }
  EXPECT_FALSE(rt.has_fault("absent:BALANCE"));
}

TEST_F(TickStream, InputsThatAreNotStreamsAcceptAnyTick) {
  auto& other = rt.subscribe(kOperatorLike);
  send(100, "OPERATOR_LIKE");
  send(3, "OPERATOR_LIKE");  // another sender's counter
  send(1'000'000, "OPERATOR_LIKE");
  EXPECT_EQ(other.count(), 3);
  EXPECT_EQ(other.errors(), 0);
}

TEST_F(TickStream, ARepeatOfAWaitingTickIsDroppedSoTheStepUsesTheFirstMessage) {
  // A node whose validator decodes into its own state (as the wbc's does), and whose step waits
  // for BALANCE only while that state is usable (utime >= 0 here), as the wbc waits for the motion
  // optimiser's command only on a usable estimate. The mark (imu_gyro_B[0]: 1 usable, -1 flagged)
  // stands for the estimator's status; the copy's time is its tick's, as a republished sample's is.
  double state_mark = 0;
  auto& state = rt.subscribe(kState, [&](const humanoid::robot_sensors_t& m) {
    state_mark = m.imu_gyro_B[0];
    return std::string();
  });
  auto& balance = rt.subscribe(kBalance);
  std::vector<double> used_mark;
  rt.on_tick(state, {{&balance, 0, [&] { return state_mark >= 0; }}}, 10.0, [&](const hpr::node::TickInfo& info) {
    stepped.push_back(info.tick);
    used_mark.push_back(state_mark);
  });
  const auto send_state = [&](std::int64_t tick, double mark) {
    humanoid::robot_sensors_t m{};
    m.tick = tick;
    m.utime = tick * 1000;
    m.imu_gyro_B[0] = mark;
    inject(rt, "STATE", m);
    rt.spin_once(0.0);
  };
  send_state(1, 1);
  send_balance(1);
  ASSERT_EQ(stepped, (std::vector<std::int64_t>{1}));
  // Tick 2 waits for BALANCE; meanwhile its source republishes tick 2 flagged unusable (a sensor
  // timeout on a slow round). The step must neither run early nor see the flagged copy.
  send_state(2, 2);
  send_state(2, -1);
  send_state(2, -1);
  EXPECT_EQ(stepped.size(), 1U) << "the repeat released the waiting step";
  EXPECT_EQ(state.repeats(), 2);
  EXPECT_EQ(state.count(), 2);
  send_balance(2);
  ASSERT_EQ(stepped, (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(used_mark.back(), 2);
  // Once tick 2 has stepped, a repeat is taken as the latest message (nothing waits on it) and
  // steps nothing.
  send_state(2, -1);
  EXPECT_EQ(state.repeats(), 2);
  EXPECT_EQ(state.count(), 3);
  EXPECT_EQ(state_mark, -1);
  EXPECT_EQ(stepped.size(), 2U);
  // A first message that is unusable is the tick's message: the step runs at once without BALANCE.
  send_state(3, -1);
  EXPECT_EQ(stepped, (std::vector<std::int64_t>{1, 2, 3}));
  EXPECT_EQ(used_mark.back(), -1);
}

}  // namespace

namespace {

TEST_F(TickStream, AStepSeesWhatTheCallbackOfTheMessageThatReleasedItDid) {
  // The wbc marks the motion optimiser's command as received in its callback and uses it in the
  // step that command releases: the callback runs before that step, also for the very first message.
  bool have_balance = false;
  auto& marked = rt.subscribe(kMarked, {}, [&](const humanoid::balance_status_t&) { have_balance = true; });
  std::vector<bool> had;
  rt.on_tick(sensors, {{&marked, 0, {}}}, 10.0, [&](const hpr::node::TickInfo& info) {
    stepped.push_back(info.tick);
    had.push_back(have_balance);
  });
  send(0);
  EXPECT_TRUE(stepped.empty()) << "stepped before its synced input";
  humanoid::balance_status_t m{};
  m.tick = 0;
  inject(rt, "MARKED", m);
  rt.spin_once(0.0);
  ASSERT_EQ(stepped, (std::vector<std::int64_t>{0}));
  EXPECT_TRUE(had[0]) << "the step of tick 0 ran before the callback of the message it waited for";
}

}  // namespace

namespace {

using hpr::node::Lifecycle;
using hpr::node::LifecycleMachine;
using hpr::node::StepOutcome;

TEST(Lifecycle, TheMachineTakesOnlyItsTransitions) {
  LifecycleMachine m;
  EXPECT_EQ(m.state(), Lifecycle::kWaiting);
  EXPECT_FALSE(m.on_restart());  // already waiting
  EXPECT_TRUE(m.on_input());
  EXPECT_EQ(m.state(), Lifecycle::kStarting);
  EXPECT_FALSE(m.on_input());  // input again: no change
  EXPECT_FALSE(m.on_step(StepOutcome::kNotReady));
  EXPECT_TRUE(m.on_step(StepOutcome::kRunning));
  EXPECT_EQ(m.state(), Lifecycle::kRunning);
  EXPECT_TRUE(m.on_step(StepOutcome::kDamping));
  EXPECT_EQ(m.state(), Lifecycle::kDamping);
  EXPECT_TRUE(m.on_step(StepOutcome::kRunning));
  EXPECT_TRUE(m.on_restart());
  EXPECT_EQ(m.state(), Lifecycle::kWaiting);
  EXPECT_TRUE(m.on_stop());
  EXPECT_EQ(m.state(), Lifecycle::kStopped);
  // Stopped is final.
  EXPECT_FALSE(m.on_input());
  EXPECT_FALSE(m.on_step(StepOutcome::kRunning));
  EXPECT_FALSE(m.on_restart());
  EXPECT_EQ(m.state(), Lifecycle::kStopped);
  EXPECT_EQ(m.transitions(), 6);
  EXPECT_STREQ(hpr::node::to_string(Lifecycle::kDamping), "damping");
}

// A component's report (hpr/common/component.hpp) applied to HEALTH: raised faults set with their
// text, cleared ones cleared, the others left; the outcome drives the lifecycle, and a running
// outcome does not undo what an earlier component of the same step reported.
TEST_F(TickStream, AComponentsReportSetsClearsAndLeavesItsFaultsAndDrivesTheLifecycle) {
  static constexpr std::array<std::string_view, 2> kKeys{"motion_qp", "reference"};
  hpr::StepReport first(kKeys), second(kKeys);
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo&) {
    rt.report(first);
    rt.report(second);
  });
  first.begin();
  second.begin();
  first.raise("motion_qp", "motion QP failed ({})", "max iterations");
  first.raise("reference", "CAM_REFERENCE stale");
  first.outcome = StepOutcome::kNotReady;
  send(1);
  EXPECT_EQ(rt.fault_text("motion_qp"), "motion QP failed (max iterations)");
  EXPECT_TRUE(rt.has_fault("reference"));
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kStarting) << "the second report, running, left the first's not-ready";
  first.begin();
  first.clear("motion_qp");
  send(2);
  EXPECT_FALSE(rt.has_fault("motion_qp"));
  EXPECT_TRUE(rt.has_fault("reference")) << "left as it was";
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kRunning);
  first.begin();
  second.set("reference", false, "");
  second.outcome = StepOutcome::kDamping;
  send(3);
  EXPECT_FALSE(rt.has_fault("reference"));
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kDamping);
}

TEST_F(TickStream, TheLifecycleFollowsTheStepsAndARestartedSource) {
  StepOutcome next = StepOutcome::kNotReady;
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) {
    stepped.push_back(info.tick);
    if (next != StepOutcome::kRunning) rt.report(next);  // a step that reports nothing was running
  });
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kWaiting);
  send(1);
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kStarting) << "stepped, not ready";
  next = StepOutcome::kRunning;
  send(2);
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kRunning);
  next = StepOutcome::kDamping;
  send(3);
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kDamping);
  next = StepOutcome::kRunning;
  send(4);
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kRunning);
  // The source restarts from tick 0: once followed, the node waits for its next step.
  send(0);
  rt.spin_until([&] { return sensors.follows() > 0; }, 1.0);
  ASSERT_EQ(sensors.follows(), 1);
  EXPECT_EQ(stepped.back(), 0) << "the restarted stream's tick was stepped";
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kRunning) << "followed, then stepped";
  rt.request_stop();
  rt.publish_health();
  EXPECT_EQ(rt.lifecycle(), Lifecycle::kStopped);
}

}  // namespace

namespace {

// With a busy-poll window the runtime still steps every tick in order, and centres the window on
// the next tick's arrival estimated from the intervals (1 ms here, give or take the machine).
TEST(BusyPoll, EveryTickIsSteppedAndTheNextArrivalIsEstimated) {
  RuntimeOptions o;
  o.health_period_s = 10.0;
  o.spin_s = 2e-4;
  o.authenticate = false;
  Runtime rt{kTestPorts, "test", "memq://", o};
  auto& sensors = rt.subscribe(kSensors);
  std::vector<std::int64_t> stepped;
  rt.on_tick(sensors, {}, 0.0, [&](const hpr::node::TickInfo& info) { stepped.push_back(info.tick); });
  EXPECT_EQ(rt.next_arrival(), 0.0) << "no estimate before two arrivals";
  for (int k = 1; k <= 50; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    humanoid::robot_sensors_t m{};
    m.tick = k;
    inject(rt, "SENSORS", m);
    rt.spin_once(0.0);
  }
  ASSERT_EQ(stepped.size(), 50U);
  for (int k = 1; k <= 50; ++k) EXPECT_EQ(stepped[static_cast<std::size_t>(k - 1)], k);
  const double ahead = rt.next_arrival() - sensors.receive_time();
  EXPECT_GT(ahead, 0.2e-3);
  EXPECT_LT(ahead, 20e-3);
  // Polling through a window in which nothing arrives returns (the test would hang otherwise) and
  // steps nothing.
  rt.spin_once(1.0);
  EXPECT_EQ(stepped.size(), 50U);
}

}  // namespace

// The signed channels (commands and clocked samples): an input of a signed type takes only what the deployment's key signed,
// refusing (and counting, in HEALTH too) a message without the code, with another key's code, or
// with one changed byte; with authentication off it takes anything.
namespace {

humanoid::operator_t enable_request() {
  humanoid::operator_t m{};
  m.utime = hpr::wall_us();  // fresh: a command is judged by its time (hpr/node/freshness.hpp)
  m.source = "test";
  m.command = humanoid::operator_t::COMMAND_ENABLE;
  m.reason = "probe";
  return m;
}

TEST(Authentication, AnInputOfASignedTypeTakesOnlyWhatTheKeySigned) {
  (void)hpr::auth::load_or_create_key(hpr::auth::key_path());
  Runtime rt{kTestPorts, "test", "memq://", RuntimeOptions{}};
  auto& in = rt.subscribe(kOperator);
  auto& health = rt.subscribe(kHealth);
  auto out = rt.advertise(kOperator);
  const humanoid::operator_t m = enable_request();

  out.publish(m);
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 1);
  EXPECT_EQ(int{in.latest().command}, int{humanoid::operator_t::COMMAND_ENABLE});

  inject(rt, "OPERATOR", m);  // unsigned: a sender without the key
  rt.spin_once(0.0);
  hpr::auth::Key other = hpr::auth::load_key(hpr::auth::key_path());
  other.bytes[0] ^= 0xff;
  inject(rt, "OPERATOR", m, &other);
  rt.spin_once(0.0);
  // One byte of a signed message changed (the command: damp instead of enable).
  std::vector<std::uint8_t> bytes;
  const int n = hpr::node::encode_message(m, bytes, "OPERATOR", rt.deployment_key());
  ASSERT_GT(n, 40);
  humanoid::operator_t damp = m;
  damp.command = humanoid::operator_t::COMMAND_DAMP;
  std::vector<std::uint8_t> damp_bytes;
  ASSERT_EQ(hpr::node::encode_message(damp, damp_bytes, {}, nullptr), n);
  std::copy(damp_bytes.begin(), damp_bytes.end() - 32, bytes.begin());  // the enable's code kept
  rt.transport().publish_bytes("OPERATOR", bytes.data(), static_cast<std::size_t>(n));
  rt.spin_once(0.0);

  EXPECT_EQ(in.count(), 1);
  EXPECT_EQ(in.unauthenticated(), 3);
  EXPECT_EQ(in.errors(), 3);
  EXPECT_NE(in.last_error().find("no valid authentication code"), std::string::npos) << in.last_error();
  EXPECT_NE(in.last_error().find(hpr::auth::key_path()), std::string::npos) << in.last_error();
  rt.publish_health();
  rt.spin_once(0.0);
  ASSERT_TRUE(health.has_value());
  EXPECT_EQ(health.latest().unauthenticated, 3);
  EXPECT_EQ(health.latest().decode_errors, 3);
}

// The attack: two stacks on one LCM group, separated by their channel prefixes, sharing one key.
// A message of one stack copied onto the other's channel is refused: its code covers the channel.
TEST(Authentication, TwoPrefixedStacksWithOneKeyRefuseEachOthersMessages) {
  (void)hpr::auth::load_or_create_key(hpr::auth::key_path());
  RuntimeOptions a_options, b_options;
  a_options.channel_prefix = "a/";
  b_options.channel_prefix = "b/";
  Runtime a{kTestPorts, "a", "memq://", a_options};
  Runtime b{kTestPorts, "b", "memq://", b_options};
  auto& in = a.subscribe(kOperator);
  humanoid::operator_t m = enable_request();
  std::vector<std::uint8_t> bytes;
  const int n = hpr::node::encode_message(m, bytes, b.transport().channel("OPERATOR"), b.deployment_key());
  ASSERT_GT(n, 0);
  a.transport().publish_bytes("OPERATOR", bytes.data(), static_cast<std::size_t>(n));  // onto a/OPERATOR
  a.spin_once(0.0);
  EXPECT_EQ(in.count(), 0);
  EXPECT_EQ(in.unauthenticated(), 1);
  // The same message signed for a/OPERATOR is taken.
  m.utime = hpr::wall_us();
  const int k = hpr::node::encode_message(m, bytes, a.transport().channel("OPERATOR"), a.deployment_key());
  a.transport().publish_bytes("OPERATOR", bytes.data(), static_cast<std::size_t>(k));
  a.spin_once(0.0);
  EXPECT_EQ(in.count(), 1);
}

TEST(Authentication, OffTakesAnySenderAndSignsNothing) {
  RuntimeOptions o;
  o.authenticate = false;
  Runtime rt{kTestPorts, "test", "memq://", o};
  EXPECT_EQ(rt.deployment_key(), nullptr);
  auto& in = rt.subscribe(kOperator);
  const humanoid::operator_t m = enable_request();
  inject(rt, "OPERATOR", m);
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 1);
  EXPECT_EQ(in.unauthenticated(), 0);
}

TEST(Authentication, ANodeWithoutTheKeyFileRefusesToStartNamingIt) {
  const std::string missing = std::string(HPR_TEST_WORK_DIR) + "/no-such-folder/lcm.key";
  const std::string saved = hpr::auth::key_path();
  ::setenv("HPR_LCM_KEY_FILE", missing.c_str(), 1);
  Runtime rt{kTestPorts, "test", "memq://", RuntimeOptions{}};
  try {
    (void)rt.subscribe(kOperator);
    ADD_FAILURE() << "subscribed without a key";
  } catch (const hpr::auth::AuthError& e) {
    EXPECT_NE(std::string(e.what()).find(missing + " does not exist"), std::string::npos) << e.what();
  }
  ::setenv("HPR_LCM_KEY_FILE", saved.c_str(), 1);
}

}  // namespace

namespace {

namespace channels = hpr::msg::channels;

// A process reads and writes only what its declared ports list: a node that drifts from its
// declaration stops at start, naming the channel. The runtime's own OPERATOR subscription (live
// parameters) is not the process's.
TEST(RuntimeDeclarations, AProcessReadsAndWritesOnlyTheChannelsItsDeclarationLists) {
  RuntimeOptions o;
  o.authenticate = false;
  static constexpr hpr::Read kReads[] = {{hpr::channel::kRobotState, 0, true, false, "the state"},
                                  {hpr::channel::kCamReference, 0, false, true, "the reference"}};
  static constexpr std::string_view kWrites[] = {hpr::channel::kWholebodyCommand};
  static constexpr hpr::Ports kPorts{"optimiser", kReads, kWrites};
  Runtime rt{kPorts, "motion_opt", "memq://", o};
  EXPECT_NO_THROW(rt.subscribe(channels::kRobotState));
  EXPECT_NO_THROW(rt.subscribe(channels::kCamReference));
  EXPECT_NO_THROW((void)rt.advertise(channels::kWholebodyCommand));
  try {
    rt.subscribe(channels::kSimTruth);
    ADD_FAILURE() << "motion_opt read SIM_TRUTH";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("motion_opt reads SIM_TRUTH, which its declared ports (optimiser) do not list"),
              std::string::npos)
        << e.what();
  }
  try {
    (void)rt.advertise(channels::kJointCommand);
    ADD_FAILURE() << "motion_opt published JOINT_COMMAND";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("motion_opt publishes JOINT_COMMAND"), std::string::npos) << e.what();
  }
  // A process that declares no OPERATOR has its live parameters set over it all the same.
  static constexpr hpr::Read kSensorReads[] = {{hpr::channel::kRobotSensors, 0, true, false, "the sample"}};
  Runtime estimator{hpr::Ports{"estimator", kSensorReads, {}}, "estimator", "memq://", o};
  EXPECT_NO_THROW((void)estimator.parameters());
  EXPECT_THROW(estimator.subscribe(channels::kOperator), std::logic_error);
  // Undecoded bytes are held to the declaration too.
  EXPECT_NO_THROW(rt.transport().subscribe_bytes(hpr::channel::kRobotState, [](const std::uint8_t*, std::size_t) {}));
  EXPECT_THROW(rt.transport().subscribe_bytes(hpr::channel::kJointCommand, [](const std::uint8_t*, std::size_t) {}), std::logic_error);
  const std::uint8_t byte = 0;
  EXPECT_THROW(rt.transport().publish_bytes(hpr::channel::kJointCommand, &byte, 1), std::logic_error);
}

}  // namespace
