// The simulator in each engine (Bullet, MuJoCo): conservation of momentum under a push, ground
// truth against the model library, the sensors at rest, standing with stiff joint impedance,
// joint limits, determinism; and, engine-neutral, the refusal of bad commands.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "hpr/model/algorithms.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/sim/engines.hpp"
#include "hpr/sim/simulator.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::Vector3d;
using Eigen::VectorXd;

struct Robot {
  explicit Robot(const std::string& name, sim::EngineKind engine = sim::EngineKind::kBullet) {
    cfg = std::make_unique<Config>(Config::load(test::source_dir() + "/config/" + name + ".yaml"));
    spec = std::make_unique<model::RobotSpec>(model::RobotSpec::load(cfg->section("robot")));
    sim_config = sim::SimConfig::load(cfg->section("sim"));
    sim_config.engine = engine;
  }
  std::unique_ptr<Config> cfg;
  std::unique_ptr<model::RobotSpec> spec;
  sim::SimConfig sim_config;
};

sim::JointCommand hold_command(const Robot& r, double kp = 1500, double kd = 30) {
  sim::JointCommand c;
  c.resize(r.spec->model.nj);
  c.mode = sim::JointCommand::Mode::kRun;
  c.q_des = r.spec->q_joints_stand;
  sim::hold_gains(*r.spec, r.spec->standing_configuration(), kp, kd, r.sim_config.dt / r.sim_config.substeps, c.kp,
                  c.kd);
  return c;
}

/// The simulator's tests that depend on the physics run in each engine.
class SimulatorEngine : public ::testing::TestWithParam<sim::EngineKind> {};
INSTANTIATE_TEST_SUITE_P(Engines, SimulatorEngine, ::testing::Values(sim::EngineKind::kBullet, sim::EngineKind::kMujoco),
                         [](const ::testing::TestParamInfo<sim::EngineKind>& p) { return std::string(sim::to_string(p.param)); });

/// The standing robot 5 m up, without gravity: a free-floating body at rest.
VectorXd float_at_rest(Robot& r, sim::Simulator& s) {
  VectorXd q = r.spec->standing_configuration();
  q(2) = 5.0;
  s.set_state(q, VectorXd::Zero(r.spec->model.nv));
  return q;
}

TEST_P(SimulatorEngine, PushedFreeFloatingBodyGainsTheImpulse) {
  Robot r("toro", GetParam());
  r.sim_config.gravity.setZero();
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  float_at_rest(r, s);
  for (auto profile : {sim::Push::Profile::kRectangle, sim::Push::Profile::kHalfSine}) {
    const Vector3d h0 = s.truth().h_lin_W;
    sim::Push p;
    p.id = profile == sim::Push::Profile::kRectangle ? 1 : 2;
    p.link = "torso";
    p.point_L = Vector3d(-0.1, 0.05, 0.2);
    p.force_W = Vector3d(120.0, -40.0, 30.0);
    p.duration = 0.15;
    p.start = -1.0;  // now
    p.profile = profile;
    s.add_push(p);
    for (int k = 0; k < 300; ++k) s.step();
    const Vector3d dh = s.truth().h_lin_W - h0;
    EXPECT_LT((dh - p.impulse()).norm(), 0.01 * p.impulse().norm()) << "momentum change " << dh.transpose();
    EXPECT_LT((s.truth().push_impulse_W - p.impulse()).norm(), 0.01 * p.impulse().norm());
  }
}

TEST_P(SimulatorEngine, JointsStopAtTheirLimitsWhicheverLinksCollide) {
  // Free-floating and without gravity, each joint below is driven towards its lower limit by a
  // torque it would otherwise turn several radians with in 0.5 s: it stops at the URDF's limit,
  // with only the feet colliding (the configured default) as with every link colliding.
  for (const char* collisions : {"feet", "all"}) {
    Robot r("toro", GetParam());
    r.sim_config.gravity.setZero();
    r.sim_config.feet_only_collisions = std::string(collisions) == "feet";
    sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
    float_at_rest(r, s);
    const model::Model& m = r.spec->model;
    sim::JointCommand c;
    c.resize(m.nj);
    c.mode = sim::JointCommand::Mode::kRun;
    const std::vector<std::string> driven{"l_hip_yaw", "r_hip_yaw", "r_knee", "waist_yaw", "l_elbow"};
    for (const auto& name : driven) c.tau_ff(m.joint_index(name)) = -40.0;
    for (int k = 0; k < 500; ++k) {
      ASSERT_TRUE(s.set_command(c));
      s.step();
    }
    for (const auto& name : driven) {
      const auto j = m.joint_index(name);
      const double lower = m.q_lower[static_cast<size_t>(j)];
      EXPECT_GT(s.truth().q(7 + j), lower - 0.01) << collisions << " collisions: " << name << " passed its lower limit " << lower;
      EXPECT_LT(s.truth().q(7 + j), lower + 0.05) << collisions << " collisions: " << name << " was driven to its limit";
    }
  }
}

