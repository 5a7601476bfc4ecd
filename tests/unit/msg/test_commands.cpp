// The command channels' documented ranges: what is refused, and that every valid command passes.
#include <gtest/gtest.h>

#include <cmath>

#include "hpr/msg/commands.hpp"

namespace {

humanoid::operator_t op(int command) {
  humanoid::operator_t m{};
  m.command = static_cast<std::int8_t>(command);
  return m;
}

TEST(Commands, EveryKnownOperatorCommandPassesAndOthersAreRefused) {
  for (int c = humanoid::operator_t::COMMAND_NONE; c <= humanoid::operator_t::COMMAND_GET_PARAMS; ++c) {
    EXPECT_EQ(hpr::msg::check_operator(op(c)), "") << c;
  }
  for (int c : {-1, 7, 99, -128, 127}) {
    EXPECT_NE(hpr::msg::check_operator(op(c)).find("unknown command " + std::to_string(c)), std::string::npos) << c;
  }
}

TEST(Commands, SetSupportNeedsAKnownSupportAndSetParamsFiniteValues) {
  auto m = op(humanoid::operator_t::COMMAND_SET_SUPPORT);
  for (int s : {0, 1, 2}) {
    m.support = static_cast<std::int8_t>(s);
    EXPECT_EQ(hpr::msg::check_operator(m), "");
  }
  m.support = 3;
  EXPECT_NE(hpr::msg::check_operator(m).find("unknown support 3"), std::string::npos);
  auto p = op(humanoid::operator_t::COMMAND_SET_PARAMS);
  p.num_params = 2;
  p.param_name = {"wbc.joint_damping", "wbc.com.stiffness.x"};
  p.param_value = {1.0, 300.0};
  EXPECT_EQ(hpr::msg::check_operator(p), "");
  p.param_value[1] = std::nan("");
  EXPECT_NE(hpr::msg::check_operator(p).find("wbc.com.stiffness.x = nan"), std::string::npos) << hpr::msg::check_operator(p);
}

TEST(Commands, SupervisorCommandsAreDownOrARestartNamingAProcess) {
  humanoid::supervisor_command_t c{};
  c.command = humanoid::supervisor_command_t::COMMAND_DOWN;
  EXPECT_EQ(hpr::msg::check_supervisor_command(c), "");
  c.command = humanoid::supervisor_command_t::COMMAND_RESTART;
  EXPECT_NE(hpr::msg::check_supervisor_command(c).find("without a process"), std::string::npos);
  c.process = "wbc";
  EXPECT_EQ(hpr::msg::check_supervisor_command(c), "");
  for (int k : {0, 3, 99, -1}) {
    c.command = static_cast<std::int8_t>(k);
    EXPECT_NE(hpr::msg::check_supervisor_command(c).find("unknown command"), std::string::npos) << k;
  }
}

}  // namespace
