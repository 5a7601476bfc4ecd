// The estimator library on synthetic sensor samples built from the model (no simulator): the α-β
// filter against its textbook noise gains, a static pose recovered exactly, gyro bias estimation,
// the momentum observer against its closed-form response, refusal of implausible samples,
// initialisation in the air, and configuration validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include "hpr/estimator/estimator.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::Matrix3d;
using Eigen::Vector3d;

/// Sensor samples of a robot standing still in configuration q, each foot carrying `load` of its
/// weight (ground force straight up at the sole centre), from the model's kinematics and statics.
struct StaticSensors {
  StaticSensors(const model::RobotSpec& robot_in, const Eigen::VectorXd& q_in, std::array<double, 2> load = {0.5, 0.5},
                std::array<Vector3d, 2> cop_offset = {Vector3d::Zero(), Vector3d::Zero()})
      : robot(robot_in), q(q_in), data(robot_in.model) {
    const model::Model& m = robot.model;
    model::forward_kinematics(m, data, q);
    model::update_frame_placements(m, data);
    sample.resize(m.nj);
    sample.q = q.tail(m.nj);
    const model::SE3& X_WI = data.oMf[static_cast<size_t>(robot.imu_frame)];
    const Eigen::Quaterniond quat(X_WI.R);
    sample.imu_quat_WB = Eigen::Vector4d(quat.w(), quat.x(), quat.y(), quat.z());
    sample.imu_accel_B = X_WI.R.transpose() * (-m.gravity);
    // Each sole's centre of pressure is shifted by (CoM − mid-point of the soles) horizontally, so
    // that the ground forces have no moment about the CoM (static equilibrium).
    const Vector3d com = model::center_of_mass(m, data, q);
    model::update_frame_placements(m, data);
    const Vector3d mid = 0.5 * (data.oMf[static_cast<size_t>(robot.feet[0].sole_frame)].p +
                                data.oMf[static_cast<size_t>(robot.feet[1].sole_frame)].p);
    const Vector3d shift(com.x() - mid.x(), com.y() - mid.y(), 0.0);
    for (size_t k = 0; k < 2; ++k) {
      const Vector3d f_ground(0, 0, load[k] * m.mass * -m.gravity.z());
      const Vector3d cop = shift + cop_offset[k];
      set_ft_reading(k, f_ground, data.oMf[static_cast<size_t>(robot.feet[k].sole_frame)].p + cop);
      tau_sole[k] = cop.cross(f_ground);
    }
  }
  /// Foot k's sensor reading (foot on leg = ground force f_ground at p_W + the foot's weight, about
  /// the sensor origin, sensor axes) in the configuration of `data`.
  void set_ft_reading(size_t k, const Vector3d& f_ground, const Vector3d& p_W) {
    const model::Model& m = robot.model;
    const model::SE3& X_WF = data.oMf[static_cast<size_t>(robot.feet[k].ft_frame)];
    const model::Inertia& I = data.Iw[static_cast<size_t>(m.frames[static_cast<size_t>(robot.feet[k].ft_frame)].body)];
    const Vector3d f = f_ground + I.m * m.gravity;
    const Vector3d tau = (p_W - X_WF.p).cross(f_ground) + (I.com() - X_WF.p).cross(I.m * m.gravity);
    sample.ft_wrench_S[k].head<3>() = X_WF.R.transpose() * f;
    sample.ft_wrench_S[k].tail<3>() = X_WF.R.transpose() * tau;
  }
  const model::RobotSpec& robot;
  Eigen::VectorXd q;
  model::Data data;
  SensorSample sample;
  std::array<Vector3d, 2> tau_sole{};  ///< moment of the ground force about each sole centre, world axes
};

Eigen::VectorXd standing_with_yaw(const model::RobotSpec& robot, double yaw) {
  Eigen::VectorXd q = robot.standing_configuration();
  const Matrix3d Rz = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  q.head<3>() = Rz * q.head<3>();
  const Eigen::Quaterniond quat(Rz * model::base_quaternion(q).toRotationMatrix());
  q.segment<4>(3) = quat.coeffs();
  return q;
}

double angle(const Eigen::VectorXd& qa, const Eigen::VectorXd& qb) {
  return model::base_quaternion(qa).angularDistance(model::base_quaternion(qb));
}

