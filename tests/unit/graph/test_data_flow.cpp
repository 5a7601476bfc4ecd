// The data flow gathered from the processes' declared ports is consistent with the channels of the
// stack and with itself: every channel named is one of the stack's, each process steps on one
// channel, every required input of a control process is written by another process, and the
// composed controllers' ports are what their five components read from outside and write.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "hpr/graph/data_flow.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/log_check.hpp"

namespace {

using namespace hpr::graph;
using hpr::msg::carries_code;
using hpr::msg::type_of_channel;
using hpr::Ports;
using hpr::Read;

TEST(DataFlow, NamesOnlyTheStacksChannelsWithOneTriggerEach) {
  for (const auto& p : data_flow()) {
    int triggers = 0;
    for (const auto& r : p.reads) {
      EXPECT_FALSE(type_of_channel(std::string(r.channel)).empty()) << p.name << " reads " << r.channel;
      EXPECT_TRUE(r.tick_offset == 0 || r.tick_offset == -1) << p.name << " " << r.channel;
      EXPECT_FALSE(r.trigger && r.optional) << p.name << ": a process cannot step on an optional input";
      EXPECT_FALSE(r.use.empty());
      triggers += r.trigger ? 1 : 0;
    }
    EXPECT_LE(triggers, 1) << p.name;
    for (const auto& w : p.writes) EXPECT_FALSE(type_of_channel(std::string(w)).empty()) << p.name << " writes " << w;
  }
}

// What a process acts on is authenticated: every channel a process reads carries a code, but the
// simulator's test push; so do the reports the supervisors act on (HEALTH, SUPERVISOR_STATUS).
TEST(DataFlow, EveryChannelAProcessReadsCarriesACodeButTheTestPush) {
  for (const auto& p : data_flow()) {
    for (const auto& r : p.reads) EXPECT_EQ(carries_code(std::string(r.channel)), r.channel != "PUSH") << p.name << " reads " << r.channel;
  }
  for (const char* c : {"OPERATOR", "SUPERVISOR_COMMAND", "SIM_TRUTH", "HAL_STATUS", "robotA/ROBOT_STATE", "HEALTH", "SUPERVISOR_STATUS"}) {
    EXPECT_TRUE(carries_code(c)) << c;
  }
  for (const char* c : {"PARAMS", "PUSH", "NOT_A_CHANNEL"}) EXPECT_FALSE(carries_code(c)) << c;
}

TEST(DataFlow, TheControlProcessesGetEveryRequiredInputFromTheChain) {
  // With a backend (the simulator or the hal), nothing required is missing, either way composed.
  EXPECT_TRUE(unmet_inputs({"sim_bullet", "estimator", "planner", "reference_gen", "motion_opt", "wbc"}).empty());
  EXPECT_TRUE(unmet_inputs({"hal", "controllers"}).empty());
  // Without one, the sensors are missing, and only they.
  const auto unmet = unmet_inputs({"estimator", "planner", "reference_gen", "motion_opt", "wbc"});
  ASSERT_EQ(unmet.size(), 1U);
  EXPECT_NE(unmet[0].find("estimator reads ROBOT_SENSORS"), std::string::npos) << unmet[0];
  // The wbc alone lacks its state and its plan; its optional inputs are not demanded.
  const auto wbc = unmet_inputs({"wbc"});
  ASSERT_EQ(wbc.size(), 2U);
  EXPECT_NE(wbc[0].find("ROBOT_STATE"), std::string::npos);
  EXPECT_NE(wbc[1].find("wbc reads BALANCE_PLAN"), std::string::npos) << wbc[1];
}

TEST(DataFlow, TheComposedControllersReadWhatTheirComponentsReadFromOutsideAndWriteWhatTheyWrite) {
  std::set<std::string_view> five;
  for (const char* n : {"estimator", "planner", "reference_gen", "motion_opt", "wbc"}) {
    const Ports* p = find_process(n);
    ASSERT_NE(p, nullptr) << n;
    five.insert(p->writes.begin(), p->writes.end());
  }
  const Ports* c = find_process("controllers");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(std::set<std::string_view>(c->writes.begin(), c->writes.end()), five);
  EXPECT_EQ(five.count("BALANCE_PLAN"), 1U);
  // From outside: the sensors it steps on, and the operator's requests (the planner's and the wbc's).
  ASSERT_EQ(c->reads.size(), 2U);
  EXPECT_EQ(c->reads[0].channel, "ROBOT_SENSORS");
  EXPECT_TRUE(c->reads[0].trigger);
  EXPECT_FALSE(c->reads[0].optional);
  EXPECT_EQ(c->reads[1].channel, "OPERATOR");
  EXPECT_TRUE(c->reads[1].optional);
  EXPECT_NE(c->reads[1].use.find("planner: support requests"), std::string_view::npos) << c->reads[1].use;
  EXPECT_NE(c->reads[1].use.find("wbc: enable, damp, stop"), std::string_view::npos) << c->reads[1].use;
  EXPECT_EQ(read_of("reference_gen", "BALANCE_STATUS").tick_offset, -1);  // the paper's one-period lag
  // motion_opt and the wbc follow the plan of their own tick, and need it.
  for (const char* n : {"motion_opt", "wbc"}) {
    EXPECT_EQ(read_of(n, "BALANCE_PLAN").tick_offset, 0) << n;
    EXPECT_FALSE(read_of(n, "BALANCE_PLAN").optional) << n;
  }
  EXPECT_THROW((void)read_of("motion_opt", "OPERATOR"), std::invalid_argument) << "support requests are the planner's";
  EXPECT_THROW((void)read_of("wbc", "CAM_REFERENCE"), std::invalid_argument);
  EXPECT_EQ(find_process("lcm_recorder"), nullptr);
}

// Composing: a channel one part writes is passed inside; one read by several parts is read once,
// stepping if any part steps on it and optional only if every part can do without it; parts that
// read one channel at different ticks cannot be composed.
TEST(DataFlow, ComposingPassesWhatThePartsWriteAndMergesWhatTheyReadAlike) {
  constexpr Read kAReads[] = {{"IN", 0, true, false, "steps"}, {"OPT", 0, false, true, "a"}};
  constexpr std::string_view kAWrites[] = {"MID"};
  constexpr Read kBReads[] = {{"MID", 0, false, false, "passed"}, {"OPT", 0, false, false, "b"}};
  constexpr std::string_view kBWrites[] = {"OUT"};
  const std::vector<Ports> parts = {{"a", kAReads, kAWrites}, {"b", kBReads, kBWrites}};
  const Ports ab = composed("ab", parts);
  EXPECT_EQ(ab.name, "ab");
  ASSERT_EQ(ab.reads.size(), 2U);
  EXPECT_EQ(ab.reads[0].channel, "IN");
  EXPECT_EQ(ab.reads[1].channel, "OPT");
  EXPECT_FALSE(ab.reads[1].optional) << "b needs it";
  EXPECT_EQ(ab.reads[1].use, "a: a; b: b");
  EXPECT_EQ(std::vector<std::string_view>(ab.writes.begin(), ab.writes.end()), (std::vector<std::string_view>{"MID", "OUT"}));
  constexpr Read kLagged[] = {{"IN", -1, false, true, "the previous tick's"}};
  const std::vector<Ports> clash = {{"a", kAReads, kAWrites}, {"c", kLagged, {}}};
  EXPECT_THROW((void)composed("ac", clash), std::logic_error);
}

// Every declared channel of every process is one of the stack's channels.
TEST(DataFlow, TheDeclaredGraphNamesOnlyTheStacksChannels) {
  namespace channels = hpr::msg::channels;
  const std::vector<std::string_view> known = {channels::kRobotSensors.name, channels::kRobotState.name,  channels::kBalancePlan.name,
                                               channels::kCamReference.name,
                                               channels::kWholebodyCommand.name, channels::kJointCommand.name, channels::kBalanceStatus.name,
                                               channels::kSimTruth.name,      channels::kHalStatus.name,   channels::kPush.name,
                                               channels::kOperator.name};
  for (const auto& p : data_flow()) {
    for (const auto& r : p.reads) EXPECT_NE(std::find(known.begin(), known.end(), r.channel), known.end()) << p.name << " " << r.channel;
    for (const auto& w : p.writes) EXPECT_NE(std::find(known.begin(), known.end(), w), known.end()) << p.name << " " << w;
  }
}

}  // namespace