// SIM_TRUTH's point of application is the pushed link's point, placed by the model library's
// forward kinematics from the truth's own configuration.
TEST_P(SimulatorEngine, TruthPushPointIsThePushedPointOfTheLink) {
  Robot r("toro", GetParam());
  r.sim_config.gravity.setZero();
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  const VectorXd q = float_at_rest(r, s);
  sim::Push p;
  p.id = 3;
  p.link = "torso";
  p.point_L = Vector3d(-0.1, 0.05, 0.2);
  p.force_W = Vector3d(200.0, 0.0, 0.0);
  p.duration = 0.5;
  p.start = -1.0;
  p.profile = sim::Push::Profile::kRectangle;
  s.add_push(p);
  model::Data data(r.spec->model);
  const int torso = r.spec->model.frame_index("torso");
  model::forward_kinematics(r.spec->model, data, q);
  const Vector3d start_W = model::update_frame_placement(r.spec->model, data, torso).act(p.point_L);
  for (int k = 0; k < 200; ++k) s.step();  // the body has turned and moved by now
  ASSERT_TRUE(s.truth().push_active);
  model::forward_kinematics(r.spec->model, data, s.truth().q);
  const Vector3d expected_W = model::update_frame_placement(r.spec->model, data, torso).act(p.point_L);
  // The truth holds the point of the tick's last sub-step, before its integration: it may lag by
  // what the point moves in one tick.
  const double lag = (s.truth().v_WB.norm() + s.truth().omega_WB.norm() * 1.0) * r.sim_config.dt;
  EXPECT_LT((s.truth().push_point_W - expected_W).norm(), lag + 1e-9)
      << s.truth().push_point_W.transpose() << " vs " << expected_W.transpose();
  EXPECT_GT((expected_W - start_W).norm(), 0.05) << "the body moved";
}

// SIM_TRUTH's momentum comes from the engine's link states; the model library computes A_G v.
TEST_P(SimulatorEngine, TruthMomentumMatchesTheModelLibrary) {
  for (const char* name : {"toro", "h1_2"}) {
    Robot r(name, GetParam());
    sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
    test::RandomState rs(21);
    model::Data data(r.spec->model);
    for (int k = 0; k < 20; ++k) {
      VectorXd q = rs.q(r.spec->model), v = rs.v(r.spec->model);
      q(2) += 3.0;
      s.set_state(q, v);
      model::ccrba(r.spec->model, data, q, v);
      const auto& t = s.truth();
      EXPECT_LT((t.l_WCom - data.hg.tail<3>()).norm(), 1e-6 * data.hg.tail<3>().norm()) << name;
      EXPECT_LT((t.h_lin_W - data.hg.head<3>()).norm(), 1e-6 * data.hg.head<3>().norm()) << name;
      EXPECT_LT((t.p_WCom - data.com).norm(), 1e-9) << name;
      EXPECT_LT((t.v_WCom - data.vcom).norm(), 1e-9 * std::max(1.0, data.vcom.norm())) << name;
    }
  }
}

// Stiff joint impedance around the standing posture, no balance controller: upright for 10 s, the
// soles neither slide nor sink.
TEST_P(SimulatorEngine, StandsWithStiffJointImpedance) {
  for (const char* name : {"toro", "h1_2"}) {
    Robot r(name, GetParam());
    sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
    const auto c = hold_command(r);
    const auto p0 = s.truth().p_WF;
    double slip = 0, sink = 0, tilt = 0;
    for (int k = 0; k < 10000; ++k) {
      ASSERT_TRUE(s.set_command(c));
      s.step();
      const auto& t = s.truth();
      for (int f = 0; f < 2; ++f) {
        slip = std::max(slip, (t.p_WF[static_cast<size_t>(f)].head<2>() - p0[static_cast<size_t>(f)].head<2>()).norm());
        sink = std::max(sink, -t.p_WF[static_cast<size_t>(f)].z());
        tilt = std::max(tilt, t.foot_tilt[static_cast<size_t>(f)]);
      }
      ASSERT_FALSE(t.fallen) << name << " fell at " << t.time;
    }
    std::printf("%s: slip %.4f mm, sink %.4f mm, tilt %.5f rad\n", name, slip * 1e3, sink * 1e3, tilt);
    EXPECT_LT(slip, 1e-3) << name;
    EXPECT_LT(sink, 2e-3) << name;
    EXPECT_LT(tilt, 0.01) << name;
    // Both soles carry the weight.
    const auto& t = s.truth();
    EXPECT_NEAR(t.contact_wrench_W[0](2) + t.contact_wrench_W[1](2), r.spec->model.mass * 9.81, 0.05 * r.spec->model.mass * 9.81);
  }
}

