// The balance planner as a component: when it plans, where the plan starts, what it keeps doing
// without a usable estimate, and a support request carried out (the CoM over the stance sole, the
// other foot lifted).

#include <gtest/gtest.h>

#include <Eigen/Core>

#include "hpr/model/algorithms.hpp"
#include "hpr/planner/component.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;

EstimatedState standing_estimate(const model::RobotSpec& robot, double t) {
  EstimatedState s;
  s.q = robot.standing_configuration();
  s.v = Eigen::VectorXd::Zero(robot.model.nv);
  s.time = t;
  s.tick = static_cast<std::int64_t>(t * 1000.0 + 0.5);
  return s;
}

TEST(BalancePlanner, PlansFromTheFirstUsableEstimateAndGoesOnWithoutOne) {
  const auto robot = test::load_robot("toro");
  balance::PostureReferenceConfig config;
  config.init_time = 0.5;
  planner::BalancePlanner planner(robot, config);
  planner::BalancePlanner::Outputs out;

  // Nothing to start from: no plan, not ready.
  EstimatedState s = standing_estimate(robot, 0.0);
  s.status = EstimatedState::kImplausible;
  EXPECT_FALSE(planner.will_plan(s));
  planner.step({s}, out);
  EXPECT_FALSE(out.valid);
  EXPECT_EQ(out.report.outcome, StepOutcome::kNotReady);

  // The first usable estimate, its CoM 2 cm to the side of the posture's: the plan starts at the
  // measured CoM (from the model's own kinematics here) and blends to the held posture.
  s = standing_estimate(robot, 0.001);
  s.q(1) += 0.02;
  model::Data data(robot.model);
  const Eigen::Vector3d c_measured = model::center_of_mass(robot.model, data, s.q);
  EXPECT_TRUE(planner.will_plan(s));
  planner.step({s}, out);
  ASSERT_TRUE(out.valid);
  EXPECT_EQ(out.report.outcome, StepOutcome::kRunning);
  EXPECT_LT((out.plan.reference.p_com - c_measured).norm(), 1e-9);
  EXPECT_EQ(out.plan.reference.time, s.time);
  EXPECT_EQ(out.plan.stage, balance::PlanStage::kInit);

  // Unusable estimates from here on: the plan goes on in time and reaches the held posture, whose
  // CoM lies over the middle of the soles (they moved with the base: 2 cm to the side).
  for (int k = 2; k <= 1000; ++k) {
    s = standing_estimate(robot, 0.001 * k);
    s.q(1) += 0.02;
    s.status = EstimatedState::kSensorStale;
    ASSERT_TRUE(planner.will_plan(s));
    planner.step({s}, out);
    ASSERT_TRUE(out.valid) << "tick " << k;
  }
  EXPECT_EQ(out.plan.reference.time, 1.0);
  EXPECT_EQ(out.plan.stage, balance::PlanStage::kHold);
  EXPECT_TRUE(out.plan.reference.settled);
  const Eigen::Vector3d mid = 0.5 * (out.plan.reference.feet[model::kRight].X_WS.p + out.plan.reference.feet[model::kLeft].X_WS.p);
  EXPECT_NEAR(out.plan.reference.p_com.y(), mid.y(), 1e-9);
  EXPECT_LT(out.plan.reference.v_com.norm(), 1e-9);

  // A clock that restarted: no plan until a usable estimate, which starts it again from there.
  planner.reset();
  s = standing_estimate(robot, 0.0);
  s.status = EstimatedState::kImplausible;
  EXPECT_FALSE(planner.will_plan(s));
  planner.step({s}, out);
  EXPECT_FALSE(out.valid);
  s = standing_estimate(robot, 0.001);
  planner.step({s}, out);
  ASSERT_TRUE(out.valid);
  EXPECT_LT((out.plan.reference.p_com - model::center_of_mass(robot.model, data, s.q)).norm(), 1e-9);
}

TEST(BalancePlanner, ASupportRequestPutsTheCoMOverTheStanceSoleAndLiftsTheOtherFoot) {
  const auto robot = test::load_robot("toro");
  balance::PostureReferenceConfig config;
  config.init_time = 0.2;
  planner::BalancePlanner planner(robot, config);
  planner::BalancePlanner::Outputs out;
  double t = 0.0;
  auto run_until = [&](double end) {
    for (; t < end - 1e-9; t += 0.001) planner.step({standing_estimate(robot, t)}, out);
  };
  run_until(0.5);
  ASSERT_TRUE(out.valid);
  EXPECT_EQ(out.plan.reference.support, balance::Support::kDouble);
  planner.request_support(balance::Support::kRight, t);
  run_until(0.5 + config.shift_time + config.lift_time + 0.2);
  EXPECT_EQ(out.plan.reference.support, balance::Support::kRight);
  EXPECT_TRUE(out.plan.reference.feet[model::kRight].contact);
  EXPECT_FALSE(out.plan.reference.feet[model::kLeft].contact);
  EXPECT_NEAR(out.plan.reference.feet[model::kLeft].X_WS.p.z() - out.plan.reference.feet[model::kRight].X_WS.p.z(), config.lift_height, 1e-9);
  const Eigen::Vector3d& stance = out.plan.reference.feet[model::kRight].X_WS.p;
  EXPECT_LT((out.plan.reference.p_com.head<2>() - stance.head<2>()).norm(), 0.02) << "the CoM over the stance sole";
}

}  // namespace
