// The composition's checks of the declarations: a binding's channels are its component's ports,
// and a diagram's parts step in an order where each sees what its process would see.
#include <gtest/gtest.h>

#include <array>

#include "hpr/graph/bindings.hpp"
#include "hpr/graph/diagram.hpp"

namespace {

using namespace hpr::graph;
using hpr::Ports;
using hpr::Read;

constexpr Ports kPlanner = hpr::planner::BalancePlanner::kPorts;
constexpr Ports kReferenceGen = hpr::reference_gen::ReferenceGenerator::kPorts;
constexpr Ports kMotionOpt = hpr::motion_opt::MotionOptComponent::kPorts;
constexpr Ports kWbc = hpr::wbc::WbcComponent::kPorts;

TEST(Diagram, TheControllersOrderIsTheOnlyOneOfTheirsThatSeesWhatTheProcessesSee) {
  EXPECT_TRUE(detail::ordered<4>({kPlanner, kReferenceGen, kMotionOpt, kWbc}));
  // The wbc before the planner: it would follow the previous tick's plan.
  EXPECT_FALSE(detail::ordered<4>({kWbc, kPlanner, kReferenceGen, kMotionOpt}));
  // motion_opt before reference_gen: the CAM reference of the previous tick.
  EXPECT_FALSE(detail::ordered<4>({kPlanner, kMotionOpt, kReferenceGen, kWbc}));
  // The wbc before reference_gen: reference_gen would read this tick's BALANCE_STATUS, not the
  // previous one's (the paper's one-period lag).
  EXPECT_FALSE(detail::ordered<4>({kPlanner, kWbc, kReferenceGen, kMotionOpt}));
  // Without motion_opt and reference_gen (the ankle strategy): still in order.
  EXPECT_TRUE(detail::ordered<2>({kPlanner, kWbc}));
}

TEST(Diagram, AChannelWithTwoWritersIsRefused) {
  static constexpr Read kReads[] = {{hpr::channel::kRobotState, 0, true, false, ""}};
  static constexpr std::string_view kWrites[] = {hpr::channel::kBalancePlan};
  constexpr Ports kSecondPlanner{"second_planner", kReads, kWrites};
  EXPECT_FALSE(detail::ordered<3>({kPlanner, kSecondPlanner, kWbc}));
  // A tick offset the composition cannot give (two ticks back) is refused too.
  static constexpr Read kOld[] = {{hpr::channel::kRobotState, 0, true, false, ""}, {hpr::channel::kBalancePlan, -2, false, true, ""}};
  constexpr Ports kOldReader{"old_reader", kOld, {}};
  EXPECT_FALSE(detail::ordered<2>({kPlanner, kOldReader}));
}

TEST(Diagram, EveryBindingsChannelsAreItsComponentsPortsInOrder) {
  EXPECT_TRUE(detail::channels_match_ports<EstimatorBinding>());
  EXPECT_TRUE(detail::channels_match_ports<TruthStateBinding>());
  EXPECT_TRUE(detail::channels_match_ports<PlannerBinding>());
  EXPECT_TRUE(detail::channels_match_ports<ReferenceGenBinding>());
  EXPECT_TRUE(detail::channels_match_ports<MotionOptBinding>());
  EXPECT_TRUE(detail::channels_match_ports<WbcBinding>());
  // Each steps on one channel: the first it declares.
  EXPECT_EQ(detail::trigger_index<WbcBinding>(), 0u);
  EXPECT_EQ(detail::trigger_index<TruthStateBinding>(), 0u);
}

}  // namespace
