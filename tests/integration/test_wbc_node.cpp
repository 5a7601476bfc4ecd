// sim_bullet, truth_state, planner and wbc as processes in lockstep (the simulator's state, in the
// estimator's place; the estimator's tests cover the estimated state): standing, a push recovered,
// BALANCE_STATUS every tick, SIGTERM; truth_state's ROBOT_STATE is SIM_TRUTH's state tick for tick.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <fstream>

#include "all_types.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/state.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;

TEST(WbcNode, StandsAndRecoversAPushInLockstep) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  auto status = lcm.collect<humanoid::balance_status_t>("BALANCE_STATUS");
  auto states = lcm.collect<humanoid::robot_state_t>("ROBOT_STATE");
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  const std::string scenario = hpr::test::temp_dir("wbc_push") + "/push.yaml";
  {
    std::ofstream f(scenario);
    f << "pushes:\n  - {link: pelvis, force: [65, 0, 0], start: 2.0, duration: 0.121, profile: half_sine}\n";
  }
  const pid_t truth_state = group.start("truth_state", {"--config", cfg});
  const pid_t planner = group.start("planner", {"--config", cfg});
  const pid_t wbc = group.start("wbc", {"--config", cfg, "--set", "wbc.wait_for_wholebody=false"});
  const pid_t sim = group.start("sim_bullet", {"--config", cfg, "--set", "sim.duration=6.0", "--set",
                                               "sim.scenario=" + scenario});
  ASSERT_TRUE(lcm.wait_for([&] { return !group.running(sim); }, 120s));
  // The simulator's last messages may still wait in this listener's queue when it exits.
  lcm.wait_for([&] { return truth->size() >= 6000; }, 5s);
  const auto r = group.wait(sim, 5s);
  EXPECT_EQ(r.exit_code, 0);
  ASSERT_EQ(truth->size(), 6000U);
  EXPECT_GE(status->size(), 5990U);
  const auto& last = truth->back();
  EXPECT_FALSE(last.fallen);
  EXPECT_NEAR(last.push_impulse_W[0], 5.0, 0.1);
  double peak = 0;
  for (const auto& t : *truth) peak = std::max(peak, std::abs(t.v_WCom[0]));
  EXPECT_GT(peak, 0.03) << "the push must move the robot";
  EXPECT_LT(std::abs(last.v_WCom[0]), 0.01) << "and it must come to rest";
  // Every state is the simulator's of its tick: the pelvis and the CoM as SIM_TRUTH has them (to
  // rounding: the state carries the twist in the base frame).
  ASSERT_GE(states->size(), 5990U);
  std::size_t compared = 0;
  for (const auto& st : *states) {
    const auto t = std::find_if(truth->begin(), truth->end(), [&](const humanoid::sim_truth_t& x) { return x.tick == st.tick; });
    ASSERT_NE(t, truth->end()) << "no SIM_TRUTH of tick " << st.tick;
    for (int i = 0; i < 3; ++i) {
      ASSERT_NEAR(st.p_WB[i], t->p_WB[i], 1e-12) << "tick " << st.tick;
      ASSERT_NEAR(st.v_WB[i], t->v_WB[i], 1e-12) << "tick " << st.tick;
      ASSERT_NEAR(st.p_WCom[i], t->p_WCom[i], 1e-12) << "tick " << st.tick;
    }
    for (int i = 0; i < 4; ++i) ASSERT_NEAR(std::abs(st.quat_WB[i]), std::abs(t->quat_WB[i]), 1e-12) << "tick " << st.tick;
    ++compared;
  }
  EXPECT_EQ(compared, states->size());
  for (const pid_t p : {wbc, planner, truth_state}) {
    group.signal(p, SIGTERM);
    const auto w = group.wait(p, 1000ms);
    EXPECT_TRUE(w.exited);
    EXPECT_EQ(w.exit_code, 0);
  }
}

// In lockstep the wbc steps with the motion optimiser's command of the same tick, except when the
// tick only damps: an estimate flagged unusable before any usable one started the posture
// (the planner and motion_opt then publish nothing) is answered at once, not after the timeout, so
// the chain runs on at full rate while the robot goes limp.
TEST(WbcNode, AnUnusableEstimateIsAnsweredWithoutWaitingForTheMotionOptimiser) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto commands = lcm.collect<humanoid::joint_command_t>("JOINT_COMMAND");
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  const auto robot = hpr::model::RobotSpec::load(hpr::Config::load(cfg).section("robot"));
  // wait_for_wholebody (the default) with a timeout of 5 s: 20 ticks of waiting would take 100 s.
  const pid_t wbc = group.start("wbc", {"--config", cfg, "--set", "wbc.wholebody_timeout=5.0"});
  hpr::EstimatedState s;
  s.q = robot.standing_configuration();
  s.v = Eigen::VectorXd::Zero(robot.model.nv);
  s.tau = Eigen::VectorXd::Zero(robot.model.nj);
  s.status = humanoid::robot_state_t::STATUS_IMPLAUSIBLE;
  hpr::msg::RobotNames names;
  names.joints = robot.model.joint_name;
  humanoid::robot_state_t m{};
  for (std::int64_t tick = 1; tick <= 20; ++tick) {
    s.tick = tick;
    s.time = 1e-3 * static_cast<double>(tick);
    hpr::msg::to_message(s, names, m);
    // Republished until answered (the wbc may not have subscribed yet at the first).
    ASSERT_TRUE(lcm.wait_for(
        [&] {
          if (!commands->empty() && commands->back().tick >= tick) return true;
          lcm.publish("ROBOT_STATE", m);
          return false;
        },
        60s));
    EXPECT_EQ(commands->back().mode, int{humanoid::joint_command_t::MODE_DAMP}) << "tick " << tick;
  }
  // HEALTH counts the steps that ran without a synced input after the timeout: none.
  ASSERT_TRUE(lcm.wait_for(
      [&] {
        for (const auto& h : *health) {
          if (h.node == "wbc" && h.tick >= 20) return true;
        }
        return false;
      },
      10s));
  for (const auto& h : *health) {
    if (h.node == "wbc") {
      EXPECT_EQ(h.stale_inputs, 0) << "tick " << h.tick;
    }
  }
  group.signal(wbc, SIGTERM);
  EXPECT_TRUE(group.wait(wbc, 2000ms).exited);
}

}  // namespace
