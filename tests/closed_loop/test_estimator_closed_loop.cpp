// The estimator against the simulator's truth, with the sensor noise of a real robot switched on
// (gyro white noise 0.005 rad/s/√Hz with a random-walk bias, accelerometer noise 0.05 m/s²/√Hz,
// 16-bit encoders, 1 N force/torque noise), and the closed loop estimator → wbc → simulator.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdio>
#include <string>
#include <vector>

#include "closed_loop.hpp"
#include "paper.hpp"

namespace {

using Eigen::Vector3d;
using hpr::test::ClosedLoop;
using hpr::test::ClosedLoopOptions;

const std::vector<std::string> kNoise = {
    "sim.noise.enabled=true",         "sim.noise.gyro_noise_density=0.005", "sim.noise.gyro_bias_random_walk=0.0001",
    "sim.noise.gyro_bias_initial=0.005", "sim.noise.accel_noise_density=0.05", "sim.noise.encoder_bits=16",
    "sim.noise.ft_force_noise=1.0"};

double angle_between(const Eigen::Vector4d& wxyz, const Eigen::VectorXd& q) {
  const Eigen::Quaterniond a(wxyz(0), wxyz(1), wxyz(2), wxyz(3));
  const Eigen::Quaterniond b(q(6), q(3), q(4), q(5));
  return a.angularDistance(b);
}

/// Error statistics of one run.
struct Errors {
  double com_drift = 0, orientation = 0, com_vel_sq = 0, cam_sq = 0, cam_peak = 0;
  long n = 0;
};

TEST(EstimatorAccuracy, Standing30sDriftAndOrientation) {
  ClosedLoop loop("toro", kNoise, ClosedLoopOptions{.run_estimator = true});
  const auto& est = *loop.estimator;
  Vector3d e0 = Vector3d::Zero();
  bool have_e0 = false;
  Errors e;
  loop.run(30.0, [&] {
    const auto& t = loop.sim.truth();
    const auto& s = est.state();
    if (t.time < est.config().initialisation_time) return;
    const Vector3d err = s.p_com - t.p_WCom;
    if (!have_e0) {
      e0 = err;
      have_e0 = true;
    }
    e.com_drift = std::max(e.com_drift, (err - e0).norm());
    e.orientation = std::max(e.orientation, angle_between(t.quat_WB, s.q));
  });
  std::printf("standing 30 s: CoM drift %.2f mm (initial offset %.2f mm), orientation error max %.3f deg, bias %s\n",
              e.com_drift * 1e3, e0.norm() * 1e3, e.orientation * 180 / M_PI,
              fmt::format("{:.4f} {:.4f} {:.4f}", est.gyro_bias().x(), est.gyro_bias().y(), est.gyro_bias().z()).c_str());
  EXPECT_FALSE(loop.sim.truth().fallen);
  EXPECT_LT(e.com_drift, 5e-3);
  EXPECT_LT(e0.norm(), 5e-3) << "the world frame at initialisation matches the simulator's";
  EXPECT_LT(e.orientation, 0.5 * M_PI / 180);
}

// Pooled over three noise seeds: one seed's error depends on where its noise lands in the push
// (from 2.4 % to 5.4 % of the peak CAM for seeds 1 to 4). Experiment 1 in the paper's
// configuration, which keeps both feet on the ground (with seed 1's noise the default unloads a
// foot in it).
TEST(EstimatorAccuracy, During18NsPush) {
  Errors e;
  double vcom_peak = 0;
  for (const int seed : {1, 2, 3}) {
    std::vector<std::string> overrides = hpr::test::paper_and(kNoise);
    overrides.push_back(fmt::format("sim.noise.seed={}", seed));
    ClosedLoop loop("toro", overrides, ClosedLoopOptions{.cam = true, .estimator_in_loop = true});
    const double t_push = 2.0, impulse = 18.0, peak = 65.0;
    loop.push_base(impulse, peak, Vector3d::UnitX(), t_push);
    const double t_end = t_push + impulse / peak * M_PI / 2.0 + 1.0;
    const auto& est = *loop.estimator;
    double min_force = 1e9;
    int switches = 0;
    std::array<bool, 2> contact{true, true};
    loop.run(t_end + 0.5, [&] {
      const auto& t = loop.sim.truth();
      const auto& s = est.state();
      for (size_t k = 0; k < 2; ++k) {
        switches += s.contact[k] != contact[k] ? 1 : 0;
        contact[k] = s.contact[k];
        min_force = std::min(min_force, t.contact_wrench_W[k](2));
      }
      if (t.time < t_push || t.time > t_end) return;
      e.com_vel_sq += (s.v_com - t.v_WCom).squaredNorm();
      e.cam_sq += (s.l_com - t.l_WCom).squaredNorm();
      e.cam_peak = std::max(e.cam_peak, t.l_WCom.norm());
      vcom_peak = std::max(vcom_peak, t.v_WCom.norm());
      ++e.n;
    });
    EXPECT_FALSE(loop.sim.truth().fallen) << "seed " << seed;
    // Both feet stay loaded through the push (true force above the release threshold), and the
    // estimator sees no contact switch.
    EXPECT_GT(min_force, est.config().contact_off) << "seed " << seed;
    EXPECT_EQ(switches, 0) << "seed " << seed;
  }
  const double vel_rms = std::sqrt(e.com_vel_sq / static_cast<double>(e.n));
  const double cam_rms = std::sqrt(e.cam_sq / static_cast<double>(e.n));
  std::printf("18 N s push, 3 seeds: CoM velocity RMS error %.2f cm/s (peak %.2f m/s), CAM RMS error %.3f N m s = %.1f %% of peak %.2f\n",
              vel_rms * 100, vcom_peak, cam_rms, 100 * cam_rms / e.cam_peak, e.cam_peak);
  EXPECT_LT(vel_rms, 0.02);
  EXPECT_LT(cam_rms, 0.05 * e.cam_peak);
}


/// Contact switches: the left foot is unloaded, lifted, lowered and loaded again (estimator in the
/// loop), against the simulator's ground force on that foot. Touchdown is the first tick with ground
/// force after the flight (at least 50 ms without force); lift-off is the last tick before the
/// flight at which the true force, through the estimator's thresholds and hysteresis, releases the
/// foot (while a foot is unloaded its force is small and intermittent, so "the last tick with any
/// force" would measure the simulator's contact ringing rather than the estimator). The estimator must release the foot
/// and take it again within 5 ms of these, never see contact during the flight, and keep the
/// loaded stance foot throughout.
TEST(EstimatorAccuracy, ContactSwitchesWithin5ms) {
  ClosedLoop loop("toro", kNoise, ClosedLoopOptions{.estimator_in_loop = true});
  const auto& est = *loop.estimator;
  struct Sample {
    double t, fz;
    bool est_contact;
  };
  std::vector<Sample> left;
  bool stance_lost = false;
  bool requested_single = false, requested_double = false;
  loop.run(9.0, [&] {
    const auto& t = loop.sim.truth();
    if (!requested_single && t.time >= 1.0) {
      loop.request_support(hpr::balance::Support::kRight, t.time);
      requested_single = true;
    }
    if (!requested_double && t.time >= 5.0) {
      loop.request_support(hpr::balance::Support::kDouble, t.time);
      requested_double = true;
    }
    left.push_back({t.time, t.contact_wrench_W[1](2), est.state().contact[1]});
    stance_lost = stance_lost || !est.state().contact[0];
  });
  ASSERT_FALSE(loop.sim.truth().fallen);
  EXPECT_FALSE(stance_lost) << "the right foot carries the robot throughout";
  // The flight: the longest run of ticks without ground force.
  size_t best_begin = 0, best_len = 0;
  for (size_t i = 0; i < left.size();) {
    size_t j = i;
    while (j < left.size() && left[j].fz < 0.5) ++j;
    if (j - i > best_len) {
      best_len = j - i;
      best_begin = i;
    }
    i = j + 1;
  }
  ASSERT_GT(best_len, 50U) << "the left foot must fly for at least 50 ms";
  ASSERT_GT(best_begin, 0U);
  const double t_touchdown = left[best_begin + best_len].t;
  // The true force through the estimator's hysteresis.
  double t_liftoff = -1;
  bool truth_contact = true;
  for (size_t i = 0; i < best_begin + 1; ++i) {
    const bool c = truth_contact ? left[i].fz >= est.config().contact_off : left[i].fz > est.config().contact_on;
    if (truth_contact && !c) t_liftoff = left[i].t;
    truth_contact = c;
  }
  double est_release = -1, est_take = -1;
  bool contact_in_flight = false;
  for (size_t i = 1; i < left.size(); ++i) {
    if (left[i - 1].est_contact && !left[i].est_contact && left[i].t <= t_touchdown) est_release = left[i].t;
    if (!left[i - 1].est_contact && left[i].est_contact && left[i].t >= t_touchdown && est_take < 0) est_take = left[i].t;
    if (left[i].t > t_liftoff + 5e-3 && left[i].t < t_touchdown) contact_in_flight = contact_in_flight || left[i].est_contact;
  }
  std::printf("lift-off at %.3f s, released by the estimator at %.3f s (%+.0f ms); touchdown at %.3f s, taken at %.3f s (%+.0f ms)\n",
              t_liftoff, est_release, (est_release - t_liftoff) * 1e3, t_touchdown, est_take, (est_take - t_touchdown) * 1e3);
  EXPECT_FALSE(contact_in_flight);
  EXPECT_LE(est_release, t_liftoff + 5e-3);
  EXPECT_GE(est_release, t_liftoff - 5e-3);
  EXPECT_GE(est_take, t_touchdown);
  EXPECT_LE(est_take, t_touchdown + 5e-3);
}

/// The closed loop estimator → wbc → simulator, sensor noise on: stands 30 s like the loop on the
/// simulator's truth does, then recovers the 5 N s push from behind about as well.
class EstimatorInTheLoop : public ::testing::TestWithParam<std::string> {};

struct LoopResult {
  bool fallen = false;
  double com_err_standing = 0, slip = 0, tilt = 0, peak_dev = 0, final_dev = 0;
};

LoopResult stand_and_push(const std::string& robot, bool with_estimator, const std::vector<std::string>& more = {}) {
  std::vector<std::string> overrides = kNoise;
  overrides.insert(overrides.end(), more.begin(), more.end());
  ClosedLoop loop(robot, overrides, ClosedLoopOptions{.estimator_in_loop = with_estimator});
  const double t_push = 30.0;
  loop.push_base(5.0, 65.0, Vector3d::UnitX(), t_push);
  const auto soles0 = loop.sim.truth().p_WF;
  LoopResult r;
  loop.run(t_push + 5.0, [&] {
    const auto& t = loop.sim.truth();
    const double dev = (t.p_WCom - loop.plan().reference.p_com).norm();
    if (t.time > 1.5 && t.time < t_push) r.com_err_standing = std::max(r.com_err_standing, dev);
    if (t.time >= t_push) r.peak_dev = std::max(r.peak_dev, dev);
    r.final_dev = dev;
    for (size_t f = 0; f < 2; ++f) {
      r.slip = std::max(r.slip, (t.p_WF[f].head<2>() - soles0[f].head<2>()).norm());
      r.tilt = std::max(r.tilt, t.foot_tilt[f]);
    }
  });
  r.fallen = loop.sim.truth().fallen;
  std::printf("%s%s, state from the %s: CoM error standing %.2f mm, slip %.2f mm, tilt %.2f deg; push: peak CoM deviation %.1f mm, final %.2f mm\n",
              robot.c_str(), more.empty() ? "" : (" (" + more.front() + ")").c_str(), with_estimator ? "estimator" : "truth", r.com_err_standing * 1e3, r.slip * 1e3,
              r.tilt * 180 / M_PI, r.peak_dev * 1e3, r.final_dev * 1e3);
  return r;
}

TEST_P(EstimatorInTheLoop, Stands30sAndRecoversThe5NsPushAsWithTruth) {
  const LoopResult truth = stand_and_push(GetParam(), false);
  const LoopResult est = stand_and_push(GetParam(), true);
  ASSERT_FALSE(truth.fallen);
  EXPECT_FALSE(est.fallen);
  EXPECT_LT(est.com_err_standing, 2e-3) << "CoM within 2 mm of the reference while standing";
  EXPECT_LT(est.slip, 1e-3);
  EXPECT_LT(est.tilt, 0.01);
  EXPECT_NEAR(est.peak_dev, truth.peak_dev, 0.2 * truth.peak_dev + 1e-3) << "the push moves the CoM as much as with truth";
  EXPECT_LT(est.final_dev, 0.01) << "back to the reference";
}

/// The same in MuJoCo. It stands as well on the truth; on the estimate its CoM strays further while
/// standing (2.3 mm against 0.5 mm in Bullet): the estimator's check that a planted sole is not
/// turning (estimator.anchor_max_rate, on the gyro's rate plus the leg's filtered joint rates)
/// fires now and then on the sensor noise, the sole is re-seated where the estimate puts it, and
/// the controller's answer to that jump, sharper in MuJoCo (base rate peaks of 0.086 rad/s against
/// 0.020 in Bullet), makes the next one likelier. Without that check, or with exact encoders, the
/// error is 0.5 mm as in Bullet (docs/notes/2026-11-30-mujoco-estimator.md).
TEST(EstimatorInTheLoop, MujocoStands30sAndRecoversThe5NsPush) {
  const LoopResult truth = stand_and_push("toro", false, {"sim.engine=mujoco"});
  const LoopResult est = stand_and_push("toro", true, {"sim.engine=mujoco"});
  ASSERT_FALSE(truth.fallen);
  EXPECT_LT(truth.com_err_standing, 1e-3);
  EXPECT_FALSE(est.fallen);
  EXPECT_LT(est.com_err_standing, 4e-3);
  EXPECT_LT(est.slip, 1e-3);
  EXPECT_LT(est.tilt, 0.01);
  EXPECT_LT(est.peak_dev, 2.0 * truth.peak_dev + 1e-3);
  EXPECT_LT(est.final_dev, 0.01) << "back to the reference";
  // The cause: without the turning check the estimate holds the CoM as in Bullet.
  const LoopResult unchecked = stand_and_push("toro", true, {"sim.engine=mujoco", "estimator.anchor_max_rate=0"});
  EXPECT_LT(unchecked.com_err_standing, 1e-3);
}

/// On one foot with the estimator in the loop (no sensor noise), the ankle and the CAM strategy:
/// the CoM shifts over the stance sole (balance.shift_time: its peak acceleration within reach of
/// the sole's CoP), the swing foot lifts, and the robot stands 3 s with its CoM on the reference.
class OneFoot : public ::testing::TestWithParam<std::string> {};

TEST_P(OneFoot, StandsOnEitherFootWithEitherStrategyAndTheEstimatorInTheLoop) {
  for (const char* foot : {"right", "left"}) {
    for (const bool cam : {false, true}) {
      ClosedLoop loop(GetParam(), {std::string("balance.support=") + foot}, ClosedLoopOptions{.cam = cam, .estimator_in_loop = true});
      const auto stance = static_cast<size_t>(std::string(foot) == "right" ? 0 : 1);
      const double t_up = loop.cfg.section("balance").real_or("init_time", 1.0) + loop.cfg.section("balance").real_or("shift_time", 1.2) +
                          loop.cfg.section("balance").real_or("lift_time", 0.6);
      double swing_height = 1e9, tilt = 0, com_err = 0;
      loop.run(t_up + 3.0, [&] {
        const auto& t = loop.sim.truth();
        tilt = std::max(tilt, t.foot_tilt[stance]);
        if (t.time > t_up + 0.5) {
          swing_height = std::min(swing_height, t.p_WF[1 - stance].z());
          com_err = std::max(com_err, (t.p_WCom - loop.plan().reference.p_com).head<2>().norm());
        }
      });
      const std::string what = fmt::format("{} on the {} foot, {} strategy", GetParam(), foot, cam ? "CAM" : "ankle");
      std::printf("%s: stance sole tilt %.2f deg, CoM error %.1f mm, swing sole %.1f mm up\n", what.c_str(), tilt * 180 / M_PI,
                  com_err * 1e3, swing_height * 1e3);
      ASSERT_FALSE(loop.sim.truth().fallen) << what;
      EXPECT_EQ(loop.plan().reference.support, stance == 0 ? hpr::balance::Support::kRight : hpr::balance::Support::kLeft) << what;
      EXPECT_LT(tilt, 2.0 * M_PI / 180) << what << ": the stance sole stays flat";
      EXPECT_LT(com_err, 8e-3) << what << ": the CoM on its reference";
      EXPECT_GT(swing_height, 0.03) << what << ": the swing foot stays lifted";
    }
  }
}

/// Largest drift over the first second of the estimated CoM against the simulator's, from where
/// each stood at the first tick, on the G1 standing with the estimator in the loop. The planner
/// holds the soles where the first estimate put them, so this drift is the CoM's error relative to
/// the support. The G1's four 5 mm sole spheres seat themselves in the first milliseconds (the
/// ankles turn at up to 1.4 rad/s): a tick of those rates taken for the base's velocity, integrated
/// until a sole is an anchor again, moves the estimate off the feet.
double g1_start_drift(bool settle_at_start, bool edges, bool sole_torsion = true) {
  ClosedLoop loop("g1",
                  {fmt::format("estimator.settle_at_start={}", settle_at_start), fmt::format("estimator.edge_velocity_noise={}", edges ? 0.03 : 0.0),
                   fmt::format("estimator.settle_after_roll={}", edges), fmt::format("wbc.contact.sole_torsion={}", sole_torsion)},
                  ClosedLoopOptions{.estimator_in_loop = true});
  Vector3d e0 = Vector3d::Zero();
  bool have_e0 = false;
  double worst = 0.0;
  loop.run(1.0, [&] {
    const Vector3d err = loop.estimator->state().p_com - loop.sim.truth().p_WCom;
    if (!have_e0) {
      e0 = err;
      have_e0 = true;
    }
    worst = std::max(worst, (err - e0).head<2>().norm());
  });
  EXPECT_FALSE(loop.sim.truth().fallen);
  return worst;
}

TEST(EstimatorAccuracy, SolesSeatingThemselvesAtTheStartLeaveTheEstimateOnItsFeet) {
  // settle_at_start on its own (the soles' edge handling off: a sole rolling on an edge gives no
  // velocity, none settles after a roll), with each sole's torsion bounded by torsion x f_z (the
  // paper's contact model, wbc.contact.sole_torsion false), under which the spheres seat themselves;
  // then the shipped configuration (all on, the torsion bounded by the sole's corners), and that
  // contact model without settle_at_start: the wbc then asks the soles for no torsion their
  // spheres cannot hold, and they hardly move.
  const double settled = g1_start_drift(true, false, false), unsettled = g1_start_drift(false, false, false);
  const double shipped = g1_start_drift(true, true), corners_unsettled = g1_start_drift(false, false);
  std::printf("G1 standing, the estimated CoM's drift against the truth in the first second: %.1f mm with settle_at_start, %.1f mm without "
              "(edge handling and the corners' torsion bound off); %.1f mm as configured, %.1f mm so without settle_at_start\n",
              settled * 1e3, unsettled * 1e3, shipped * 1e3, corners_unsettled * 1e3);
  EXPECT_LT(settled, 3e-3);
  EXPECT_GT(unsettled, 10e-3) << "without it the start's transient is in the estimate (what this test guards against)";
  EXPECT_LT(shipped, 3e-3);
  EXPECT_LT(corners_unsettled, 3e-3);
}

INSTANTIATE_TEST_SUITE_P(Robots, EstimatorInTheLoop, ::testing::Values("toro", "h1_2"));
INSTANTIATE_TEST_SUITE_P(Robots, OneFoot, ::testing::Values("toro", "h1_2", "g1"));

}  // namespace
