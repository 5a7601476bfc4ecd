// sim_bullet as a process: lockstep determinism over LCM, refusal of malformed commands, SIGTERM.
#include <algorithm>
#include <gtest/gtest.h>

#include <csignal>
#include <fstream>

#include "all_types.hpp"
#include "hpr/hal/hal.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/common/auth.hpp"
#include "lcm_listener.hpp"
#include "process_group.hpp"
#include "shell.hpp"

namespace {

using namespace std::chrono_literals;
using hpr::test::LcmListener;
using hpr::test::ProcessGroup;

struct HoldController {
  HoldController(LcmListener& lcm, const std::string& robot) : lcm_(lcm) {
    const auto cfg = hpr::Config::load(hpr::test::source_dir() + "/config/" + robot + ".yaml");
    const auto spec = hpr::model::RobotSpec::load(cfg.section("robot"));
    names_.joints = spec.model.joint_name;
    command_.resize(spec.model.nj);
    command_.mode = hpr::JointCommand::Mode::kRun;
    command_.q_des = spec.q_joints_stand;
    // Gains inside the drives' ranges (hal.drive_defaults.kp_max 1000): the simulator refuses what the hal would.
    hpr::sim::hold_gains(spec, spec.standing_configuration(), 1000, 30, 1e-3, command_.kp, command_.kd);
    lcm.lcm().subscribe("ROBOT_SENSORS", &HoldController::on_sensors, this);
  }
  void on_sensors(const lcm::ReceiveBuffer* rb, const std::string&) {
    humanoid::robot_sensors_t s;
    if (s.decode(rb->data, 0, static_cast<int>(rb->data_size)) < 0) return;
    sensors.emplace_back(static_cast<const uint8_t*>(rb->data), static_cast<const uint8_t*>(rb->data) + rb->data_size);
    command_.tick = s.tick;
    humanoid::joint_command_t m;
    hpr::msg::to_message(command_, names_, m);
    lcm_.stamp(m);  // as the wbc would: its identity and message count
    lcm_.publish("JOINT_COMMAND", m);
  }
  LcmListener& lcm_;
  hpr::msg::RobotNames names_;
  hpr::JointCommand command_;
  std::vector<std::vector<uint8_t>> sensors;
};

std::string scenario_file() {
  const std::string path = hpr::test::temp_dir("scenario") + "/push.yaml";
  std::ofstream f(path);
  f << "pushes:\n  - {link: torso, point: [0, 0, 0.1], force: [50, 0, 0], start: 0.3, duration: 0.3, profile: half_sine}\n";
  return path;
}

// Runs the simulator for `seconds` in lockstep against the hold controller; returns the encoded
// ROBOT_SENSORS and SIM_TRUTH streams.
std::pair<std::vector<std::vector<uint8_t>>, std::vector<std::vector<uint8_t>>> run_once(const std::string& scenario) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  HoldController ctl(lcm, "toro");
  std::vector<std::vector<uint8_t>> truth;
  struct TruthSink {
    std::vector<std::vector<uint8_t>>* out;
    void on(const lcm::ReceiveBuffer* rb, const std::string&) {
      out->emplace_back(static_cast<const uint8_t*>(rb->data), static_cast<const uint8_t*>(rb->data) + rb->data_size);
    }
  } sink{&truth};
  lcm.lcm().subscribe("SIM_TRUTH", &TruthSink::on, &sink);
  const pid_t pid = group.start("sim_bullet", {"--config", hpr::test::source_dir() + "/config/toro.yaml", "--set",
                                               "sim.duration=1.0", "--set", "sim.scenario=" + scenario});
  lcm.wait_for([&] { return !group.running(pid); }, 60s);
  // The simulator's last messages may still wait in this listener's queue when it exits (1 s: 1000).
  lcm.wait_for([&] { return truth.size() >= 1000; }, 5s);
  const auto r = group.wait(pid, 5s);
  EXPECT_TRUE(r.exited);
  EXPECT_EQ(r.exit_code, 0);
  return {ctl.sensors, truth};
}

TEST(SimNode, LockstepRunsAreIdentical) {
  const std::string scenario = scenario_file();
  const auto a = run_once(scenario);
  const auto b = run_once(scenario);
  ASSERT_EQ(a.first.size(), 1000U);
  ASSERT_EQ(a.first.size(), b.first.size());
  ASSERT_EQ(a.second.size(), b.second.size());
  // Byte for byte, but for the publisher's identity (`source`, bytes 24-31: each process draws its
  // own) and the authentication code over it (the last 32 bytes, each valid for the deployment's key).
  const hpr::auth::Key key = hpr::auth::load_key(hpr::auth::key_path());
  const auto same = [&key](std::vector<uint8_t> x, std::vector<uint8_t> y, std::string_view channel) {
    if (x.size() < 64 || y.size() < 64) return false;
    if (!hpr::auth::verify(x.data(), x.size(), channel, key) || !hpr::auth::verify(y.data(), y.size(), channel, key)) return false;
    const bool other_source = !std::equal(x.begin() + 24, x.begin() + 32, y.begin() + 24);
    for (auto* v : {&x, &y}) {
      std::fill(v->begin() + 24, v->begin() + 32, 0);
      std::fill(v->end() - static_cast<std::ptrdiff_t>(hpr::auth::kTagBytes), v->end(), 0);
    }
    return other_source && x == y;
  };
  for (size_t k = 0; k < a.first.size(); ++k) ASSERT_TRUE(same(a.first[k], b.first[k], "ROBOT_SENSORS")) << "ROBOT_SENSORS tick " << k;
  for (size_t k = 0; k < a.second.size(); ++k) ASSERT_TRUE(same(a.second[k], b.second[k], "SIM_TRUTH")) << "SIM_TRUTH tick " << k;
  // The push was applied: the last truth message reports its impulse.
  humanoid::sim_truth_t last;
  last.decode(a.second.back().data(), 0, static_cast<int>(a.second.back().size()));
  EXPECT_NEAR(last.push_impulse_W[0], 50 * 0.3 * 2 / M_PI, 0.01 * 50 * 0.3 * 2 / M_PI);
  EXPECT_FALSE(last.fallen);
}