/// Hip, knee and ankle pitch rates `rate`, −2 `rate` and `rate` (summing to zero): the leg says its
/// sole translates without turning.
void translate_sole(SensorSample& s, int hip, int knee, int ankle, double rate) {
  s.qd(hip) = rate;
  s.qd(knee) = -2.0 * rate;
  s.qd(ankle) = rate;
}

class EstimatorTest : public ::testing::Test {
 protected:
  model::RobotSpec robot = test::load_robot("toro");
};

TEST(AlphaBeta, NoiseGainsMatchTheTextbookFormulas) {
  // Steady-state α-β filter on a ramp with white position noise σ: no bias, and the variances of
  // the position and velocity errors (Kalata 1984):
  //   σ_p² = σ² (2α² + β(2 − 3α)) / (α (4 − 2α − β)),  σ_v² = σ² 2β² / (T² α (4 − 2α − β)).
  const double T = 1e-3, sigma = 1e-4;
  const Eigen::Vector2d ab = estimator::alpha_beta_gains(T, 10.0, sigma);
  const double a = ab(0), b = ab(1);
  ASSERT_GT(a, 0.0);
  ASSERT_LT(a, 1.0);
  ASSERT_GT(b, 0.0);
  std::mt19937 gen(3);
  std::normal_distribution<double> noise(0.0, sigma);
  const double v = 0.7;
  double x = 0, xd = v, sum_ep = 0, sum_ev = 0, sum_ep2 = 0, sum_ev2 = 0;
  long n = 0;
  for (long k = 1; k <= 400000; ++k) {
    const double truth = v * T * static_cast<double>(k);
    const double pred = x + xd * T;
    const double r = truth + noise(gen) - pred;
    x = pred + a * r;
    xd += b * r / T;
    if (k < 2000) continue;
    const double ep = x - truth, ev = xd - v;
    sum_ep += ep;
    sum_ev += ev;
    sum_ep2 += ep * ep;
    sum_ev2 += ev * ev;
    ++n;
  }
  const double nn = static_cast<double>(n);
  const double var_p = sigma * sigma * (2 * a * a + b * (2 - 3 * a)) / (a * (4 - 2 * a - b));
  const double var_v = sigma * sigma * 2 * b * b / (T * T * a * (4 - 2 * a - b));
  EXPECT_NEAR(sum_ep2 / nn, var_p, 0.05 * var_p);
  EXPECT_NEAR(sum_ev2 / nn, var_v, 0.05 * var_v);
  EXPECT_LT(std::abs(sum_ep / nn), 0.05 * std::sqrt(var_p)) << "a ramp is tracked without bias";
  EXPECT_LT(std::abs(sum_ev / nn), 0.05 * std::sqrt(var_v));
  // More trust in the measurements (less noise) gives larger gains.
  const Eigen::Vector2d ab2 = estimator::alpha_beta_gains(T, 10.0, sigma / 10);
  EXPECT_GT(ab2(0), a);
  EXPECT_GT(ab2(1), b);
}

TEST_F(EstimatorTest, RecoversAStaticPoseExactly) {
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.4);
  StaticSensors sensors(robot, q);
  estimator::Estimator est(robot, estimator::EstimatorConfig{});
  for (int k = 0; k <= 500; ++k) {
    sensors.sample.tick = k;
    sensors.sample.time = 1e-3 * k;
    est.update(sensors.sample);
  }
  const EstimatedState& s = est.state();
  EXPECT_EQ(s.status, estimator::kStatusOk);
  EXPECT_LT((s.q.head<3>() - q.head<3>()).norm(), 1e-6) << "soles centred on the origin, as the configuration is";
  EXPECT_LT(angle(s.q, q), 1e-6);
  EXPECT_LT((s.q.tail(robot.model.nj) - q.tail(robot.model.nj)).norm(), 1e-9);
  EXPECT_LT(s.v.norm(), 1e-6);
  model::Data data(robot.model);
  EXPECT_LT((s.p_com - model::center_of_mass(robot.model, data, q)).norm(), 1e-6);
  EXPECT_LT(s.v_com.norm(), 1e-6);
  EXPECT_LT(s.l_com.norm(), 1e-6);
  EXPECT_TRUE(s.contact[0] && s.contact[1]);
  const double half_weight = 0.5 * robot.model.mass * 9.81;
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_NEAR(s.foot_force_z[k], half_weight, 1e-6);
    EXPECT_LT((s.foot_wrench_W[k].tail<3>() - sensors.tau_sole[k]).norm(), 1e-6);
  }
}

