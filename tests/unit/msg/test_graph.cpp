// The declared data flow is consistent with the channels of the stack and with itself: every
// channel named is one of the stack's, each process steps on one channel, every required input of
// a control process is written by another process, and the composed controllers write what the
// four processes write.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "hpr/msg/graph.hpp"
#include "hpr/msg/log_check.hpp"

namespace {

using namespace hpr::msg;

TEST(DataFlow, NamesOnlyTheStacksChannelsWithOneTriggerEach) {
  for (const auto& p : data_flow()) {
    int triggers = 0;
    for (const auto& r : p.reads) {
      EXPECT_FALSE(type_of_channel(r.channel).empty()) << p.name << " reads " << r.channel;
      EXPECT_TRUE(r.tick_offset == 0 || r.tick_offset == -1) << p.name << " " << r.channel;
      EXPECT_FALSE(r.trigger && r.optional) << p.name << ": a process cannot step on an optional input";
      EXPECT_FALSE(r.use.empty());
      triggers += r.trigger ? 1 : 0;
    }
    EXPECT_LE(triggers, 1) << p.name;
    for (const auto& w : p.writes) EXPECT_FALSE(type_of_channel(w).empty()) << p.name << " writes " << w;
  }
}

// What a process acts on is authenticated: every channel a process reads carries a code, but the
// simulator's test push; the reports no process acts on do not.
TEST(DataFlow, EveryChannelAProcessReadsCarriesACodeButTheTestPush) {
  for (const auto& p : data_flow()) {
    for (const auto& r : p.reads) EXPECT_EQ(carries_code(r.channel), r.channel != "PUSH") << p.name << " reads " << r.channel;
  }
  for (const char* c : {"OPERATOR", "SUPERVISOR_COMMAND", "SIM_TRUTH", "HAL_STATUS", "robotA/ROBOT_STATE"}) EXPECT_TRUE(carries_code(c)) << c;
  for (const char* c : {"HEALTH", "PARAMS", "SUPERVISOR_STATUS", "PUSH", "NOT_A_CHANNEL"}) EXPECT_FALSE(carries_code(c)) << c;
}

TEST(DataFlow, TheControlProcessesGetEveryRequiredInputFromTheChain) {
  // With a backend (the simulator or the hal), nothing required is missing, either way composed.
  EXPECT_TRUE(unmet_inputs({"sim_bullet", "estimator", "reference_gen", "motion_opt", "wbc"}).empty());
  EXPECT_TRUE(unmet_inputs({"hal", "controllers"}).empty());
  // Without one, the sensors are missing, and only they.
  const auto unmet = unmet_inputs({"estimator", "reference_gen", "motion_opt", "wbc"});
  ASSERT_EQ(unmet.size(), 1U);
  EXPECT_NE(unmet[0].find("estimator reads ROBOT_SENSORS"), std::string::npos) << unmet[0];
  // The wbc alone lacks its state; its optional inputs are not demanded.
  const auto wbc = unmet_inputs({"wbc"});
  ASSERT_EQ(wbc.size(), 1U);
  EXPECT_NE(wbc[0].find("ROBOT_STATE"), std::string::npos);
}

TEST(DataFlow, TheComposedControllersWriteWhatTheFourProcessesWrite) {
  std::set<std::string> four;
  for (const char* n : {"estimator", "reference_gen", "motion_opt", "wbc"}) {
    const ProcessPorts* p = find_process(n);
    ASSERT_NE(p, nullptr) << n;
    four.insert(p->writes.begin(), p->writes.end());
  }
  const ProcessPorts* c = find_process("controllers");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(std::set<std::string>(c->writes.begin(), c->writes.end()), four);
  EXPECT_EQ(read_of("reference_gen", "BALANCE_STATUS").tick_offset, -1);  // the paper's one-period lag
  EXPECT_THROW((void)read_of("wbc", "CAM_REFERENCE"), std::invalid_argument);
  EXPECT_EQ(find_process("lcm_recorder"), nullptr);
}

}  // namespace
