// Live parameters end to end: hpr_operator set changes reference_gen's α while it runs, the next
// CAM_REFERENCE uses it (τ^thres = α τ^max, (23)), the node answers on PARAMS, a refused set changes
// nothing, and the three copies hpr_operator sends are applied once.
#include <gtest/gtest.h>

#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/params_t.hpp>
#include <humanoid/robot_state_t.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "hpr/model/robot.hpp"
#include "hpr/msg/state.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;
using hpr::test::run_command;

class LiveParameters : public ::testing::Test {
 protected:
  void SetUp() override {
    refs_ = lcm_.collect<humanoid::cam_reference_t>("CAM_REFERENCE");
    params_ = lcm_.collect<humanoid::params_t>("PARAMS");
    const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
    // A standing robot's state (only its tick and time matter to reference_gen, which decodes it whole).
    const auto robot = hpr::model::RobotSpec::load(hpr::Config::load(cfg).section("robot"));
    names_.joints = robot.model.joint_name;
    state_.q = robot.standing_configuration();
    state_.v = Eigen::VectorXd::Zero(robot.model.nv);
    group_.start("reference_gen", {"--config", cfg, "--set", "reference_gen.wait_for_balance=false"});
    // The node announces its parameters once it runs.
    ASSERT_TRUE(lcm_.wait_for([&] { return !params_->empty(); }, 20s)) << "reference_gen did not start";
  }

  /// One tick: BALANCE_STATUS with ankle torque limits ±100 N m, then ROBOT_STATE; returns the
  /// CAM_REFERENCE of that tick.
  humanoid::cam_reference_t tick() {
    ++tick_;
    const std::int64_t utime = 1'000'000 + tick_ * 1000;
    humanoid::balance_status_t b{};
    b.tick = tick_;
    b.utime = utime;
    for (int k = 0; k < 3; ++k) {
      b.tau_min_V[k] = -100.0;
      b.tau_max_V[k] = 100.0;
      b.tau_ankle_V[k] = 1.0;
    }
    lcm_.publish("BALANCE_STATUS", b);
    state_.tick = tick_;
    state_.time = static_cast<double>(utime) * 1e-6;
    humanoid::robot_state_t s{};
    hpr::msg::to_message(state_, names_, s);
    lcm_.publish("ROBOT_STATE", s);
    const bool got = lcm_.wait_for([&] { return !refs_->empty() && refs_->back().tick == tick_; }, 5s);
    EXPECT_TRUE(got) << "no CAM_REFERENCE for tick " << tick_;
    return got ? refs_->back() : humanoid::cam_reference_t{};
  }

  hpr::test::CommandResult operator_cmd(std::vector<std::string> args) {
    args.insert(args.begin(), hpr::test::bin_dir() + "/hpr_operator");
    args.insert(args.end(), {"--lcm-url", group_.lcm_url()});
    if (std::find(args.begin(), args.end(), "--wait") == args.end()) args.insert(args.end(), {"--wait", "5"});
    return run_command(args);
  }

  ProcessGroup group_;
  LcmListener lcm_{group_.lcm_url()};
  std::shared_ptr<std::vector<humanoid::cam_reference_t>> refs_;
  std::shared_ptr<std::vector<humanoid::params_t>> params_;
  std::int64_t tick_ = 0;
  hpr::msg::RobotNames names_;
  hpr::EstimatedState state_;
};

TEST_F(LiveParameters, AnOperatorSetReachesTheNextStep) {
  // Before: α = 0.9 from the configuration on every axis.
  const auto before = tick();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(before.tau_thres_V[k], 90.0, 1e-12);

  const auto set = operator_cmd({"set", "reference_gen.x.alpha=0.7", "reference_gen.beta=0.35"});
  EXPECT_EQ(set.exit_code, 0) << set.out;
  EXPECT_NE(set.out.find("reference_gen: x.alpha 0.9 -> 0.7"), std::string::npos) << set.out;

  const auto after = tick();
  EXPECT_NEAR(after.tau_thres_V[0], 70.0, 1e-12);
  EXPECT_NEAR(after.tau_thres_V[1], 90.0, 1e-12);
  EXPECT_NEAR(after.tau_thres_V[2], 90.0, 1e-12);

  // The answer carries the new values; the three copies were applied once.
  lcm_.spin_for(100ms);
  const humanoid::params_t* answer = nullptr;
  for (const auto& p : *params_) {
    if (p.request_utime != 0) answer = &p;
  }
  ASSERT_NE(answer, nullptr);
  EXPECT_TRUE(answer->accepted);
  EXPECT_EQ(answer->version, 1);
  EXPECT_EQ(answer->node, "reference_gen");
  std::map<std::string, double> values;
  for (int i = 0; i < answer->num_params; ++i) values[answer->name[static_cast<size_t>(i)]] = answer->value[static_cast<size_t>(i)];
  EXPECT_EQ(values.at("x.alpha"), 0.7);
  EXPECT_EQ(values.at("y.alpha"), 0.9);
  EXPECT_TRUE(std::isnan(values.at("alpha"))) << "the axes differ";
  EXPECT_EQ(values.at("z.beta"), 0.35);
  int answers = 0;
  for (const auto& p : *params_) answers += p.request_utime == answer->request_utime ? 1 : 0;
  EXPECT_EQ(answers, 1) << "each request is answered once";
}