TEST_F(EstimatorTest, ASoleLoadedAtItsEdgeIsNoAnchor) {
  // The right sole carries its load at the toe and its leg says it is pitched by 0.05 rad (rotating
  // about the toe): the estimate must follow the flat left sole, not the average of the two.
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  const double toe = 0.5 * robot.feet[0].length - 0.002;
  StaticSensors sensors(robot, q, {0.5, 0.5}, {Vector3d(toe, 0, 0), Vector3d::Zero()});
  const int ankle = robot.model.joint_index("r_ankle_pitch");
  sensors.sample.q(ankle) += 0.05;
  estimator::Estimator est(robot, estimator::EstimatorConfig{});
  for (int k = 0; k <= 500; ++k) {
    sensors.sample.tick = k;
    sensors.sample.time = 1e-3 * k;
    est.update(sensors.sample);
  }
  EXPECT_TRUE(est.state().contact[0] && est.state().contact[1]) << "still in contact";
  EXPECT_LT(angle(est.state().q, q), 1e-4) << "orientation from the flat sole only";
  EXPECT_LT((est.state().q.head<3>() - q.head<3>()).norm(), 5e-3) << "half the pitched sole's centre error at most";
  // The same sample with the load at the sole centre: the pitched leg now pulls the estimate.
  StaticSensors centred(robot, q);
  centred.sample.q(ankle) += 0.05;
  estimator::Estimator est2(robot, estimator::EstimatorConfig{});
  for (int k = 0; k <= 500; ++k) {
    centred.sample.tick = k;
    centred.sample.time = 1e-3 * k;
    est2.update(centred.sample);
  }
  EXPECT_GT(angle(est2.state().q, q), 0.01);
}

TEST_F(EstimatorTest, ASoleThatTurnedWhileItWasNoAnchorCorrectsNothingWithItsOldHeading) {
  // Standing (both soles anchors), then 0.3 s in which the robot, rigid, turns by 0.1 rad about the
  // vertical with both soles loaded at their toes (pivoting: no anchor, the gyro alone follows the
  // turn), then standing again on flat soles. The soles are anchors again where they now stand: the
  // estimate keeps the heading the gyro integrated, and no sole pulls it back to where it stood.
  // Turning about the midpoint of the soles, both toes slide (5 cm/s): the velocity of a toe's CoP
  // point, which a sole rolling on its edge gives, is off here.
  const double turn = 0.1, t_turn = 0.3;
  const Vector3d toe(0.5 * robot.feet[0].length - 0.002, 0, 0);
  estimator::EstimatorConfig config;
  config.edge_velocity_noise = 0.0;
  estimator::Estimator est(robot, config);
  Eigen::VectorXd q;
  for (int k = 0; k <= 1500; ++k) {
    const double t = 1e-3 * k;
    const double s = std::clamp((t - 0.5) / t_turn, 0.0, 1.0);
    const bool turning = t > 0.5 && t < 0.5 + t_turn;
    q = standing_with_yaw(robot, turn * s);
    StaticSensors sensors(robot, q, {0.5, 0.5}, turning ? std::array<Vector3d, 2>{toe, toe} : std::array<Vector3d, 2>{Vector3d::Zero(), Vector3d::Zero()});
    const Matrix3d R_WI = sensors.data.oMf[static_cast<size_t>(robot.imu_frame)].R;
    sensors.sample.imu_gyro_B = R_WI.transpose() * Vector3d(0, 0, turning ? turn / t_turn : 0.0);
    sensors.sample.tick = k;
    sensors.sample.time = t;
    est.update(sensors.sample);
  }
  EXPECT_TRUE(est.state().contact[0] && est.state().contact[1]);
  EXPECT_LT(angle(est.state().q, q), 2e-3) << "the heading the gyro integrated, not the soles' old one (0.1 rad off)";
  EXPECT_LT((est.state().q.head<3>() - q.head<3>()).norm(), 1e-3) << "nor back to where they stood";
  EXPECT_LT(est.state().v.norm(), 1e-3) << "at rest";
}