TEST(SimNode, MalformedCommandsAreCountedAndRefused) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  const pid_t pid = group.start("sim_bullet", {"--config", hpr::test::source_dir() + "/config/toro.yaml", "--set",
                                               "sim.mode=realtime"});
  ASSERT_TRUE(lcm.wait_for([&] { return truth->size() > 10; }, 20s));
  const auto cfg = hpr::Config::load(hpr::test::source_dir() + "/config/toro.yaml");
  const auto spec = hpr::model::RobotSpec::load(cfg.section("robot"));
  humanoid::joint_command_t bad;
  bad.num_joints = 27;
  bad.joint_name = spec.model.joint_name;
  for (auto* v : {&bad.tau_ff, &bad.q_des, &bad.qd_des, &bad.kp, &bad.kd}) v->assign(27, 0.0);
  bad.mode = humanoid::joint_command_t::MODE_RUN;
  bad.tau_ff[4] = std::nan("");
  lcm.publish("JOINT_COMMAND", bad);
  bad.tau_ff[4] = 0.0;
  bad.num_joints = 12;
  bad.joint_name.resize(12);
  for (auto* v : {&bad.tau_ff, &bad.q_des, &bad.qd_des, &bad.kp, &bad.kd}) v->resize(12);
  lcm.publish("JOINT_COMMAND", bad);
  ASSERT_TRUE(lcm.wait_for([&] { return !health->empty() && health->back().decode_errors >= 2; }, 5s));
  EXPECT_TRUE(group.running(pid));
  group.signal(pid, SIGTERM);
  const auto r = group.wait(pid, 1000ms);
  EXPECT_TRUE(r.exited);
  EXPECT_EQ(r.exit_code, 0);
}

// The simulator refuses what the hal refuses: a run command with kp = 10^9 on one joint is refused
// and counted with the hal's own reason (its drive range from the configuration's hal section),
// while the same command with a gain inside the range is taken.
TEST(SimNode, ACommandTheHalRefusesIsRefusedByTheSimulatorWithTheHalsReason) {
  ProcessGroup group;
  LcmListener lcm(group.lcm_url());
  auto health = lcm.collect<humanoid::health_t>("HEALTH");
  auto truth = lcm.collect<humanoid::sim_truth_t>("SIM_TRUTH");
  const std::string log = hpr::test::temp_dir("sim-kp") + "/sim.log";
  const pid_t pid = group.start("sim_bullet", {"--config", hpr::test::source_dir() + "/config/toro.yaml", "--set", "sim.mode=realtime"},
                                {}, log);
  ASSERT_TRUE(lcm.wait_for([&] { return truth->size() > 10; }, 20s));
  const auto cfg = hpr::Config::load(hpr::test::source_dir() + "/config/toro.yaml");
  const auto spec = hpr::model::RobotSpec::load(cfg.section("robot"));
  hpr::msg::RobotNames names;
  names.joints = spec.model.joint_name;
  hpr::JointCommand c;
  c.resize(spec.model.nj);
  c.mode = hpr::JointCommand::Mode::kRun;
  c.q_des = spec.q_joints_stand;
  c.kp.setConstant(100.0);
  c.kd.setConstant(2.0);
  c.kp(4) = 1e9;
  const hpr::hal::HalConfig hal = hpr::hal::HalConfig::load(cfg.section("hal"), spec);
  const std::string hal_says = hpr::hal::check_command(c, hal.drives, hal.controlled);
  ASSERT_NE(hal_says.find("kp of joint '" + spec.model.joint_name[4] + "'"), std::string::npos) << hal_says;
  humanoid::joint_command_t m;
  c.tick = truth->back().tick;
  hpr::msg::to_message(c, names, m);
  lcm.stamp(m);
  lcm.publish("JOINT_COMMAND", m);
  ASSERT_TRUE(lcm.wait_for([&] { return !health->empty() && health->back().decode_errors == 1; }, 5s));
  c.kp(4) = 900.0;  // inside [0, 1000]
  ASSERT_TRUE(hpr::hal::check_command(c, hal.drives, hal.controlled).empty());
  c.tick = truth->back().tick;
  hpr::msg::to_message(c, names, m);
  lcm.stamp(m);
  lcm.publish("JOINT_COMMAND", m);
  lcm.spin_for(300ms);
  EXPECT_EQ(health->back().decode_errors, 1) << "a command inside the hal's ranges was refused";
  group.signal(pid, SIGTERM);
  EXPECT_TRUE(group.wait(pid, 2000ms).exited);
  const std::string text = hpr::test::read_file(log);
  EXPECT_NE(text.find(hal_says), std::string::npos) << "the simulator did not give the hal's reason '" << hal_says << "':\n" << text;
  EXPECT_NE(text.find("commands rejected 1,"), std::string::npos) << text;
}

}  // namespace