TEST_P(SimulatorEngine, SensorsAtRestAreConsistent) {
  Robot r("toro", GetParam());
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  const auto c = hold_command(r);
  for (int k = 0; k < 3000; ++k) {  // let the hand-over from the settling gains die out
    s.set_command(c);
    s.step();
  }
  Vector3d acc = Vector3d::Zero();
  double fz = 0;
  for (int k = 0; k < 1000; ++k) {
    s.set_command(c);
    s.step();
    acc += s.sensors().imu_accel_B;
    fz += s.sensors().ft_wrench_S[0](2) + s.sensors().ft_wrench_S[1](2);
  }
  acc /= 1000;
  fz /= 1000;
  // The accelerometer measures minus gravity, in the IMU frame.
  const Eigen::Quaterniond q(s.sensors().imu_quat_WB(0), s.sensors().imu_quat_WB(1), s.sensors().imu_quat_WB(2),
                             s.sensors().imu_quat_WB(3));
  EXPECT_LT((q.toRotationMatrix() * acc - Vector3d(0, 0, 9.81)).norm(), 0.05);
  EXPECT_LT(s.sensors().imu_gyro_B.norm(), 0.01);
  // The ankle sensors carry the weight above the sensors: the whole robot minus the two feet.
  const double feet = 2 * 1.6;
  EXPECT_NEAR(fz, (r.spec->model.mass - feet) * 9.81, 5.0);
}

TEST_P(SimulatorEngine, IsDeterministic) {
  Robot r("toro", GetParam());
  sim::Simulator a(*r.spec, r.sim_config, sim::make_engine), b(*r.spec, r.sim_config, sim::make_engine);
  auto c = hold_command(r, 800, 20);
  sim::Push p;
  p.link = "torso";
  p.force_W = Vector3d(60, 0, 0);
  p.start = 0.2;
  p.duration = 0.2;
  a.add_push(p);
  b.add_push(p);
  for (int k = 0; k < 1500; ++k) {
    c.tau_ff(0) = 5.0 * std::sin(k * 0.01);
    a.set_command(c);
    b.set_command(c);
    a.step();
    b.step();
    ASSERT_EQ(a.sensors().q, b.sensors().q) << "tick " << k;
    ASSERT_EQ(a.sensors().qd, b.sensors().qd) << "tick " << k;
    ASSERT_EQ(a.sensors().imu_accel_B, b.sensors().imu_accel_B) << "tick " << k;
    ASSERT_EQ(a.sensors().ft_wrench_S[0], b.sensors().ft_wrench_S[0]) << "tick " << k;
    ASSERT_EQ(a.truth().l_WCom, b.truth().l_WCom) << "tick " << k;
    ASSERT_EQ(a.truth().contact_wrench_W[1], b.truth().contact_wrench_W[1]) << "tick " << k;
  }
}

TEST(Simulator, BadCommandsAreRefusedThenStaleCommandsDamp) {
  Robot r("toro");
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  const auto good = hold_command(r);
  for (int k = 0; k < 500; ++k) {
    ASSERT_TRUE(s.set_command(good));
    s.step();
  }
  const VectorXd tau_good = s.applied_torque();
  auto nan = good;
  nan.tau_ff(3) = std::nan("");
  auto small = good;
  small.resize(5);
  auto negative = good;
  negative.kd(0) = -1;
  std::string why;
  EXPECT_FALSE(s.set_command(nan, &why));
  EXPECT_EQ(why, "non-finite value");
  EXPECT_FALSE(s.set_command(small, &why));
  EXPECT_NE(why.find("expected 27 joints"), std::string::npos) << why;
  EXPECT_FALSE(s.set_command(negative, &why));
  EXPECT_EQ(s.rejected_commands(), 3);
  // The last valid command is still applied.
  s.step();
  EXPECT_FALSE(s.command_stale());
  EXPECT_LT((s.applied_torque() - tau_good).norm(), 0.05 * tau_good.norm());
  // After the configured age without a valid command: damping only.
  const int ticks = static_cast<int>(r.sim_config.command_timeout / r.sim_config.dt) + 2;
  for (int k = 0; k < ticks; ++k) s.step();
  EXPECT_TRUE(s.command_stale());
  const VectorXd qd = s.truth().v.tail(r.spec->model.nj);
  for (int j = 0; j < r.spec->model.nj; ++j) {
    // τ = −kd q̇ with q̇ of the last physics step (before the step whose velocity is reported).
    EXPECT_LE(std::abs(s.applied_torque()(j)), r.sim_config.damping_kd * (std::abs(qd(j)) + 0.01));
    EXPECT_NE(s.sensors().drive_status[static_cast<size_t>(j)] & 2, 0);
  }
}