TEST_F(EstimatorTest, ASoleRollingOnItsToeGivesTheVelocityOfTheBase) {
  // Standing still on both soles, then the robot, joints frozen, pivots forward about the right
  // sole's toe edge at ω = 0.2 rad/s with all its weight on that edge, the left sole unloaded. The
  // rotation starts at once: the base's velocity jumps (to ω × (p − p_toe), about 0.18 m/s) where
  // the accelerometer sees nothing. No sole is an anchor (the right one carries its load at its
  // edge); the toe's point at the CoP is at rest and gives the velocity. Without it (noise 0) the
  // jump is never seen.
  const model::Model& m = robot.model;
  const Eigen::VectorXd q0 = standing_with_yaw(robot, 0.0);
  model::Data d0(m);
  model::forward_kinematics(m, d0, q0);
  model::update_frame_placements(m, d0);
  const model::SE3& X_WS0 = d0.oMf[static_cast<size_t>(robot.feet[0].sole_frame)];
  const Vector3d p_toe = X_WS0.p + X_WS0.R * Vector3d(0.5 * robot.feet[0].length, 0, 0);
  const Vector3d omega(0, 0.2, 0);
  const Vector3d g = m.gravity;
  auto run = [&](double edge_noise) {
    estimator::EstimatorConfig config;
    config.edge_velocity_noise = edge_noise;
    estimator::Estimator est(robot, config);
    Vector3d v_true = Vector3d::Zero();
    for (int k = 0; k <= 600; ++k) {
      const double t = 1e-3 * k, tp = std::max(0.0, t - 0.5);
      // q: q0 rotated by exp(ω tp) about the toe edge.
      const Matrix3d R = model::exp3(omega * tp);
      Eigen::VectorXd q = q0;
      q.head<3>() = p_toe + R * (q0.head<3>() - p_toe);
      const Eigen::Quaterniond quat(R * model::base_quaternion(q0).toRotationMatrix());
      q.segment<4>(3) = quat.coeffs();
      StaticSensors sensors(robot, q);
      SensorSample& s = sensors.sample;
      if (t > 0.5) {
        const model::SE3& X_WI = sensors.data.oMf[static_cast<size_t>(robot.imu_frame)];
        s.imu_gyro_B = X_WI.R.transpose() * omega;
        s.imu_accel_B = X_WI.R.transpose() * (omega.cross(omega.cross(X_WI.p - p_toe)) - g);
        // The whole weight on the toe edge of the right sole; the left foot's sensor carries its foot.
        sensors.set_ft_reading(0, -m.mass * g, p_toe);
        sensors.set_ft_reading(1, Vector3d::Zero(), p_toe);
        v_true = omega.cross(q.head<3>() - p_toe);
      }
      s.tick = k;
      s.time = t;
      est.update(s);
    }
    EXPECT_TRUE(est.state().contact[0] && !est.state().contact[1]);
    const Vector3d v_est = model::base_quaternion(est.state().q).toRotationMatrix() * est.state().v.head<3>();
    return (v_est - v_true).norm() / v_true.norm();
  };
  const double with_toe = run(0.03), without = run(0.0);
  EXPECT_LT(with_toe, 0.05) << "relative error of the base velocity, 0.1 s into the roll";
  EXPECT_GT(without, 0.5) << "the jump the accelerometer cannot see";
}

TEST_F(EstimatorTest, ASoleThatReadsLoadedWhileItStillMovesOverridesNothingAtFirst) {
  // The robot stands still, its weight on the left sole's toe edge (no anchor) from t = 0.3 s. At
  // t = 0.5 s the right foot's sensor reads a load while its leg says the sole still moves at about
  // 0.3 m/s without turning (a swing foot's inertia on its sensor before it lands): the sole's
  // velocity measurement disagrees with the estimate, and no other sole agrees. It is no anchor to
  // trust before it has stayed in contact (kAnchorTrust, 0.1 s): the estimate stays at rest; after
  // that, an anchor that stays in contact and disagrees means the estimate is wrong, and it corrects
  // it (what the gate falls back to).
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  const int hip = robot.model.joint_index("r_hip_pitch"), knee = robot.model.joint_index("r_knee"),
            ankle = robot.model.joint_index("r_ankle_pitch");
  const Vector3d toe(0.5 * robot.feet[1].length - 0.002, 0, 0);
  estimator::EstimatorConfig config;
  config.edge_velocity_noise = 0.0;
  config.filter_joints = false;  // the leg's rates as the drives report them
  estimator::Estimator est(robot, config);
  double v_at_trust = 0.0;
  for (int k = 0; k <= 700; ++k) {
    const double t = 1e-3 * k;
    StaticSensors sensors(robot, q, t < 0.3 ? std::array<double, 2>{0.5, 0.5} : std::array<double, 2>{t < 0.5 ? 0.0 : 0.3, 1.0},
                          {Vector3d::Zero(), t < 0.3 ? Vector3d::Zero() : toe});
    if (t >= 0.5) translate_sole(sensors.sample, hip, knee, ankle, 2.0);
    sensors.sample.tick = k;
    sensors.sample.time = t;
    est.update(sensors.sample);
    if (k == 595) {
      ASSERT_TRUE(est.state().contact[0]);
      v_at_trust = est.state().v.head<3>().norm();
    }
  }
  EXPECT_LT(v_at_trust, 0.01) << "95 ms after the touchdown the estimate is still at rest";
  EXPECT_GT(est.state().v.head<3>().norm(), 0.1) << "the sole that stayed in contact moved it";
}

