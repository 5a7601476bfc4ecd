// The motion optimisation (13)-(17) on its own: CAM tracking when the posture weight vanishes, the
// posture converging at the rate K_p, limits respected under a large CAM reference, the commanded
// CAM against the model's centroidal momentum matrix, and a change of the adjusted set without a
// jump.
#include <gtest/gtest.h>

#include "hpr/motion_opt/optimizer.hpp"
#include "model_fixture.hpp"

namespace {

using namespace hpr;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

constexpr double kDt = 1e-3;

class MotionOptTest : public ::testing::Test {
 protected:
  explicit MotionOptTest(std::vector<std::string> overrides = {})
      : cfg(Config::load(test::source_dir() + "/config/toro.yaml", overrides)),
        robot(model::RobotSpec::load(cfg.section("robot"))),
        reference(robot, balance::PostureReferenceConfig::load(cfg.section("balance"))) {
    q = robot.standing_configuration();
    v = VectorXd::Zero(robot.model.nv);
    reference.start(q, 0.0);
    ref = reference.update(2.0);  // past the initial blend: the held standing posture
  }
  motion_opt::MotionOptConfig config(const std::vector<std::string>& overrides = {}) const {
    const Config c = Config::load(test::source_dir() + "/config/toro.yaml", overrides);
    return motion_opt::MotionOptConfig::load(c.section("motion_opt"), robot);
  }

