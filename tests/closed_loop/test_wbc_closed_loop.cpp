// The whole-body controller closing the loop around the Bullet simulator (state from the
// simulator's truth): standing in double support, single support on either foot, and a push that
// the ankle strategy alone recovers. For both robots, configuration changes only.
#include <gtest/gtest.h>

#include "closed_loop.hpp"

namespace {

using hpr::test::ClosedLoop;
using Eigen::Vector3d;

class WbcClosedLoop : public ::testing::TestWithParam<std::string> {};

TEST_P(WbcClosedLoop, StandsInDoubleSupportFor30s) {
  ClosedLoop loop(GetParam());
  const auto soles0 = loop.sim.truth().p_WF;
  double com_err = 0, slip = 0, tilt = 0;
  loop.run(30.0, [&] {
    const auto& t = loop.sim.truth();
    if (t.time > 1.5) com_err = std::max(com_err, (t.p_WCom - loop.plan().reference.p_com).norm());
    for (size_t f = 0; f < 2; ++f) {
      slip = std::max(slip, (t.p_WF[f].head<2>() - soles0[f].head<2>()).norm());
      tilt = std::max(tilt, t.foot_tilt[f]);
    }
  });
  EXPECT_FALSE(loop.sim.truth().fallen);
  EXPECT_LT(com_err, 2e-3) << "CoM error [m]";
  EXPECT_LT(slip, 1e-3) << "sole slip [m]";
  EXPECT_LT(tilt, 0.01) << "sole tilt [rad]";
}

TEST_P(WbcClosedLoop, StandsOnEitherFootFor20s) {
  for (const char* foot : {"right", "left"}) {
    ClosedLoop loop(GetParam(), {std::string("balance.support=") + foot});
    const int stance = std::string(foot) == "right" ? 0 : 1;
    const auto sole0 = loop.sim.truth().p_WF[static_cast<size_t>(stance)];
    double com_err = 0, slip = 0, swing_height = 1e9;
    loop.run(20.0, [&] {
      const auto& t = loop.sim.truth();
      slip = std::max(slip, (t.p_WF[static_cast<size_t>(stance)].head<2>() - sole0.head<2>()).norm());
      if (t.time > 5.0) {
        com_err = std::max(com_err, (t.p_WCom - loop.plan().reference.p_com).norm());
        swing_height = std::min(swing_height, t.p_WF[static_cast<size_t>(1 - stance)].z());
      }
    });
    EXPECT_FALSE(loop.sim.truth().fallen) << foot;
    EXPECT_EQ(loop.plan().reference.support, stance == 0 ? hpr::balance::Support::kRight : hpr::balance::Support::kLeft);
    EXPECT_LT(com_err, 5e-3) << foot << ": CoM error [m]";
    EXPECT_LT(slip, 1e-3) << foot << ": stance sole slip [m]";
    EXPECT_GT(swing_height, 0.03) << foot << ": the swing foot must stay lifted";
  }
}

TEST_P(WbcClosedLoop, AnkleStrategyRecoversA5NsPushFromBehind) {
  ClosedLoop loop(GetParam());
  loop.push_base(5.0, 65.0, Vector3d::UnitX(), 2.0);
  double tilt = 0, peak_dev = 0;
  loop.run(7.0, [&] {
    const auto& t = loop.sim.truth();
    for (size_t f = 0; f < 2; ++f) tilt = std::max(tilt, t.foot_tilt[f]);
    peak_dev = std::max(peak_dev, (t.p_WCom - loop.plan().reference.p_com).norm());
  });
  const auto& t = loop.sim.truth();
  EXPECT_FALSE(t.fallen);
  EXPECT_NEAR(t.push_impulse_W.x(), 5.0, 0.05);
  EXPECT_GT(peak_dev, 2e-3) << "the push must move the CoM";
  EXPECT_LT((t.p_WCom - loop.plan().reference.p_com).norm(), 0.01) << "back to the reference";
  EXPECT_LT(tilt, 2.0 * M_PI / 180) << "soles flat";
}

INSTANTIATE_TEST_SUITE_P(Robots, WbcClosedLoop, ::testing::Values("toro", "h1_2"));

}  // namespace
