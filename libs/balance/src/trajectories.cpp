#include "hpr/balance/trajectories.hpp"

#include <algorithm>
#include <cmath>

namespace hpr::balance {

using Eigen::Vector3d;

Vector3d quintic(double tau) {
  if (tau <= 0) return Vector3d::Zero();
  if (tau >= 1) return Vector3d(1, 0, 0);
  const double t2 = tau * tau, t3 = t2 * tau;
  return {t3 * (10 - 15 * tau + 6 * t2), 30 * t2 * (1 - 2 * tau + t2), 60 * tau * (1 - 3 * tau + 2 * t2)};
}

double quintic_shift_time(double travel, double z_c, double cop_reach, double fraction, double g) {
  const double omega2 = g / z_c;
  return std::sqrt(kQuinticPeakAcceleration * std::abs(travel) / (fraction * omega2 * cop_reach));
}

Vector3d quintic_to_rest(double p0, double v0, double a0, double p1, double T, double t) {
  if (T <= 0.0 || t >= T) return {p1, 0.0, 0.0};
  const double d = p1 - p0, T2 = T * T, T3 = T2 * T;
  const double c3 = (20 * d - 12 * v0 * T - 3 * a0 * T2) / (2 * T3);
  const double c4 = (-30 * d + 16 * v0 * T + 3 * a0 * T2) / (2 * T3 * T);
  const double c5 = (12 * d - 6 * v0 * T - a0 * T2) / (2 * T3 * T2);
  const double t2 = t * t, t3 = t2 * t;
  return {p0 + v0 * t + 0.5 * a0 * t2 + c3 * t3 + c4 * t3 * t + c5 * t3 * t2,
          v0 + a0 * t + 3 * c3 * t2 + 4 * c4 * t3 + 5 * c5 * t3 * t, a0 + 6 * c3 * t + 12 * c4 * t2 + 20 * c5 * t3};
}

Vector3d swing_height(double tau, double T, double z_ground, double z0, double h, double depth) {
  if (tau > 1.0) return {z_ground - depth - kSwingProbeSpeed * (tau - 1.0) * T, -kSwingProbeSpeed, 0.0};
  // The bump plus the sink from the lift-off height to `depth` below the ground.
  const double tc = std::clamp(tau, 0.0, 1.0), u = 1.0 - tc;
  const Vector3d sink = quintic(tc);
  const double dz = z0 + depth;
  return {z_ground + 64 * h * tc * tc * tc * u * u * u + z0 - dz * sink(0),
          64 * h * 3 * tc * tc * u * u * (u - tc) / T - dz * sink(1) / T,
          64 * h * 6 * tc * u * (u * u - 3 * tc * u + tc * tc) / (T * T) - dz * sink(2) / (T * T)};
}

SwingOrientation swing_orientation(const model::Matrix3d& R0, const model::Matrix3d& R1, double tau, double T) {
  const Vector3d phi = model::log3(R0.transpose() * R1);
  const Vector3d s = quintic(std::clamp(tau, 0.0, 1.0));
  return {R0 * model::exp3(s(0) * phi), R0 * phi * (s(1) / T), R0 * phi * (s(2) / (T * T))};
}

}  // namespace hpr::balance