TEST_F(EstimatorTest, ASoleThatDropsBackFlatFromItsEdgeSettlesBeforeItCorrects) {
  // The robot stands still, the right sole flat. From t = 0.3 s the left sole, half the weight on
  // its outer edge, turns about it (its ankle roll at 3 rad/s: no anchor); at t = 0.4 s it is flat
  // again, its CoP back inside, and for 10 ms its leg's rates carry the impact (a translation of
  // the sole at about 0.2 m/s, below the velocity gate). With settle_after_roll a sole landing on
  // its face from an edge settles as after a touchdown: the impact corrects nothing, and the
  // estimate stays at rest. Without it the sole is an anchor at once and pulls the estimate along.
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  const int roll = robot.model.joint_index("l_ankle_roll"), hip = robot.model.joint_index("l_hip_pitch"),
            knee = robot.model.joint_index("l_knee"), ankle = robot.model.joint_index("l_ankle_pitch");
  const Vector3d edge(0, 0.5 * robot.feet[1].width - 0.002, 0);
  estimator::EstimatorConfig config;
  config.edge_velocity_noise = 0.0;
  config.filter_joints = false;  // the leg's rates as the drives report them
  const auto peak_speed = [&](bool settle) {
    config.settle_after_roll = settle;
    estimator::Estimator est(robot, config);
    double v_max = 0.0;
    for (int k = 0; k <= 500; ++k) {
      const double t = 1e-3 * k;
      const bool on_edge = t >= 0.3 && t < 0.4;
      StaticSensors sensors(robot, q, {0.5, 0.5}, {Vector3d::Zero(), on_edge ? edge : Vector3d::Zero()});
      if (on_edge) sensors.sample.qd(roll) = 3.0;
      if (t >= 0.4 && t < 0.41) translate_sole(sensors.sample, hip, knee, ankle, 1.2);
      sensors.sample.tick = k;
      sensors.sample.time = t;
      est.update(sensors.sample);
      EXPECT_TRUE(est.state().contact[0] && est.state().contact[1]);
      if (t >= 0.4) v_max = std::max(v_max, est.state().v.head<3>().norm());
    }
    return v_max;
  };
  EXPECT_LT(peak_speed(true), 0.01) << "the impact moved the estimate";
  EXPECT_GT(peak_speed(false), 0.05) << "what kept it at rest was the settling, not the velocity gate";
}

TEST_F(EstimatorTest, EstimatesTheGyroBias) {
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  StaticSensors sensors(robot, q);
  const Vector3d bias(0.01, -0.02, 0.005);
  sensors.sample.imu_gyro_B = bias;
  estimator::EstimatorConfig cfg;
  cfg.gyro_bias_initial = 0.03;
  estimator::Estimator est(robot, cfg);
  double worst = 0;
  for (int k = 0; k <= 10000; ++k) {
    sensors.sample.tick = k;
    sensors.sample.time = 1e-3 * k;
    est.update(sensors.sample);
    worst = std::max(worst, angle(est.state().q, q));
  }
  EXPECT_LT((est.gyro_bias() - bias).norm(), 1e-3);
  EXPECT_LT(worst, 0.1 * M_PI / 180) << "the legs hold the orientation while the bias is learnt";
  EXPECT_LT(est.state().v.segment<3>(3).norm(), 2e-3) << "angular velocity without the bias";
}