TEST_F(LiveParameters, ARefusedSetChangesNothing) {
  // The first pair is fine, the second outside (0, 1]: neither is applied.
  const auto r = operator_cmd({"set", "reference_gen.y.alpha=0.8", "reference_gen.x.alpha=1.5"});
  EXPECT_EQ(r.exit_code, 1);
  const auto after = tick();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(after.tau_thres_V[k], 90.0, 1e-12);
  // An unknown node: nobody answers.
  EXPECT_EQ(operator_cmd({"set", "no_such_node.alpha=0.8", "--wait", "0.3"}).exit_code, 4);
  // A get lists the parameters with their ranges.
  const auto get = operator_cmd({"params", "reference_gen"});
  EXPECT_EQ(get.exit_code, 0);
  EXPECT_NE(get.out.find("reference_gen (sets applied: 0)"), std::string::npos) << get.out;
  EXPECT_NE(get.out.find("posture_tolerance"), std::string::npos) << get.out;
}

}  // namespace

namespace {

/// Starts `processes` on config/toro.yaml; every control component announces its parameters under
/// its own name with the values of the configuration, and one OPERATOR set reaches several of them.
void announce_and_set(const std::vector<std::string>& processes) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto params = lcm.collect<humanoid::params_t>("PARAMS");
  const std::string cfg = hpr::test::source_dir() + "/config/toro.yaml";
  for (const auto& n : processes) group.start(n, {"--config", cfg});
  std::map<std::string, std::map<std::string, double>> announced;
  ASSERT_TRUE(lcm.wait_for(
      [&] {
        for (const auto& p : *params) {
          for (int i = 0; i < p.num_params; ++i) announced[p.node][p.name[static_cast<size_t>(i)]] = p.value[static_cast<size_t>(i)];
        }
        return announced.size() == 4;
      },
      30s));
  // config/toro.yaml
  EXPECT_EQ(announced["wbc"].at("com.stiffness.z"), 3000.0);
  EXPECT_EQ(announced["wbc"].at("base.damping.x"), 60.0);
  EXPECT_EQ(announced["wbc"].at("contact.friction"), 0.6);
  EXPECT_EQ(announced["motion_opt"].at("weights.posture"), 0.2);
  EXPECT_EQ(announced["motion_opt"].at("gains.posture"), 3.0);
  EXPECT_EQ(announced["estimator"].at("contact_on"), 30.0);
  EXPECT_EQ(announced["reference_gen"].at("beta"), 0.4);
  const auto set = run_command({hpr::test::bin_dir() + "/hpr_operator", "set", "wbc.com.stiffness.z=2500", "motion_opt.gains.posture=2",
                                "estimator.contact_off=8", "wbc.contact.friction=0.5", "--lcm-url", group.lcm_url(), "--wait", "5"});
  EXPECT_EQ(set.exit_code, 0) << set.out;
  EXPECT_NE(set.out.find("wbc: com.stiffness.z 3000 -> 2500 N/m, contact.friction 0.6 -> 0.5"), std::string::npos) << set.out;
  EXPECT_NE(set.out.find("motion_opt: gains.posture 3 -> 2 1/s"), std::string::npos) << set.out;
  EXPECT_NE(set.out.find("estimator: contact_off 5 -> 8 N"), std::string::npos) << set.out;
}

// Every control node announces its parameters with the values of the configuration and accepts a set.
TEST(LiveParametersOfEveryNode, AnnouncedWithTheConfiguredValuesAndSettable) {
  announce_and_set({"estimator", "wbc", "motion_opt", "reference_gen"});
}

// Composed in one process, the components answer under their own names, as the processes do.
TEST(LiveParametersOfEveryNode, TheComposedControllersAnswerForEachComponent) { announce_and_set({"controllers"}); }

}  // namespace
