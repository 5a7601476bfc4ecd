// The estimator as a process: in lockstep with sim_bullet (sensor noise on), the planner and wbc using its
// state, ROBOT_STATE for every tick close to SIM_TRUTH; a sensor dropout flagged in ROBOT_STATE
// and HEALTH; malformed ROBOT_SENSORS rejected and counted.
#include <gtest/gtest.h>

#include <csignal>

#include "all_types.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;

TEST(EstimatorNode, EstimatesInLockstepAndFlagsADropout) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  auto states = lcm.collect<humanoid::robot_state_t>("ROBOT_STATE");
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  const pid_t est = group.start("estimator", {"--config", cfg});
  group.start("planner", {"--config", cfg});
  group.start("wbc", {"--config", cfg, "--set", "wbc.wait_for_wholebody=false"});
  const pid_t sim = group.start("sim_bullet", {"--config", cfg, "--set", "sim.duration=3.0", "--set", "sim.noise.enabled=true"});
  ASSERT_TRUE(lcm.wait_for([&] { return !group.running(sim); }, 120s));
  EXPECT_EQ(group.wait(sim, 5s).exit_code, 0);
  // The simulator's last messages may still wait in this listener's queue when it exits.
  lcm.wait_for([&] { return truth->size() >= 3000; }, 5s);
  ASSERT_EQ(truth->size(), 3000U);
  // One state per tick (the last may still be in flight), each close to the truth of its tick.
  // The first state of a tick is the estimate; a later one with the same tick is the flagged
  // republication after the sensors went stale, checked below.
  std::map<std::int64_t, const humanoid::robot_state_t*> by_tick;
  for (const auto& s : *states) by_tick.emplace(s.tick, &s);
  EXPECT_GE(by_tick.size(), 2999U);
  double com_err = 0;
  int compared = 0;
  for (const auto& t : *truth) {
    auto it = by_tick.find(t.tick);
    if (it == by_tick.end() || t.tick < 300) continue;
    const auto& s = *it->second;
    double e2 = 0;
    for (int k = 0; k < 3; ++k) e2 += (s.p_WCom[k] - t.p_WCom[k]) * (s.p_WCom[k] - t.p_WCom[k]);
    com_err = std::max(com_err, std::sqrt(e2));
    EXPECT_EQ(s.status & ~humanoid::robot_state_t::STATUS_INITIALISING, 0) << "tick " << t.tick;
    ++compared;
  }
  EXPECT_GT(compared, 2600);
  EXPECT_LT(com_err, 3e-3) << "CoM estimate against SIM_TRUTH [m]";
  EXPECT_FALSE(truth->back().fallen);
  // The simulator has stopped: the estimator flags the dropout instead of holding the state.
  const auto last_tick = truth->back().tick;
  ASSERT_TRUE(lcm.wait_for(
      [&] {
        return !states->empty() && (states->back().status & humanoid::robot_state_t::STATUS_SENSOR_STALE) != 0;
      },
      2s));
  EXPECT_LE(states->back().tick, last_tick);
  ASSERT_TRUE(lcm.wait_for(
      [&] {
        for (const auto& h : *health) {
          if (h.node != "estimator") continue;
          for (const auto& f : h.faults) {
            if (f.find("ROBOT_SENSORS") != std::string::npos) return true;
          }
        }
        return false;
      },
      2s));
  // A sample for another robot (wrong joint count) is rejected and counted, and nothing is published for it.
  humanoid::robot_sensors_t bad{};
  hpr::test::Filler(7, 12).fill(bad);
  bad.tick = last_tick + 10;
  const size_t before = states->size();
  const auto health_before = health->size();
  lcm.publish("ROBOT_SENSORS", bad);
  ASSERT_TRUE(lcm.wait_for(
      [&] {
        for (size_t i = health_before; i < health->size(); ++i) {
          if ((*health)[i].node == "estimator" && (*health)[i].decode_errors >= 1) return true;
        }
        return false;
      },
      2s));
  for (size_t i = before; i < states->size(); ++i) EXPECT_NE((*states)[i].tick, bad.tick);
  group.signal(est, SIGTERM);
  const auto r = group.wait(est, 1000ms);
  EXPECT_TRUE(r.exited);
  EXPECT_EQ(r.exit_code, 0);
}

}  // namespace