// Held joints: out of the commands and sensors, held at their positions by the simulator.
TEST_P(SimulatorEngine, HeldJointsStayAtTheirPositionsOutsideTheCommands) {
  auto cfg = Config::load(test::source_dir() + "/config/toro.yaml",
                          {"robot.held_joints={r_wrist_yaw: 0.4, l_wrist_pitch: -0.6, neck_yaw: -0.2}"});
  const auto spec = model::RobotSpec::load(cfg.section("robot"));
  auto sim_config = sim::SimConfig::load(cfg.section("sim"));
  sim_config.engine = GetParam();
  ASSERT_EQ(spec.model.nj, 24);
  sim::Simulator s(spec, sim_config, sim::make_engine);
  EXPECT_EQ(s.simulated_model().nj, 27);
  EXPECT_EQ(s.sensors().q.size(), 24);
  sim::JointCommand c;
  c.resize(spec.model.nj);
  c.mode = sim::JointCommand::Mode::kRun;
  c.q_des = spec.q_joints_stand;
  sim::hold_gains(spec, spec.standing_configuration(), 1500, 30, sim_config.dt / sim_config.substeps, c.kp, c.kd);
  // Swing the right shoulder: the held wrist must not follow its inertia away from 0.4.
  const int shoulder = spec.model.joint_index("r_shoulder_pitch");
  for (int k = 0; k < 1000; ++k) {
    c.q_des(shoulder) = spec.q_joints_stand(shoulder) + 0.6 * std::sin(2 * M_PI * k / 1000.0);
    ASSERT_TRUE(s.set_command(c));
    s.step();
    ASSERT_EQ(s.truth().q_held.size(), 3);
    for (Eigen::Index h = 0; h < 3; ++h) {
      const std::string& name = spec.model.held_joint_name[static_cast<size_t>(h)];
      EXPECT_NEAR(s.truth().q_held(h), spec.held.at(name), 0.02) << name << " at tick " << k;
    }
  }
  EXPECT_FALSE(s.truth().fallen);
  EXPECT_NEAR(s.truth().q(7 + shoulder), spec.q_joints_stand(shoulder), 0.1);
}

// Held joints welded (sim.held_joints.rigid): Bullet integrates the controllers' joints only, the
// held links fixed at their held positions, so the simulated CoM and momentum are the controllers'
// model's (held joints fixed there too) for any state; the held drives' commands are accepted and
// change nothing.
TEST_P(SimulatorEngine, RigidHeldJointsAreWeldedAtTheirPositions) {
  auto cfg = Config::load(test::source_dir() + "/config/toro.yaml",
                          {"robot.held_joints={r_wrist_yaw: 0.4, l_wrist_pitch: -0.6, neck_yaw: -0.2}",
                           "sim.held_joints.rigid=true"});
  const auto spec = model::RobotSpec::load(cfg.section("robot"));
  auto sim_config = sim::SimConfig::load(cfg.section("sim"));
  sim_config.engine = GetParam();
  ASSERT_TRUE(sim_config.held_rigid);
  sim::Simulator s(spec, sim_config, sim::make_engine);
  EXPECT_EQ(s.simulated_model().nj, 24);
  test::RandomState rs(3);
  model::Data data(spec.model);
  for (int k = 0; k < 5; ++k) {
    VectorXd q = rs.q(spec.model), v = rs.v(spec.model);
    q(2) += 3.0;
    s.set_state(q, v);
    model::ccrba(spec.model, data, q, v);
    EXPECT_LT((s.truth().p_WCom - data.com).norm(), 1e-9);
    EXPECT_LT((s.truth().l_WCom - data.hg.tail<3>()).norm(), 1e-6 * data.hg.tail<3>().norm());
  }
  s.reset();  // stands again: the random states above count as falls until then
  sim::JointCommand held;
  held.resize(2);
  EXPECT_FALSE(s.set_held_command(held)) << "three held drives, not two";
  held.resize(3);
  held.mode = sim::JointCommand::Mode::kRun;
  held.q_des.setConstant(1.0);
  held.kp.setConstant(100.0);
  EXPECT_TRUE(s.set_held_command(held));
  sim::JointCommand c;
  c.resize(spec.model.nj);
  c.mode = sim::JointCommand::Mode::kRun;
  c.q_des = spec.q_joints_stand;
  sim::hold_gains(spec, spec.standing_configuration(), 1500, 30, sim_config.dt / sim_config.substeps, c.kp, c.kd);
  for (int k = 0; k < 300; ++k) {
    ASSERT_TRUE(s.set_command(c));
    s.step();
  }
  ASSERT_EQ(s.truth().q_held.size(), 3);
  for (Eigen::Index h = 0; h < 3; ++h) {
    const std::string& name = spec.model.held_joint_name[static_cast<size_t>(h)];
    EXPECT_EQ(s.truth().q_held(h), spec.held.at(name)) << name;
    EXPECT_EQ(s.truth().v_held(h), 0.0) << name;
  }
  EXPECT_FALSE(s.truth().fallen);
}

}  // namespace

