// Commands are taken once and only while fresh (hpr/node/freshness.hpp): a recording of a signed
// command played again, later or at once, is refused; a copy is dropped; a stop is always taken.
#include <gtest/gtest.h>

#include <humanoid/operator_t.hpp>

#include <string>

#include "hpr/node/freshness.hpp"
#include "hpr/node/runtime.hpp"

namespace {

using hpr::node::CommandFreshness;
using Verdict = hpr::node::CommandFreshness::Verdict;

constexpr std::int64_t kOneSecond = 1'000'000;

TEST(CommandFreshness, TakesEachSendersCommandsOnceInTheOrderTheyWereMade) {
  CommandFreshness f(2.0);
  const std::int64_t now = 1'800'000'000 * kOneSecond;
  std::string why;
  EXPECT_EQ(f.check("operator@a:1", now - 10, now, why), Verdict::kFresh);
  EXPECT_EQ(f.check("operator@a:1", now - 10, now, why), Verdict::kCopy);  // the tool's second copy
  EXPECT_EQ(f.check("operator@a:1", now - 20, now, why), Verdict::kReplayed);
  EXPECT_NE(why.find("replayed"), std::string::npos) << why;
  EXPECT_EQ(f.check("operator@a:1", now - 5, now, why), Verdict::kFresh);
  // Another sender has a clock of its own in this table.
  EXPECT_EQ(f.check("supervisor@b", now - 50, now, why), Verdict::kFresh);
}

TEST(CommandFreshness, RefusesACommandOutsideTheWindowEitherWay) {
  CommandFreshness f(2.0);
  const std::int64_t now = 1'800'000'000 * kOneSecond;
  std::string why;
  EXPECT_EQ(f.check("s", now - 2 * kOneSecond - 1, now, why), Verdict::kStale);
  EXPECT_NE(why.find("ago"), std::string::npos) << why;
  EXPECT_EQ(f.check("s", now + 2 * kOneSecond + 1, now, why), Verdict::kStale);
  EXPECT_NE(why.find("ahead"), std::string::npos) << why;
  EXPECT_EQ(f.check("s", now - 2 * kOneSecond, now, why), Verdict::kFresh);  // the window's edge is in it
  // Times at int64's ends do not overflow into the window.
  EXPECT_EQ(f.check("t", INT64_MIN, now, why), Verdict::kStale);
  EXPECT_EQ(f.check("t", INT64_MAX, now, why), Verdict::kStale);
  // A window of 0 checks nothing (a re-run of a recording).
  CommandFreshness off(0.0);
  EXPECT_EQ(off.check("s", 1, now, why), Verdict::kFresh);
  EXPECT_EQ(off.check("s", 1, now, why), Verdict::kFresh);
}

TEST(CommandFreshness, RemembersABoundedNumberOfSendersForgettingTheOldest) {
  CommandFreshness f(2.0);
  const std::int64_t now = 1'800'000'000 * kOneSecond;
  std::string why;
  for (std::size_t k = 0; k <= CommandFreshness::kMaxSenders; ++k) {
    ASSERT_EQ(f.check("s" + std::to_string(k), now - kOneSecond + static_cast<std::int64_t>(k), now, why), Verdict::kFresh);
  }
  // s0 (the oldest) was forgotten: its replay within the window is taken again; s1 is remembered.
  EXPECT_EQ(f.check("s0", now - kOneSecond, now, why), Verdict::kFresh);
  EXPECT_EQ(f.check("s2", now - kOneSecond + 2, now, why), Verdict::kCopy);
}

constexpr hpr::Channel<humanoid::operator_t> kCommandChannel{"OPERATOR"};
constexpr hpr::Read kCommandReads[] = {{"OPERATOR", 0, false, false, "commands"}};
constexpr std::string_view kCommandWrites[] = {"OPERATOR"};
constexpr hpr::Ports kCommandPorts{.name = "test", .reads = kCommandReads, .writes = kCommandWrites};

humanoid::operator_t command(std::int8_t what, std::int64_t utime) {
  humanoid::operator_t m{};
  m.utime = utime;
  m.source = "operator@test";
  m.command = what;
  return m;
}

// The attack: every OPERATOR on the group recorded (signed, as sent), then played again.
TEST(CommandFreshness, ARecordedEnableIsRefusedWhenPlayedAgainAndAStopIsAlwaysTaken) {
  (void)hpr::auth::load_or_create_key(hpr::auth::key_path());
  hpr::node::Runtime rt{kCommandPorts, "test", "memq://", hpr::node::RuntimeOptions{}};
  auto& in = rt.subscribe(kCommandChannel);
  auto out = rt.advertise(kCommandChannel);
  const std::int64_t t0 = hpr::wall_us();
  const auto enable = command(humanoid::operator_t::COMMAND_ENABLE, t0 - 3000);
  const auto stop = command(humanoid::operator_t::COMMAND_STOP, t0 - 2000);
  out.publish(enable);
  out.publish(enable);  // a copy
  out.publish(stop);
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 2);
  EXPECT_EQ(in.copies(), 1);
  out.publish(enable);  // replayed at once: older than the stop from the same sender
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 2);
  EXPECT_EQ(in.stale_commands(), 1);
  out.publish(command(humanoid::operator_t::COMMAND_ENABLE, t0 - 10 * kOneSecond));  // replayed later
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 2);
  EXPECT_EQ(in.stale_commands(), 2);
  EXPECT_EQ(in.errors(), 2);
  EXPECT_NE(in.last_error().find("stale or replayed"), std::string::npos) << in.last_error();
  out.publish(command(humanoid::operator_t::COMMAND_DAMP, t0 - 10 * kOneSecond));  // a stale damp: still a stop
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 3);
  EXPECT_EQ(in.stale_stops(), 1);
  EXPECT_EQ(int{in.latest().command}, int{humanoid::operator_t::COMMAND_DAMP});
  out.publish(command(humanoid::operator_t::COMMAND_ENABLE, hpr::wall_us()));  // a new one
  rt.spin_once(0.0);
  EXPECT_EQ(in.count(), 4);
  EXPECT_EQ(int{in.latest().command}, int{humanoid::operator_t::COMMAND_ENABLE});
}

}  // namespace
