// The push-trial evaluator on synthetic runs: a robot that stands still through the whole window is
// recovered; a run that ends early with nothing decided is inconclusive (a sweep runs it again),
// never "not recovered"; a fall or a tilted sole decides the trial whatever the run's length.
#include <gtest/gtest.h>

#include <cmath>

#include <humanoid/sim_truth_t.hpp>

#include "hpr/experiments/trial.hpp"
#include "model_fixture.hpp"

namespace {

using hpr::experiments::TrialEvaluator;
using hpr::experiments::TrialResult;

constexpr double kPushStart = 1.0, kPushEnd = 1.2;

/// Standing still at the origin: level pelvis and soles, half the weight on each sole centre.
humanoid::sim_truth_t standing(double t, double weight) {
  humanoid::sim_truth_t m{};
  m.sim_time = t;
  m.tick = static_cast<std::int64_t>(std::lround(t * 1e3));
  m.quat_WB[0] = 1.0;
  m.p_WCom[2] = 0.9;
  m.push_id = t >= kPushStart ? 0 : -1;
  m.push_impulse_W[0] = t >= kPushStart ? 12.0 : 0.0;
  m.num_feet = 2;
  m.p_WF = {{0.0, -0.1, 0.0}, {0.0, 0.1, 0.0}};
  m.quat_WF = {{1, 0, 0, 0}, {1, 0, 0, 0}};
  m.contact_wrench_W = {{0, 0, weight / 2, 0, 0, 0}, {0, 0, weight / 2, 0, 0, 0}};
  m.foot_tilt = {0.0, 0.0};
  return m;
}

struct Run {
  double end = 0.0;            ///< last sample [s]
  double fall_at = -1.0;       ///< fallen flag from then on
  double tilt_at = -1.0;       ///< a sole tilted by 3 deg from then on
};

TrialResult evaluate(const Run& run) {
  static const auto robot = hpr::test::load_robot("toro");
  const double weight = robot.model.mass * robot.model.gravity.norm();
  TrialEvaluator eval(robot, "double", kPushStart, kPushEnd);
  for (int k = 500; k <= static_cast<int>(std::lround(run.end * 1e3)); ++k) {
    const double t = k * 1e-3;
    auto m = standing(t, weight);
    if (run.fall_at >= 0 && t >= run.fall_at) m.fallen = true;
    if (run.tilt_at >= 0 && t >= run.tilt_at) m.foot_tilt[0] = 3.0 * M_PI / 180.0;
    eval.on_truth(m);
  }
  return eval.result();
}

TEST(TrialEvaluator, StandingThroughTheWindowIsRecovered) {
  const TrialResult r = evaluate({kPushEnd + 5.0 + 0.01});
  EXPECT_TRUE(r.completed);
  EXPECT_TRUE(r.recovered) << r.failure;
  EXPECT_FALSE(r.inconclusive);
  EXPECT_NEAR(r.impulse_W.x(), 12.0, 1e-12);
  EXPECT_NEAR(r.min_cop_margin, 0.05, 1e-9) << "CoP at the sole centre: half the sole width";
  EXPECT_EQ(r.outcome, "recovered");
}

TEST(TrialEvaluator, AWindowWithoutAPushIsAStandingTrialThatStood) {
  // push_trial --stand: the window opens and closes at the same time, judged alike.
  static const auto robot = hpr::test::load_robot("toro");
  const double weight = robot.model.mass * robot.model.gravity.norm();
  TrialEvaluator eval(robot, "double", kPushStart, kPushStart);
  for (int k = 500; k <= 6010; ++k) eval.on_truth(standing(k * 1e-3, weight));
  const TrialResult r = eval.result();
  EXPECT_TRUE(r.recovered) << r.failure;
  EXPECT_EQ(r.outcome, "stood");
  TrialEvaluator fell(robot, "double", kPushStart, kPushStart);
  for (int k = 500; k <= 3000; ++k) {
    auto m = standing(k * 1e-3, weight);
    m.fallen = k >= 2000;
    fell.on_truth(m);
  }
  EXPECT_EQ(fell.result().outcome, "fell");
}

TEST(TrialEvaluator, ARunThatEndsEarlyIsInconclusive) {
  const TrialResult r = evaluate({4.0});
  EXPECT_FALSE(r.completed);
  EXPECT_FALSE(r.recovered);
  EXPECT_TRUE(r.inconclusive);
  EXPECT_NE(r.failure.find("run ended at t = 4.00 s"), std::string::npos) << r.failure;
  EXPECT_EQ(r.outcome, "inconclusive");
}

TEST(TrialEvaluator, AFallOrATiltDecidesAShortRun) {
  const TrialResult fell = evaluate({4.0, 3.0});
  EXPECT_TRUE(fell.fallen);
  EXPECT_FALSE(fell.recovered);
  EXPECT_FALSE(fell.inconclusive);
  EXPECT_EQ(fell.outcome, "fell");
  const TrialResult tilted = evaluate({4.0, -1.0, 2.0});
  EXPECT_FALSE(tilted.recovered);
  EXPECT_FALSE(tilted.inconclusive);
  EXPECT_NE(tilted.failure.find("sole tilt 3.0 deg"), std::string::npos) << tilted.failure;
  EXPECT_EQ(tilted.outcome, "tilted");
  // Every outcome word is in the legend the tools print.
  for (const char* w : {"recovered", "stood", "fell", "tilted", "slipped", "unsettled", "inconclusive", "error", "CoP margin"}) {
    EXPECT_NE(std::string(hpr::experiments::kOutcomeLegend).find(std::string("  ") + w + " "), std::string::npos) << w;
  }
}

TEST(TrialEvaluator, WithStepsAllowedASoleThatSlidesOrTiltsBeforeAnyStepFailsAsInAStandingTrial) {
  // The same runs judged with and without steps allowed: the left sole sliding 2 cm on the ground,
  // or rolling 3 deg onto its edge and back, with no step at all. A controller that may step but
  // does not is judged as one that may not: the same verdict, the same figures.
  static const auto robot = hpr::test::load_robot("toro");
  const double weight = robot.model.mass * robot.model.gravity.norm();
  for (const bool slide : {true, false}) {
    TrialEvaluator with_steps(robot, "double", kPushStart, kPushEnd), standing_only(robot, "double", kPushStart, kPushEnd);
    with_steps.allow_steps(true);
    for (int k = 500; k <= static_cast<int>(std::lround((kPushEnd + 5.01) * 1e3)); ++k) {
      const double t = k * 1e-3;
      auto m = standing(t, weight);
      m.foot_contact = {true, true};
      if (slide && t >= 1.3) m.p_WF[1][0] = std::min(0.02, 0.1 * (t - 1.3));
      if (!slide && t >= 1.3 && t < 1.5) m.foot_tilt[1] = 3.0 * M_PI / 180.0;
      with_steps.on_truth(m);
      standing_only.on_truth(m);
    }
    const TrialResult r = with_steps.result(), s = standing_only.result();
    EXPECT_FALSE(r.recovered) << (slide ? "slide" : "tilt");
    EXPECT_EQ(r.outcome, s.outcome);
    EXPECT_EQ(r.outcome, slide ? "slipped" : "tilted");
    EXPECT_EQ(r.failure, s.failure);
    EXPECT_EQ(r.max_slip, s.max_slip);
    EXPECT_EQ(r.max_tilt_deg, s.max_tilt_deg);
    EXPECT_EQ(r.steps, 0);
    EXPECT_TRUE(with_steps.failed()) << "a sweep may stop it as it stops the standing trial";
  }
}

TEST(TrialEvaluator, WithStepsASoleThatLiftsAndLandsElsewhereIsAStepNotASlip) {
  // The planner starts a step at 1.25 s; the left sole in the air from 1.3 to 1.6 s, then down
  // 0.2 m further forward; a 10 ms loss of contact at 2 s is chatter, no step. Judged with steps
  // allowed the run is recovered with one step; judged as a standing trial the same run is a sole
  // slip. A sole that flies without a step started (a robot falling over) is no step.
  static const auto robot = hpr::test::load_robot("toro");
  const double weight = robot.model.mass * robot.model.gravity.norm();
  TrialEvaluator with_steps(robot, "double", kPushStart, kPushEnd), standing_only(robot, "double", kPushStart, kPushEnd),
      unannounced(robot, "double", kPushStart, kPushEnd);
  with_steps.allow_steps(true);
  unannounced.allow_steps(true);
  for (int k = 500; k <= static_cast<int>(std::lround((kPushEnd + 5.01) * 1e3)); ++k) {
    const double t = k * 1e-3;
    auto m = standing(t, weight);
    m.foot_contact = {true, true};
    if (t >= 1.3 && t < 1.6) {
      m.foot_contact[1] = false;
      m.contact_wrench_W[1] = {0, 0, 0, 0, 0, 0};
      m.p_WF[1][2] = 0.05;
    }
    if (t >= 1.6) m.p_WF[1][0] = 0.2;
    if (t >= 2.0 && t < 2.01) m.foot_contact[1] = false;
    humanoid::wholebody_command_t w{};  // the planner announces its step before the lift-off
    w.utime = static_cast<std::int64_t>(std::lround(t * 1e6));
    w.steps_taken = t >= 1.25 ? 1 : 0;
    for (TrialEvaluator* e : {&with_steps, &standing_only}) {
      e->on_wholebody(w);
      e->on_truth(m);
    }
    unannounced.on_truth(m);
  }
  const TrialResult u = unannounced.result();
  EXPECT_EQ(u.steps, 0) << "no step was started";
  EXPECT_EQ(u.outcome, "slipped") << u.failure;
  const TrialResult r = with_steps.result();
  EXPECT_TRUE(r.recovered) << r.failure;
  EXPECT_EQ(r.steps, 1);
  EXPECT_TRUE(r.stepping) << "the result says by which criteria it was judged";
  EXPECT_LT(r.max_slip, 1e-9) << "judged until the step: the soles had not moved";
  const TrialResult s = standing_only.result();
  EXPECT_FALSE(s.recovered);
  EXPECT_NE(s.failure.find("sole slip"), std::string::npos) << s.failure;
  EXPECT_EQ(s.outcome, "slipped");
  EXPECT_EQ(s.steps, 0) << "steps are counted only when they are allowed";
  EXPECT_FALSE(s.stepping);
  EXPECT_TRUE(hpr::experiments::overrides_enable_steps({"a.b=1", "balance.stepping.enabled=true"}));
  EXPECT_FALSE(hpr::experiments::overrides_enable_steps({"balance.stepping.enabled=true", "balance.stepping.enabled=false"}));
}

TEST(TrialEvaluator, AResultReadBackFromItsJsonIsTheSameToTheLastBit) {
  // What a trial run in another process (a pre-push checkpoint's copy) hands back.
  hpr::experiments::TrialResult r;
  r.recovered = false;
  r.fallen = true;
  r.completed = true;
  r.failure = "fell; sole tilt 3.1 deg";
  r.outcome = "fell";
  r.impulse_W = Eigen::Vector3d(0.1 / 3.0, -2.0 / 7.0, 0.0);
  r.max_tilt_deg = M_PI;
  r.max_slip = 1e-17;
  r.stepping = true;
  r.steps = 2;
  r.peak_cam = Eigen::Vector3d(1.0 / 3.0, 2.0 / 3.0, 5.0 / 9.0);
  r.peak_cam_cmd = Eigen::Vector3d(std::sqrt(2.0), 1e300, -0.0);
  r.min_cop_margin = -0.0123456789012345678;
  r.max_com_deviation = std::exp(1.0);
  r.return_time = 0.1 + 0.2;
  r.final_com_deviation = 1.0 / 7.0;
  r.final_base_angle_deg = 4.9e-324;
  r.final_joint_deg = 0.3;
  r.final_joint = "left_hip_pitch";
  r.push_start = 2.0;
  r.push_end = 2.0 + 0.6 / 3.0;
  r.sim_time = 7.21;
  r.wall_time = 1.5;
  hpr::experiments::TrialSpec spec;
  spec.config = "toro";
  const std::string json = r.to_json(spec);
  const TrialResult back = TrialResult::from_json(json);
  EXPECT_EQ(back.to_json(spec), json);
  EXPECT_EQ(back.impulse_W, r.impulse_W);
  EXPECT_EQ(back.peak_cam_cmd, r.peak_cam_cmd);
  EXPECT_EQ(back.return_time, r.return_time);
  EXPECT_EQ(back.completed, r.completed);
  EXPECT_EQ(back.final_base_angle_deg, r.final_base_angle_deg);
  EXPECT_EQ(back.outcome, "fell");
  r.return_time.reset();
  EXPECT_FALSE(TrialResult::from_json(r.to_json(spec)).return_time.has_value());
  EXPECT_THROW((void)TrialResult::from_json("{\"recovered\": true}"), std::exception);
}

}  // namespace