namespace {

// Model uncertainty: a body simulated heavier, with its centre of mass moved, as the configuration
// says; the simulator's momentum and CoM (from Bullet's link states) then match the model library
// on the same changed body and differ from the controllers' model by the expected amounts.
TEST_P(SimulatorEngine, ModelErrorChangesTheSimulatedBodyOnly) {
  Robot r("toro", GetParam());
  r.sim_config.model_error = {{"torso", 1.1, Vector3d(0.02, 0.0, 0.0)}};
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  model::Model changed = r.spec->model;
  const auto b = static_cast<size_t>(changed.body_index("torso"));
  const model::Inertia before = changed.inertia[b];
  changed.set_inertia(static_cast<int>(b), model::Inertia::from_com(1.1 * before.m, before.com() + Vector3d(0.02, 0, 0), 1.1 * before.inertia_about_com()));
  EXPECT_NEAR(changed.mass - r.spec->model.mass, 0.1 * before.m, 1e-12);
  test::RandomState rs(5);
  model::Data data(changed), nominal(r.spec->model);
  for (int k = 0; k < 10; ++k) {
    VectorXd q = rs.q(changed), v = rs.v(changed);
    q(2) += 3.0;
    s.set_state(q, v);
    model::ccrba(changed, data, q, v);
    model::ccrba(r.spec->model, nominal, q, v);
    const auto& t = s.truth();
    EXPECT_LT((t.p_WCom - data.com).norm(), 1e-9);
    EXPECT_LT((t.l_WCom - data.hg.tail<3>()).norm(), 1e-6 * data.hg.tail<3>().norm());
    EXPECT_GT((t.p_WCom - nominal.com).norm(), 1e-3) << "the simulated CoM must differ from the controllers' model's";
  }
  // The simulated total mass: linear momentum / CoM velocity.
  const auto& t = s.truth();
  EXPECT_NEAR(t.h_lin_W.norm() / t.v_WCom.norm(), changed.mass, 1e-6 * changed.mass);
  // An unknown body is refused, naming the bodies there are.
  Robot bad("toro", GetParam());
  bad.sim_config.model_error = {{"trunk", 1.1, Vector3d::Zero()}};
  try {
    sim::Simulator unused(*bad.spec, bad.sim_config, sim::make_engine);
    FAIL() << "an unknown body was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no moving body named 'trunk'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("torso"), std::string::npos) << e.what();
  }
}

// An actuation delay of N ticks: a torque step commanded at tick k acts from tick k + N on.
TEST_P(SimulatorEngine, ActuationDelayAppliesTheCommandOfNTicksAgo) {
  for (const int delay : {0, 1, 3}) {
    Robot r("toro", GetParam());
    r.sim_config.actuation_delay_ticks = delay;
    r.sim_config.gravity.setZero();
    sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
    float_at_rest(r, s);
    sim::JointCommand c;
    c.resize(r.spec->model.nj);
    c.mode = sim::JointCommand::Mode::kRun;
    c.q_des = r.spec->q_joints_stand;  // kp = kd = 0: torque only
    const int j = r.spec->model.joint_index("r_elbow");
    std::vector<double> qdd;
    for (int k = 0; k < 8; ++k) {
      c.tau_ff(j) = k >= 2 ? 5.0 : 0.0;  // the step is commanded at tick 2
      ASSERT_TRUE(s.set_command(c));
      const double v0 = s.truth().v(6 + j);
      s.step();
      qdd.push_back(s.truth().v(6 + j) - v0);
    }
    for (int k = 0; k < 8; ++k) {
      if (k < 2 + delay) {
        EXPECT_NEAR(qdd[static_cast<size_t>(k)], 0.0, 1e-9) << "delay " << delay << ", tick " << k << ": moved before its time";
      } else {
        EXPECT_GT(qdd[static_cast<size_t>(k)], 1e-4) << "delay " << delay << ", tick " << k << ": the torque did not act";
      }
    }
  }
}

}  // namespace