  Config cfg;
  model::RobotSpec robot;
  balance::PostureReference reference;
  balance::TaskReference ref;
  VectorXd q, v;
};

/// The CAM of a commanded task-space velocity, computed without TaskSpace: the model velocity v
/// that gives the commanded CoM velocity, base angular velocity, sole twists and free-joint rates
/// (a square linear system of the model's own Jacobians), then the angular rows of A_G times v.
Vector3d cam_of_command(const model::RobotSpec& robot, const VectorXd& q, const balance::TaskReference& cmd) {
  const model::Model& m = robot.model;
  model::Data data(m);
  model::ccrba(m, data, q, VectorXd::Zero(m.nv));
  const int nv = m.nv, nf = static_cast<int>(robot.free_joints.size());
  MatrixXd J = MatrixXd::Zero(nv, nv);
  VectorXd rhs(nv);
  J.topRows<3>() = data.Jcom;
  rhs.head<3>() = cmd.v_com;
  J.block(3, 3, 3, 3) = data.oMi[0].R;  // ω_W = R ω_B
  rhs.segment<3>(3) = cmd.omega_base;
  for (int k = 0; k < 2; ++k) {
    model::Matrix6Xd Jf = model::Matrix6Xd::Zero(6, nv);
    model::frame_jacobian(m, data, robot.feet[static_cast<size_t>(k)].sole_frame, model::ReferenceFrame::kLocalWorldAligned, Jf);
    J.middleRows(6 + 6 * k, 6) = Jf;
    rhs.segment<6>(6 + 6 * k) = cmd.feet[static_cast<size_t>(k)].twist;
  }
  for (int f = 0; f < nf; ++f) {
    J(18 + f, 6 + robot.free_joints[static_cast<size_t>(f)]) = 1.0;
    rhs(18 + f) = cmd.qd_free(f);
  }
  const VectorXd vel = J.fullPivLu().solve(rhs);
  return data.Ag.bottomRows<3>() * vel;
}

TEST_F(MotionOptTest, TracksTheCamReferenceExactlyWithoutPostureWeight) {
  motion_opt::MotionOptConfig c = config();
  c.Q_p = 1e-12;
  c.Q_p_overrides.clear();
  motion_opt::MotionOptimizer opt(robot, c);
  const Vector3d l_ref(0.4, -1.2, 0.3);
  const auto& out = opt.step(q, v, ref, l_ref, true, kDt);
  ASSERT_FALSE(out.qp_failed);
  for (Eigen::Index a = 0; a < out.xad_opt.size(); ++a) {
    ASSERT_GT(out.xad_opt(a), out.xad_min(a) + 1e-6) << "no limit may be active";
    ASSERT_LT(out.xad_opt(a), out.xad_max(a) - 1e-6);
  }
  // Ā_a ẋ_a^opt + Ā_u ẋ_u^ref = l_c^ref, with Ā from the model independently of the optimiser.
  EXPECT_LT((cam_of_command(robot, q, out.command) - l_ref).norm(), 1e-8);
  EXPECT_LT((out.l_cmd - l_ref).norm(), 1e-8);
}

TEST_F(MotionOptTest, PostureConvergesAtTheRateKp) {
  // No CAM weight: the offsets decay exactly as the discrete ẋ = −K_p δ, δ_k = δ_0 (1 − K_p dt)^k.
  motion_opt::MotionOptConfig c = config();
  c.Q_l = Vector3d::Constant(1e-12);
  motion_opt::MotionOptimizer opt(robot, c);
  VectorXd delta0 = VectorXd::Zero(static_cast<Eigen::Index>(opt.coordinates().size()));
  delta0(1) = 0.08;   // base pitch
  delta0(3) = -0.1;   // waist
  delta0(6) = 0.3;    // an arm joint
  opt.set_offsets(delta0);
  const int steps = 1000;
  for (int k = 1; k <= steps; ++k) {
    opt.step(q, v, ref, Vector3d::Zero(), true, kDt);
    const double expected = std::pow(1.0 - c.K_p * kDt, k);
    for (int i : {1, 3, 6}) ASSERT_NEAR(opt.offsets()(i), delta0(i) * expected, 1e-9 * std::abs(delta0(i))) << "k " << k;
  }
  EXPECT_NEAR(opt.offsets()(6) / delta0(6), std::exp(-c.K_p * steps * kDt), 2e-3);
}

TEST_F(MotionOptTest, WithCamWeightOnlyTheMomentumFreeDirectionsKeepTheRateKp) {
  // With l_ref ≡ 0 and a uniform posture weight, H = Q_p E + Ā_aᵀ Q_l Ā_a keeps null(Ā_a) and its
  // complement apart: the part of δ that produces no CAM decays at K_p exactly, the rest no faster.
  motion_opt::MotionOptConfig c = config();
  c.Q_p_overrides.clear();
  motion_opt::MotionOptimizer opt(robot, c);
  const auto& out0 = opt.step(q, v, ref, Vector3d::Zero(), true, kDt);  // learn the adjusted set
  const std::vector<int> set = out0.adjusted;
  const int k = static_cast<int>(set.size());
  MatrixXd Aa(3, k);
  for (int a = 0; a < k; ++a) Aa.col(a) = opt.task_space().Abar().col(opt.coordinates()[static_cast<size_t>(set[static_cast<size_t>(a)])].task);
  const MatrixXd N = MatrixXd::Identity(k, k) - Aa.transpose() * (Aa * Aa.transpose()).inverse() * Aa;  // projector on null(Ā_a)
  VectorXd delta0 = VectorXd::Zero(static_cast<Eigen::Index>(opt.coordinates().size()));
  VectorXd da(k);
  for (int a = 0; a < k; ++a) da(a) = 0.05 * std::sin(1.0 + a);
  for (int a = 0; a < k; ++a) delta0(set[static_cast<size_t>(a)]) = da(a);
  opt.set_offsets(delta0);
  double prev_norm = da.norm();
  for (int s = 1; s <= 500; ++s) {
    opt.step(q, v, ref, Vector3d::Zero(), true, kDt);
    VectorXd d(k);
    for (int a = 0; a < k; ++a) d(a) = opt.offsets()(set[static_cast<size_t>(a)]);
    const double expected = std::pow(1.0 - c.K_p * kDt, s);
    ASSERT_LT((N * d - N * da * expected).norm(), 1e-9) << "step " << s;
    ASSERT_LE(d.norm(), prev_norm + 1e-15);
    ASSERT_GE(d.norm(), da.norm() * expected - 1e-12) << "no faster than K_p";
    prev_norm = d.norm();
  }
}

TEST_F(MotionOptTest, LargeConstantCamReferenceRespectsEveryLimitFor10s) {
  const motion_opt::MotionOptConfig c = config();
  motion_opt::MotionOptimizer opt(robot, c);
  const Vector3d l_ref(20.0, 40.0, 15.0);
  const model::Model& m = robot.model;
  int active_at_end = 0;
  double l_err_end = 0;
  for (int s = 0; s < 10000; ++s) {
    const auto& out = opt.step(q, v, ref, l_ref, true, kDt);
    ASSERT_FALSE(out.qp_failed) << "step " << s;
    for (Eigen::Index a = 0; a < out.xa_opt.size(); ++a) {
      ASSERT_GE(out.xa_opt(a), out.xa_min(a) - 1e-12) << opt.coordinates()[static_cast<size_t>(out.adjusted[static_cast<size_t>(a)])].name;
      ASSERT_LE(out.xa_opt(a), out.xa_max(a) + 1e-12);
    }
    const auto& cmd = out.command;
    for (size_t f = 0; f < robot.free_joints.size(); ++f) {
      const auto j = static_cast<size_t>(robot.free_joints[f]);
      const auto fi = static_cast<Eigen::Index>(f);
      ASSERT_GE(cmd.q_free(fi), m.q_lower[j] - 1e-12) << m.joint_name[j];
      ASSERT_LE(cmd.q_free(fi), m.q_upper[j] + 1e-12) << m.joint_name[j];
      ASSERT_LE(std::abs(cmd.qd_free(fi)), m.v_max[j] + 1e-9) << m.joint_name[j];
    }
    const Vector3d base_offset = model::log3(cmd.R_base * ref.R_base.transpose());
    for (int i = 0; i < 3; ++i) {
      ASSERT_GE(base_offset(i), c.base_min(i) - 1e-9);
      ASSERT_LE(base_offset(i), c.base_max(i) + 1e-9);
    }
    ASSERT_LE((cmd.omega_base - ref.omega_base).cwiseAbs().maxCoeff(), c.base_velocity + 1e-9);
    if (s == 9999) {
      l_err_end = (out.l_cmd - l_ref).norm();
      for (Eigen::Index a = 0; a < out.xa_opt.size(); ++a) {
        if (out.xa_opt(a) > out.xa_max(a) - 1e-3 || out.xa_opt(a) < out.xa_min(a) + 1e-3) ++active_at_end;
      }
    }
  }
  EXPECT_GT(active_at_end, 0) << "so large a reference must drive coordinates to their limits";
  EXPECT_GT(l_err_end, 1.0) << "and can then no longer be tracked";
}

TEST_F(MotionOptTest, CommandedCamEqualsTheModelsMomentumOfTheCommandedVelocities) {
  motion_opt::MotionOptimizer opt(robot, config());
  // A moving reference (the CoM shift of a support change) and a CAM reference, over many ticks.
  reference.request_support(balance::Support::kRight, 2.0);
  for (int s = 0; s < 1500; ++s) {
    const double t = 2.0 + kDt * (s + 1);
    const auto& r = reference.update(t);
    const Vector3d l_ref(0.5 * std::sin(3.0 * t), 2.0 * std::sin(2.0 * t), 0.0);
    const auto& out = opt.step(q, v, r, l_ref, true, kDt);
    if (s % 100 == 0) {
      EXPECT_LT((cam_of_command(robot, q, out.command) - out.l_cmd).norm(), 1e-9 * std::max(1.0, out.l_cmd.norm()))
          << "t " << t;
      Vector3d sum = Vector3d::Zero();
      for (const auto& l : out.segment_l) sum += l;
      EXPECT_LT((sum - out.l_cmd).norm(), 1e-9) << "segment contributions add up to the commanded CAM";
    }
  }
}

TEST_F(MotionOptTest, ChangingTheAdjustedSetDoesNotMakeTheCommandJump) {
  motion_opt::MotionOptimizer opt(robot, config());
  const Vector3d l_ref(0.0, 8.0, 2.0);
  balance::TaskReference r = ref;
  const model::Model& m = robot.model;
  balance::TaskReference prev;
  bool have_prev = false;
  size_t last_size = 0;
  int set_changes = 0;
  for (int s = 0; s < 3500; ++s) {
    // Double support, then the left foot off the ground (settled single support: the swing foot
    // joins x_a), then the foot set down (it leaves x_a) and double support again.
    const bool single = s >= 1000 && s < 2600, lowering = s >= 2000 && s < 2600;
    r.support = single ? balance::Support::kRight : balance::Support::kDouble;
    r.feet[1].contact = !single;
    r.settled = !lowering;
    const auto& out = opt.step(q, v, r, l_ref, true, kDt);
    if (have_prev && out.adjusted.size() != last_size) ++set_changes;
    last_size = out.adjusted.size();
    if (have_prev) {
      for (size_t f = 0; f < robot.free_joints.size(); ++f) {
        const auto fi = static_cast<Eigen::Index>(f);
        const double vmax = m.v_max[static_cast<size_t>(robot.free_joints[f])];
        ASSERT_LE(std::abs(out.command.q_free(fi) - prev.q_free(fi)), vmax * kDt + 1e-12) << "step " << s;
      }
      ASSERT_LE(model::log3(out.command.R_base * prev.R_base.transpose()).norm(), 3.0 * kDt * std::sqrt(3.0) + 1e-12);
      for (size_t k = 0; k < 2; ++k) {
        ASSERT_LE((out.command.feet[k].X_WS.p - prev.feet[k].X_WS.p).norm(), 1.0 * kDt * std::sqrt(3.0) + 1e-12) << "step " << s;
      }
    }
    prev = out.command;
    have_prev = true;
  }
  EXPECT_EQ(set_changes, 2) << "the swing foot joins and leaves x_a";
}

TEST_F(MotionOptTest, TheSwingFootNeverComesLowerThanItsClearanceAboveTheStanceSole) {
  // In single support the swing foot is an adjusted coordinate; a large CAM reference about x
  // would swing it down and under the body, onto the ground, where it takes load the contact plan
  // does not know of (the robot then tips over the sole it thinks it stands on).
  const motion_opt::MotionOptConfig c = config();
  ASSERT_GT(c.swing_clearance, 0.0);
  balance::TaskReference r = ref;
  r.support = balance::Support::kRight;
  r.settled = true;
  r.feet[1].contact = false;
  r.feet[1].X_WS.p.z() += 0.05;  // lifted 5 cm
  double lowest = 1.0;
  for (const double sign : {1.0, -1.0}) {
    for (int axis = 0; axis < 2; ++axis) {
      motion_opt::MotionOptimizer opt(robot, c);
      const Vector3d l_ref = sign * 25.0 * Vector3d::Unit(axis);
      for (int s = 0; s < 2000; ++s) {
        const auto& out = opt.step(q, v, r, l_ref, true, kDt);
        ASSERT_FALSE(out.qp_failed);
        const double height = out.command.feet[1].X_WS.p.z() - r.feet[0].X_WS.p.z();
        ASSERT_GE(height, c.swing_clearance - 1e-9) << "l_ref " << l_ref.transpose() << ", step " << s;
        lowest = std::min(lowest, height);
      }
    }
  }
  EXPECT_LT(lowest, c.swing_clearance + 1e-3) << "some reference drives the foot down to the bound (else this proves nothing)";
}

TEST_F(MotionOptTest, TheCamTaskKeepsTheMomentumOfAMovingReference) {
  // A swinging foot carries CAM of its own (Ā ẋ^ref); the CAM task asks for l_c^ref on top of it,
  // so that the upper body does not cancel a step's swing leg. Without posture weight the commanded
  // CAM is l_c^ref + Ā ẋ^ref, that momentum taken from the model independently of the optimiser.
  motion_opt::MotionOptConfig c = config();
  c.Q_p = 1e-12;
  c.Q_p_overrides.clear();
  motion_opt::MotionOptimizer opt(robot, c);
  balance::TaskReference r = ref;
  r.support = balance::Support::kRight;
  r.settled = false;  // a step's swing: the swing foot is no adjusted coordinate
  r.feet[1].contact = false;
  r.feet[1].twist << 0.8, 0.1, -0.2, 0.0, 0.0, 0.0;
  balance::TaskReference at_rest = r;
  at_rest.feet[1].twist.setZero();
  const Vector3d l_ref(0.3, -0.8, 0.2);
  const auto& out = opt.step(q, v, r, l_ref, true, kDt);
  ASSERT_FALSE(out.qp_failed);
  balance::TaskReference reference_motion = r;  // ẋ^ref alone: the reference with no offsets
  const Vector3d l_swing = cam_of_command(robot, q, reference_motion) - cam_of_command(robot, q, at_rest);
  ASSERT_GT(l_swing.norm(), 0.5) << "the swinging leg carries momentum worth testing";
  EXPECT_LT((out.l_cmd - (l_ref + l_swing)).norm(), 1e-6);
}

TEST_F(MotionOptTest, ATouchdownDoesNotMakeTheCamRateJump) {
  // At touchdown the swing foot's reference twist drops to zero in one tick. The commanded CAM
  // jumps by the swing leg's momentum there; its difference quotient would be an impulse of
  // hundreds of N m that no CoM wrench should follow: the rate of the tick before is kept.
  motion_opt::MotionOptimizer opt(robot, config());
  balance::TaskReference r = ref;
  r.support = balance::Support::kRight;
  r.settled = false;
  r.feet[1].contact = false;
  r.feet[1].twist << 0.0, 0.0, -0.3, 0.0, 0.0, 0.0;
  Vector3d l_before = Vector3d::Zero(), ldot_before = Vector3d::Zero();
  for (int s = 0; s < 200; ++s) {
    const auto& out = opt.step(q, v, r, Vector3d::Zero(), false, kDt);
    l_before = out.l_cmd;
    ldot_before = out.ldot_cmd;
  }
  r.support = balance::Support::kDouble;
  r.feet[1].contact = true;
  r.feet[1].twist.setZero();
  const auto& out = opt.step(q, v, r, Vector3d::Zero(), false, kDt);
  ASSERT_GT((out.l_cmd - l_before).norm() / kDt, 50.0) << "the commanded CAM does jump at the touchdown";
  EXPECT_LT((out.ldot_cmd - ldot_before).norm(), 1e-9) << "its rate does not";
  const auto& next = opt.step(q, v, r, Vector3d::Zero(), false, kDt);
  EXPECT_LT(next.ldot_cmd.norm(), 50.0) << "differences resume after the touchdown";
}

TEST_F(MotionOptTest, StaleReferenceMeansPostureOnly) {
  motion_opt::MotionOptimizer opt(robot, config());
  const auto& out = opt.step(q, v, ref, Vector3d(50, 50, 50), false, kDt);
  EXPECT_TRUE(out.reference_stale);
  EXPECT_LT(out.l_ref.norm(), 1e-15);
  EXPECT_LT(out.l_cmd.norm(), 1e-9) << "standing still with no offsets: no CAM";
}

TEST_F(MotionOptTest, ConfigurationIsValidated) {
  const std::string path = test::source_dir() + "/config/toro.yaml";
  EXPECT_THROW(motion_opt::MotionOptConfig::load(Config::load(path, {"motion_opt.adjusted.double=[base_rotation, r_knee]"}).section("motion_opt"), robot),
               ConfigError)
      << "a leg joint cannot be adjusted";
  EXPECT_THROW(motion_opt::MotionOptConfig::load(Config::load(path, {"motion_opt.adjusted.double=[no_such_joint]"}).section("motion_opt"), robot),
               ConfigError);
  EXPECT_THROW(motion_opt::MotionOptConfig::load(Config::load(path, {"motion_opt.gains.posture=-1"}).section("motion_opt"), robot),
               ConfigError);
  EXPECT_THROW(motion_opt::MotionOptConfig::load(Config::load(path, {"motion_opt.weights.cam=[1, 2]"}).section("motion_opt"), robot),
               ConfigError);
}

}  // namespace
