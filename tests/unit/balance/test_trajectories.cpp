// The planner's blends against their boundary conditions and against finite differences of
// their own positions (the velocities and accelerations they return must be the derivatives).

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "hpr/balance/trajectories.hpp"

namespace {

using namespace hpr::balance;
using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kEps = 1e-6;

// Central differences of f(x)(0) and f(x)(1) against f(x)(1) and f(x)(2), in units of x.
template <class F>
void expect_derivatives(F f, double x, double scale, const char* what) {
  const Vector3d lo = f(x - kEps), hi = f(x + kEps), at = f(x);
  EXPECT_NEAR((hi(0) - lo(0)) / (2 * kEps), at(1), 1e-6 * scale) << what << " at " << x << ": velocity";
  EXPECT_NEAR((hi(1) - lo(1)) / (2 * kEps), at(2), 1e-5 * scale) << what << " at " << x << ": acceleration";
}

TEST(Trajectories, TheQuinticsMeetTheirEndsAndTheirDerivatives) {
  EXPECT_EQ(quintic(0.0), Vector3d::Zero());
  EXPECT_EQ(quintic(1.0), Vector3d(1, 0, 0));
  EXPECT_NEAR(quintic(0.5)(0), 0.5, 1e-15);
  for (double tau : {0.1, 0.3, 0.5, 0.77, 0.95}) expect_derivatives([](double x) { return quintic(x); }, tau, 1.0, "quintic");
  // From (p0, v0, a0) to (p1, 0, 0) over T.
  const double p0 = 0.2, v0 = -0.7, a0 = 3.0, p1 = 0.45, T = 0.4;
  auto q = [&](double t) { return quintic_to_rest(p0, v0, a0, p1, T, t); };
  EXPECT_LT((q(0.0) - Vector3d(p0, v0, a0)).norm(), 1e-12);
  EXPECT_LT((q(T - 1e-12) - Vector3d(p1, 0, 0)).norm(), 1e-9);
  EXPECT_EQ(q(T + 0.1), Vector3d(p1, 0, 0));
  for (double t : {0.05, 0.13, 0.2, 0.31, 0.39}) expect_derivatives(q, t, 10.0, "quintic_to_rest");
}

TEST(Trajectories, AShiftOfTheQuinticShiftTimeAsksTheSoleForTheFractionOfItsReachAtItsPeak) {
  // The peak of the quintic's second derivative, searched on a fine grid.
  double peak = 0.0;
  for (int i = 0; i <= 200000; ++i) peak = std::max(peak, std::abs(quintic(i / 200000.0)(2)));
  EXPECT_NEAR(peak, kQuinticPeakAcceleration, 1e-8);
  // A CoM shift x(t) = d s(t / T): its largest acceleration against the pendulum's ω² (c − p)
  // with the CoP `reach` beyond the CoM.
  const double d = 0.118, z_c = 0.65, reach = 0.02, fraction = 0.6, g = 9.81;
  const double T = quintic_shift_time(d, z_c, reach, fraction, g);
  double a_max = 0.0;
  for (int i = 0; i <= 200000; ++i) a_max = std::max(a_max, std::abs(d * quintic(i / 200000.0)(2) / (T * T)));
  EXPECT_NEAR(a_max, fraction * g / z_c * reach, 1e-9);
  // Slower for a longer way, a taller pendulum, a narrower sole; the sign of the way is no matter.
  EXPECT_GT(quintic_shift_time(2 * d, z_c, reach, fraction, g), T);
  EXPECT_GT(quintic_shift_time(d, 2 * z_c, reach, fraction, g), T);
  EXPECT_GT(quintic_shift_time(d, z_c, 0.5 * reach, fraction, g), T);
  EXPECT_EQ(quintic_shift_time(-d, z_c, reach, fraction, g), T);
}

TEST(Trajectories, TheSwingHeightLiftsToItsPeakAndSetsDownBelowTheGroundAtRest) {
  const double T = 0.35, z_ground = 0.02, z0 = 0.01, h = 0.05, depth = 0.02;
  // In time: the returned derivatives are per second.
  auto z = [&](double t) { return swing_height(t / T, T, z_ground, z0, h, depth); };
  EXPECT_LT((z(0.0) - Vector3d(z_ground + z0, 0, 0)).norm(), 1e-12) << "at lift-off, at rest";
  EXPECT_LT((z(T) - Vector3d(z_ground - depth, 0, 0)).norm(), 1e-12) << "at touchdown, at rest, depth below";
  for (double t : {0.03, 0.1, 0.175, 0.26, 0.33}) expect_derivatives(z, t, 100.0, "swing_height");
  // Without the sink, the bump alone peaks at h at mid-swing.
  EXPECT_NEAR(swing_height(0.5, T, z_ground, 0.0, h, 0.0)(0), z_ground + h, 1e-15);
  double peak = 0.0;
  for (int i = 0; i <= 1000; ++i) peak = std::max(peak, swing_height(i / 1000.0, T, 0.0, 0.0, h, 0.0)(0));
  EXPECT_NEAR(peak, h, 1e-12);
  // Past the planned touchdown it goes on down at the probe speed, from where it ended.
  EXPECT_NEAR(z(T + 1e-9)(0), z(T)(0), 1e-9);
  EXPECT_NEAR(z(T + 0.1)(0), z_ground - depth - kSwingProbeSpeed * 0.1, 1e-12);
  EXPECT_EQ(z(T + 0.1)(1), -kSwingProbeSpeed);
}

Vector3d log_of(const Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

TEST(Trajectories, TheSwingOrientationBlendsOnSO3WithItsAngularVelocityAndAcceleration) {
  const Matrix3d R0 = (Eigen::AngleAxisd(0.3, Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.2, Vector3d::UnitY())).toRotationMatrix();
  const Matrix3d R1 = Eigen::AngleAxisd(-0.4, Vector3d::UnitZ()).toRotationMatrix();
  const double T = 0.4;
  EXPECT_LT((swing_orientation(R0, R1, 0.0, T).R - R0).norm(), 1e-12);
  EXPECT_LT((swing_orientation(R0, R1, 1.0, T).R - R1).norm(), 1e-12);
  EXPECT_LT((swing_orientation(R0, R1, 1.5, T).R - R1).norm(), 1e-12) << "held at the ground's past touchdown";
  for (double tau : {0.1, 0.4, 0.5, 0.8}) {
    const SwingOrientation o = swing_orientation(R0, R1, tau, T);
    EXPECT_LT((o.R.transpose() * o.R - Matrix3d::Identity()).norm(), 1e-12);
    // ω from the rotation between two nearby instants (Eigen's own log), in the world.
    const double dtau = 1e-6;
    const SwingOrientation lo = swing_orientation(R0, R1, tau - dtau, T), hi = swing_orientation(R0, R1, tau + dtau, T);
    const Vector3d omega_fd = log_of(hi.R * lo.R.transpose()) / (2 * dtau * T);
    EXPECT_LT((omega_fd - o.omega).norm(), 1e-6 * (1 + o.omega.norm())) << "tau " << tau;
    const Vector3d omegadot_fd = (hi.omega - lo.omega) / (2 * dtau * T);
    EXPECT_LT((omegadot_fd - o.omegadot).norm(), 1e-5 * (1 + o.omegadot.norm())) << "tau " << tau;
  }
}

}  // namespace