namespace {

// The engine and MuJoCo's settings are validated on load, the error naming the key and its value.
TEST(SimConfig, TheEngineAndMujocoSettingsAreValidatedNamingTheKey) {
  const auto error_of = [](const std::string& yaml) -> std::string {
    try {
      (void)sim::SimConfig::load(Config::parse(yaml, "robot.yaml").section("sim"));
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of("sim: {engine: mujoco, mujoco: {condim: 4, cone: pyramidal}}"), "");
  EXPECT_NE(error_of("sim: {engine: physx}").find("sim.engine"), std::string::npos);
  const std::string condim = error_of("sim: {engine: mujoco, mujoco: {condim: 2}}");
  EXPECT_NE(condim.find("sim.mujoco.condim"), std::string::npos) << condim;
  EXPECT_NE(condim.find("1, 3, 4 or 6"), std::string::npos) << condim;
  const std::string soft = error_of("sim: {engine: mujoco, dt: 0.001, substeps: 1, mujoco: {timeconst: 0.001}}");
  EXPECT_NE(soft.find("sim.mujoco.timeconst"), std::string::npos) << soft;
  EXPECT_NE(soft.find("two physics steps"), std::string::npos) << soft;
  EXPECT_NE(error_of("sim: {mujoco: {cone: round}}").find("sim.mujoco.cone"), std::string::npos);
  const auto c = sim::SimConfig::load(Config::parse("sim: {engine: mujoco, mujoco: {impratio: 5, integrator: implicit}}", "x.yaml").section("sim"));
  EXPECT_EQ(c.engine, sim::EngineKind::kMujoco);
  EXPECT_EQ(c.mujoco.impratio, 5.0);
  EXPECT_TRUE(c.mujoco.implicit);
  EXPECT_TRUE(c.mujoco.elliptic_cone);
}

// The MuJoCo model is written from the simulated model: every body with its mass, and the
// implicit integrator and condim 4 and 6 load as well as the defaults.
TEST(SimConfig, EveryMujocoVariantBuildsAndStands) {
  for (const char* variant : {"integrator: implicit", "condim: 4", "condim: 6", "cone: pyramidal, impratio: 1"}) {
    Robot r("toro", sim::EngineKind::kMujoco);
    const auto c = sim::SimConfig::load(Config::parse(std::string("sim: {engine: mujoco, substeps: 2, mujoco: {") + variant + "}}", "x.yaml").section("sim"));
    r.sim_config.mujoco = c.mujoco;
    sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
    const auto hold = hold_command(r);
    for (int k = 0; k < 1000; ++k) {
      ASSERT_TRUE(s.set_command(hold));
      s.step();
    }
    EXPECT_FALSE(s.truth().fallen) << variant;
    const double fz = s.truth().contact_wrench_W[0](2) + s.truth().contact_wrench_W[1](2);
    EXPECT_NEAR(fz, s.simulated_model().mass * 9.81, 0.02 * s.simulated_model().mass * 9.81) << variant;
  }
  // The model as MuJoCo got it, written for its own tools: every body of the simulated model.
  Robot r("toro", sim::EngineKind::kMujoco);
  r.sim_config.mujoco.write_model = test::temp_dir("mujoco-model") + "/toro.xml";
  sim::Simulator s(*r.spec, r.sim_config, sim::make_engine);
  std::ifstream in(r.sim_config.mujoco.write_model);
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(xml.find("<freejoint"), std::string::npos);
  for (const auto& body : s.simulated_model().body_name) EXPECT_NE(xml.find("<body name=\"" + body + "\""), std::string::npos) << body;
}

}  // namespace