TEST_F(EstimatorTest, MomentumObserverFollowsItsClosedFormResponse) {
  // A robot at rest whose soles report an unbalanced moment τ about the CoM (the reaction to an
  // unmeasured external torque): with A_G ν = 0 the observer l̂̇ = τ + K (0 − l̂) gives
  // l̂(t) = τ/K (1 − e^{−Kt}) and l̂̇(t) = τ e^{−Kt}.
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  StaticSensors sensors(robot, q);
  const Vector3d tau_extra(3.0, -5.0, 1.0);  // added to the right sole's moment, world axes
  const model::SE3& X_WF = sensors.data.oMf[static_cast<size_t>(robot.feet[0].ft_frame)];
  sensors.sample.ft_wrench_S[0].tail<3>() += X_WF.R.transpose() * tau_extra;
  estimator::EstimatorConfig cfg;
  estimator::Estimator est(robot, cfg);
  const double K = cfg.cam_observer_gain, dt = 1e-3;
  for (int k = 0; k <= 2000; ++k) {
    sensors.sample.tick = k;
    sensors.sample.time = dt * k;
    est.update(sensors.sample);
    if (k == 0) continue;
    const double t = dt * k;
    // Forward Euler of the observer: l_k = τ/K (1 − (1 − K dt)^k).
    const double decay = std::pow(1.0 - K * dt, k);
    const Vector3d l_expected = tau_extra / K * (1.0 - decay);
    ASSERT_LT((est.state().l_com - l_expected).norm(), 1e-6 + 1e-3 * tau_extra.norm() / K) << "t = " << t;
  }
  EXPECT_LT((est.state().l_com - tau_extra / K).norm(), 1e-3);
  EXPECT_LT(est.state().ldot_com.norm(), 1e-3);
}

TEST_F(EstimatorTest, RefusesImplausibleSamplesAndKeepsTheEstimate) {
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  StaticSensors sensors(robot, q);
  estimator::Estimator est(robot, estimator::EstimatorConfig{});
  int k = 0;
  auto feed = [&](SensorSample s) {
    s.tick = k;
    s.time = 1e-3 * k;
    ++k;
    return est.update(s);
  };
  for (int i = 0; i < 300; ++i) feed(sensors.sample);
  const Eigen::VectorXd q_before = est.state().q;
  struct Case {
    const char* what;
    std::function<void(SensorSample&)> spoil;
    const char* reason;
  };
  const std::vector<Case> cases = {
      {"NaN gyro", [](SensorSample& s) { s.imu_gyro_B.x() = std::nan(""); }, "IMU"},
      {"huge acceleration", [](SensorSample& s) { s.imu_accel_B.z() = 1e3; }, "specific force"},
      {"joint out of range", [](SensorSample& s) { s.q(3) = 10.0; }, robot.model.joint_name[3].c_str()},
      {"infinite force", [](SensorSample& s) { s.ft_wrench_S[1](2) = std::numeric_limits<double>::infinity(); }, "left force/torque"},
      {"wrong size", [](SensorSample& s) { s.q.resize(3); }, "joint arrays"},
  };
  for (const auto& c : cases) {
    SensorSample s = sensors.sample;
    c.spoil(s);
    const int tick = k;
    const EstimatedState& out = feed(s);
    EXPECT_EQ(out.tick, tick) << c.what << ": the flagged state is for this tick";
    EXPECT_NE(out.status & estimator::kStatusImplausible, 0) << c.what;
    EXPECT_NE(est.implausible_reason().find(c.reason), std::string::npos) << c.what << ": " << est.implausible_reason();
    EXPECT_TRUE(out.q.allFinite()) << c.what;
    EXPECT_LT((out.q - q_before).norm(), 1e-9) << c.what << ": the estimate is kept";
  }
  // Time that does not advance.
  SensorSample again = sensors.sample;
  again.time = 0.0;
  EXPECT_NE(est.update(again).status & estimator::kStatusImplausible, 0);
  // A good sample afterwards is accepted.
  EXPECT_EQ(feed(sensors.sample).status, estimator::kStatusOk);
  EXPECT_TRUE(est.implausible_reason().empty());
}

