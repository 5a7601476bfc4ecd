// The simulator's truth in the estimator's place: the state a perfect estimator would give, and no
// state for a tick without its truth.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "hpr/estimator/truth_state.hpp"

namespace {

using hpr::EstimatedState;
using hpr::SensorSample;
using hpr::SimTruth;
using hpr::estimator::TruthState;

SimTruth some_truth() {
  SimTruth t;
  t.tick = 12;
  t.time = 0.012;
  t.p_WB = {0.1, -0.2, 0.9};
  const Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())).normalized();
  t.quat_WB = {q.w(), q.x(), q.y(), q.z()};
  t.v_WB = {0.4, 0.5, -0.1};
  t.omega_WB = {-0.3, 0.2, 0.7};
  t.p_WCom = {0.05, 0.0, 0.85};
  t.v_WCom = {0.3, 0.1, 0.0};
  t.foot_contact = {true, false};
  t.contact_wrench_W[0] << 1, 2, 300, 4, 5, 6;
  t.contact_wrench_W[1].setZero();
  return t;
}

SensorSample some_sensors() {
  SensorSample s;
  s.resize(4);
  s.tick = 12;
  s.time = 0.012;
  s.q << 0.1, -0.2, 0.3, -0.4;
  s.qd << 1.0, -2.0, 3.0, -4.0;
  return s;
}

TEST(TruthState, GivesTheStateOfAPerfectEstimatorWithTheBaseTwistInTheBaseFrame) {
  const SimTruth t = some_truth();
  const SensorSample sensors = some_sensors();
  TruthState truth_state;
  TruthState::Outputs out;
  truth_state.step({.sensors = sensors, .truth = t}, out);
  ASSERT_TRUE(out.valid);
  EXPECT_EQ(out.report.outcome, hpr::StepOutcome::kRunning);
  EXPECT_EQ(out.report.fault("truth").change, hpr::StepReport::Change::kCleared);
  const EstimatedState& s = out.state;
  const Eigen::Quaterniond qb(t.quat_WB(0), t.quat_WB(1), t.quat_WB(2), t.quat_WB(3));
  EXPECT_EQ(s.tick, 12);
  EXPECT_EQ(s.time, 0.012);
  EXPECT_EQ(s.q.head<3>(), t.p_WB);
  EXPECT_TRUE(Eigen::Quaterniond(s.q.segment<4>(3)).isApprox(qb, 1e-15));
  EXPECT_EQ(s.q.tail(4), sensors.q);
  // v holds the base's twist in the base frame: rotated back, the world's.
  EXPECT_LT((qb.toRotationMatrix() * s.v.head<3>() - t.v_WB).norm(), 1e-14);
  EXPECT_LT((qb.toRotationMatrix() * s.v.segment<3>(3) - t.omega_WB).norm(), 1e-14);
  EXPECT_EQ(s.v.tail(4), sensors.qd);
  EXPECT_EQ(s.p_com, t.p_WCom);
  EXPECT_EQ(s.v_com, t.v_WCom);
  EXPECT_TRUE(s.contact[0]);
  EXPECT_FALSE(s.contact[1]);
  EXPECT_EQ(s.foot_force_z[0], 300.0);
  EXPECT_EQ(s.foot_wrench_W[0], t.contact_wrench_W[0]);
}

TEST(TruthState, ATickWithoutItsTruthGivesNoStateAndSaysWhy) {
  const SensorSample sensors = some_sensors();
  TruthState truth_state;
  TruthState::Outputs out;
  truth_state.step({.sensors = sensors, .truth = std::nullopt}, out);
  EXPECT_FALSE(out.valid);
  EXPECT_EQ(out.report.outcome, hpr::StepOutcome::kNotReady);
  ASSERT_TRUE(out.report.raised("truth"));
  EXPECT_NE(out.report.fault("truth").message().find("no SIM_TRUTH"), std::string_view::npos);
  // The truth back: a state again.
  const SimTruth t = some_truth();
  truth_state.step({.sensors = sensors, .truth = t}, out);
  EXPECT_TRUE(out.valid);
  EXPECT_FALSE(out.report.raised("truth"));
}

}  // namespace
