// The tick of an encoded message and the coverage of the data-flow channels' ticks, checked on
// messages encoded by the LCM-generated code.
#include <gtest/gtest.h>

#include <humanoid/joint_command_t.hpp>

#include <vector>

#include "hpr/msg/ticks.hpp"

namespace {

using hpr::msg::TickCoverage;

TEST(Ticks, TickOfAnEncodedMessageIsItsTickField) {
  for (const std::int64_t tick : {0LL, 1LL, 1234567890123LL, -5LL}) {
    humanoid::joint_command_t m{};
    m.tick = tick;
    m.num_joints = 0;
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
    ASSERT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
    EXPECT_EQ(hpr::msg::tick_of(buf.data(), static_cast<int>(buf.size())), tick);
  }
  const std::uint8_t short_buf[10] = {};
  EXPECT_EQ(hpr::msg::tick_of(short_buf, sizeof(short_buf)), -1);
}

TEST(Ticks, FlowOrderFollowsTheDataFlow) {
  using hpr::msg::flow_rank;
  EXPECT_LT(flow_rank("ROBOT_SENSORS"), flow_rank("ROBOT_STATE"));
  EXPECT_LT(flow_rank("ROBOT_STATE"), flow_rank("CAM_REFERENCE"));
  EXPECT_LT(flow_rank("CAM_REFERENCE"), flow_rank("WHOLEBODY_COMMAND"));
  EXPECT_LT(flow_rank("WHOLEBODY_COMMAND"), flow_rank("JOINT_COMMAND"));
  EXPECT_LT(flow_rank("JOINT_COMMAND"), flow_rank("BALANCE_STATUS"));
  EXPECT_EQ(flow_rank("HEALTH"), hpr::msg::kNotInFlow);
}

TEST(Ticks, CoverageFindsTheMissingTicksInAnyArrivalOrder) {
  TickCoverage c;
  for (const std::int64_t t : {12, 10, 11, 15, 19, 14, 20}) c.add("ROBOT_SENSORS", t);  // 13, 16-18 missing
  for (std::int64_t t = 0; t < 100; ++t) c.add("JOINT_COMMAND", t);
  c.add("HEALTH", 5);  // outside the flow: never reported
  c.add("HEALTH", 50);
  c.add("ROBOT_STATE", -1);  // no tick: ignored
  const auto lacking = c.lacking();
  ASSERT_EQ(lacking.size(), 1U);
  EXPECT_EQ(lacking.at("ROBOT_SENSORS"), (std::vector<std::int64_t>{13, 16, 17, 18}));
  EXPECT_EQ(hpr::msg::tick_ranges(lacking.at("ROBOT_SENSORS")), "13, 16-18");
  EXPECT_EQ(hpr::msg::tick_ranges({1, 3, 5, 7}, 2), "1, 3, ...");
  EXPECT_EQ(hpr::msg::tick_ranges({}), "");
}

}  // namespace