TEST_F(EstimatorTest, AStaleJointIsPredictedAndNoEstimateStartsFromAnIncompleteSample) {
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  StaticSensors sensors(robot, q);
  estimator::Estimator est(robot, estimator::EstimatorConfig{});
  const int nj = robot.model.nj;
  auto at = [&](SensorSample s, int k) {
    s.tick = k;
    s.time = 1e-3 * k;
    return s;
  };
  // The first sample of a robot whose drives have not answered: zeros, every joint stale.
  SensorSample none = at(sensors.sample, 0);
  none.q.setZero();
  none.qd.setZero();
  for (auto& b : none.drive_status) b = SensorSample::kDriveStale;
  const EstimatedState& first = est.update(none);
  EXPECT_NE(first.status & estimator::kStatusInitialising, 0);
  EXPECT_NE(first.status & estimator::kStatusSensorStale, 0) << "no estimate yet: flagged as nothing to act on";
  for (int k = 1; k <= 400; ++k) est.update(at(sensors.sample, k));
  EXPECT_LT((est.state().q.tail(nj) - q.tail(nj)).norm(), 1e-9) << "initialised from the first complete sample";
  // A joint moving at constant velocity whose drive misses every third reply: the stale reading
  // (the previous one, held) is not taken as a measurement, so the filter keeps tracking the ramp.
  const int j = 3;
  const double v = 0.5;
  double worst = 0.0;
  for (int k = 401; k <= 700; ++k) {
    SensorSample s = at(sensors.sample, k);
    const double truth = q(7 + j) + v * 1e-3 * (k - 400);
    s.q(j) = k % 3 == 0 ? q(7 + j) + v * 1e-3 * (k - 401) : truth;  // held: last tick's value
    s.qd(j) = v;
    if (k % 3 == 0) s.drive_status[static_cast<std::size_t>(j)] = SensorSample::kDriveStale;
    est.update(s);
    if (k > 600) worst = std::max(worst, std::abs(est.state().v(6 + j) - v));
  }
  EXPECT_LT(worst, 0.01 * v) << "velocity of a joint with missed replies";
  EXPECT_NEAR(est.state().q(7 + j), q(7 + j) + v * 0.3, 1e-5);
}

TEST_F(EstimatorTest, InitialisedInTheAirPlacesTheWorldFrameAtTheFirstContact) {
  const Eigen::VectorXd q = standing_with_yaw(robot, 0.0);
  StaticSensors loaded(robot, q);
  StaticSensors hanging(robot, q, {0.0, 0.0});  // only the feet's weight on the sensors
  estimator::Estimator est(robot, estimator::EstimatorConfig{});
  for (int k = 0; k < 100; ++k) {
    hanging.sample.tick = k;
    hanging.sample.time = 1e-3 * k;
    est.update(hanging.sample);
    EXPECT_NE(est.state().status & estimator::kStatusNoContact, 0);
  }
  EXPECT_LT(angle(est.state().q, q), 1e-3) << "tilt from the accelerometer";
  for (int k = 100; k < 400; ++k) {
    loaded.sample.tick = k;
    loaded.sample.time = 1e-3 * k;
    est.update(loaded.sample);
  }
  EXPECT_EQ(est.state().status, estimator::kStatusOk);
  EXPECT_LT((est.state().q.head<3>() - q.head<3>()).norm(), 1e-5);
}

TEST(EstimatorConfig, ValidatesOnLoad) {
  const Config ok = Config::parse("estimator: {contact_on: 40, contact_off: 10}", "test.yaml");
  EXPECT_EQ(estimator::EstimatorConfig::load(ok.section("estimator")).contact_on, 40.0);
  const Config inverted = Config::parse("estimator: {contact_on: 10, contact_off: 40}", "test.yaml");
  try {
    (void)estimator::EstimatorConfig::load(inverted.section("estimator"));
    FAIL() << "inverted thresholds accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("estimator.contact_off"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.yaml"), std::string::npos) << e.what();
  }
  const Config misspelt = Config::parse("estimator: {contact_onn: 40}", "test.yaml");
  EXPECT_THROW((void)estimator::EstimatorConfig::load(misspelt.section("estimator")), ConfigError);
  const Config negative = Config::parse("estimator: {gyro_noise: -1}", "test.yaml");
  EXPECT_THROW((void)estimator::EstimatorConfig::load(negative.section("estimator")), ConfigError);
}

}  // namespace
