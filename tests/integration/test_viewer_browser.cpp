// The viewer's page in a real browser (headless Chromium, software WebGL) on a recorded run of the
// TORO-like robot: it loads without a console error, the scene graph's joint angles are the
// logged ROBOT_STATE's at the shown tick (to 1e-9 rad), and the rendered image shows the robot
// where it stands, the push arrow while the push acts (and no arrow before), and the stepping
// strategy's capture point always and its planned step while one is under way.
#include <gtest/gtest.h>

#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>
#include <humanoid/balance_plan_t.hpp>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "hpr/common/config.hpp"
#include "hpr/model/robot.hpp"
#include "process_group.hpp"
#include "shell.hpp"
#include "viewer_support.hpp"

namespace {

using nlohmann::json;

constexpr double kPushStart = 1.0, kPushEnd = 1.3;
constexpr double kStepAhead = 0.35;  // [m] the planned step's landing ahead of the base

/// The logged angle of joint j at tick k: the standing posture plus a slow sine per joint.
double q_at(const Eigen::VectorXd& stand, std::int64_t k, int j) {
  return stand(j) + 0.2 * std::sin(2.0 * M_PI * 0.5 * 1e-3 * static_cast<double>(k) + j);
}

TEST(ViewerBrowser, PageShowsTheLoggedPostureTheRobotAndThePush) {
  const std::string web = hpr::test::source_dir() + "/viewer/web";
  ASSERT_TRUE(std::filesystem::exists(web + "/node_modules/playwright-core")) << "tools/install-web-packages " << web << " (tools/install-deps)";
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "Debian's chromium (tools/install-deps)";

  const auto spec = hpr::model::RobotSpec::load(hpr::Config::load(hpr::test::source_dir() + "/config/toro.yaml").section("robot"));
  const Eigen::VectorXd q0 = spec.standing_configuration();
  const Eigen::VectorXd stand = q0.tail(spec.model.nj);
  const std::string dir = hpr::test::temp_dir("viewer_browser");
  {
    hpr::test::LogWriter log(dir + "/run.lcm");
    for (std::int64_t k = 0; k <= 2000; ++k) {
      const double t = 1e-3 * static_cast<double>(k);
      humanoid::robot_state_t s{};
      s.tick = k;
      s.utime = 1000 * k;
      for (int i = 0; i < 3; ++i) s.p_WB[i] = q0(i);
      s.quat_WB[0] = q0(6);
      for (int i = 0; i < 3; ++i) s.quat_WB[1 + i] = q0(3 + i);
      s.p_WCom[2] = 0.85;
      s.num_joints = spec.model.nj;
      s.joint_name = spec.model.joint_name;
      for (int j = 0; j < spec.model.nj; ++j) s.q.push_back(q_at(stand, k, j));
      s.qd = s.tau = std::vector<double>(s.q.size(), 0.0);
      log.write("ROBOT_STATE", s, 1000 * k);
      humanoid::sim_truth_t tr{};
      tr.tick = k;
      tr.utime = 1000 * k;
      tr.sim_time = t;
      std::copy(std::begin(s.p_WB), std::end(s.p_WB), std::begin(tr.p_WB));
      std::copy(std::begin(s.quat_WB), std::end(s.quat_WB), std::begin(tr.quat_WB));
      tr.push_active = t >= kPushStart && t < kPushEnd;
      tr.push_force_W[0] = tr.push_active ? 120.0 : 0.0;
      tr.push_point_W[0] = q0(0) - 0.12;
      tr.push_point_W[2] = q0(2) + 0.05;
      log.write("SIM_TRUTH", tr, 1000 * k);
      // The stepping strategy (the planner's BALANCE_PLAN): the capture point runs ahead with the
      // push, and the left foot (index 1) steps 0.35 m ahead while it acts.
      humanoid::balance_plan_t wb{};
      wb.tick = k;
      wb.utime = 1000 * k;
      wb.stepping = true;
      wb.xi_W[0] = q0(0) + (tr.push_active ? 0.15 : 0.0);
      wb.xi_excess = tr.push_active ? 0.02 : -0.05;
      wb.step_foot = tr.push_active ? 1 : -1;
      wb.step_target_W[0] = q0(0) + kStepAhead;
      wb.step_target_W[1] = 0.1;  // [m] the left sole's side
      wb.step_time_left = tr.push_active ? kPushEnd - t : 0.0;
      wb.stage = tr.push_active ? humanoid::balance_plan_t::STAGE_STEP_SWING : humanoid::balance_plan_t::STAGE_HOLD;
      log.write("BALANCE_PLAN", wb, 1000 * k);
    }
  }
  hpr::test::ProcessGroup group;
  const int port = hpr::test::start_viewer(group,
                                           {"--config", hpr::test::source_dir() + "/config/toro.yaml", "--set", "viewer.port=0",
                                            "--set", "viewer.log=" + dir + "/run.lcm"},
                                           dir + "/viewer.log");
  ASSERT_GT(port, 0) << hpr::test::read_text(dir + "/viewer.log");

  const auto r = hpr::test::run_command({"node", web + "/test/browser_check.mjs", "http://127.0.0.1:" + std::to_string(port) + "/",
                                         std::to_string(0.5 * (kPushStart + kPushEnd)), "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const json out = json::parse(r.out);
  EXPECT_TRUE(out["errors"].empty()) << "the page reported: " << out["errors"].dump(1);
  ASSERT_TRUE(out.contains("push")) << r.out;
  EXPECT_EQ(out["info"]["mode"], "log");
  EXPECT_EQ(out["info"]["robot"], "toro");

  for (const char* when : {"push", "before"}) {
    SCOPED_TRACE(when);
    const json& m = out[when];
    const auto tick = m["tick"].get<std::int64_t>();
    ASSERT_EQ(m["angles"].size(), static_cast<std::size_t>(spec.model.nj)) << m["angles"].dump();
    for (int j = 0; j < spec.model.nj; ++j) {
      const auto& name = spec.model.joint_name[static_cast<std::size_t>(j)];
      EXPECT_NEAR(m["angles"][name].get<double>(), q_at(stand, tick, j), 1e-9) << name << " at tick " << tick;
    }
    // The robot's screen box is mostly robot; a box of the same size beside it is not.
    const json& p = m["pixels"];
    const double inside = p["box"]["robot"].get<double>() / p["box"]["pixels"].get<double>();
    const double beside = p["side"]["robot"].get<double>() / std::max(1.0, p["side"]["pixels"].get<double>());
    EXPECT_GT(inside, 0.2) << p.dump();
    EXPECT_LT(beside, 0.05) << p.dump();
    EXPECT_GT(p["box"]["pixels"].get<double>(), 5000.0) << "the robot is not a speck: " << m["robot_box"].dump();
  }
  EXPECT_EQ(out["push"]["tick"].get<std::int64_t>(), 1150);
  EXPECT_TRUE(out["push"]["push_visible"].get<bool>());
  EXPECT_GT(out["push"]["push_pixels"]["red"].get<int>(), 40) << out["push"]["push_pixels"].dump();
  EXPECT_FALSE(out["before"]["push_visible"].get<bool>());
  EXPECT_EQ(out["before"]["pixels"]["whole"]["red"].get<int>(), 0) << "no arrow before the push";

  // The capture point is drawn at both moments; the planned step only while a step is under way,
  // as a sole-sized outline ahead of the robot.
  EXPECT_TRUE(out["push"]["stepping"]["capture"].get<bool>());
  EXPECT_TRUE(out["push"]["stepping"]["step"].get<bool>());
  EXPECT_TRUE(out["before"]["stepping"]["capture"].get<bool>());
  EXPECT_FALSE(out["before"]["stepping"]["step"].get<bool>());
  EXPECT_GT(out["push"]["step_pixels"]["teal"].get<int>(), 100) << out["push"]["step_pixels"].dump();
  EXPECT_GT(out["before"]["capture_pixels"]["teal"].get<int>(), 20) << out["before"]["capture_pixels"].dump();
  EXPECT_GT(out["push"]["capture_pixels"]["red"].get<int>(), 20) << "red once a step is due: " << out["push"]["capture_pixels"].dump();
  // The step lies ahead (+x) of the robot; the camera looks from behind and to the right, so
  // ahead is up and to the right on the screen: its box starts right of the robot's centre.
  const json& rb = out["push"]["robot_box"];
  EXPECT_GT(out["push"]["step_box"]["x0"].get<double>(), 0.5 * (rb["x0"].get<double>() + rb["x1"].get<double>())) << out["push"].dump();
}

}  // namespace
