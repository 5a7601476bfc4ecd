#pragma once
/// \file
/// The smooth blends the balance planner draws its references with: quintics (zero velocity and
/// acceleration where they end), and a step's swing sole (its height and its orientation).

#include <Eigen/Core>

#include "hpr/model/spatial.hpp"

namespace hpr::balance {

/// Quintic blend s(τ) from 0 to 1 over [0, 1] with zero velocity and acceleration at both ends;
/// returns (s, ds/dτ, d²s/dτ²).
Eigen::Vector3d quintic(double tau);
/// The largest |d²s/dτ²| of quintic(): 10/√3, at τ = 1/2 ± √3/6.
inline constexpr double kQuinticPeakAcceleration = 5.773502691896258;

/// The shortest duration [s] of a quintic CoM shift over `travel` [m] whose peak acceleration
/// asks the stance sole for at most `fraction` of what its CoP can do: on the linear inverted
/// pendulum of height z_c, c̈ = ω² (c − p), so a CoP that reaches `cop_reach` [m] beyond the CoM
/// gives ω² cop_reach; T = sqrt(kQuinticPeakAcceleration · travel / (fraction · ω² · cop_reach)).
double quintic_shift_time(double travel, double z_c, double cop_reach, double fraction, double g = 9.81);

/// One axis of a quintic from (p0, v0, a0) to (p1, 0, 0) over T, at time t ∈ [0, T]; returns
/// (p, v, a) at t.
Eigen::Vector3d quintic_to_rest(double p0, double v0, double a0, double p1, double T, double t);

/// The swing sole's height over a step of duration T [s], at τ = (t − t_lift-off) / T: from
/// `z_ground + z0` (z0 the height above the ground at lift-off) to `depth` below the ground at
/// τ = 1, through a bump of 64 h τ³ (1 − τ)³ (h at mid-swing), with zero velocity and
/// acceleration at both ends; past τ = 1 (the sole not yet loaded) it goes on down at
/// kSwingProbeSpeed. Returns (z, ż, z̈) [m, m/s, m/s²].
Eigen::Vector3d swing_height(double tau, double T, double z_ground, double z0, double h, double depth);
inline constexpr double kSwingProbeSpeed = 0.3;  ///< [m/s]

/// The swing sole's orientation: from R0 (at lift-off) to R1 (the ground's) by a quintic blend on
/// SO(3), R(τ) = R0 exp(s(τ) φ), φ = log(R0ᵀ R1), with the angular velocity and acceleration in
/// the world (τ clamped to [0, 1]).
struct SwingOrientation {
  model::Matrix3d R;
  Eigen::Vector3d omega, omegadot;  ///< [rad/s], [rad/s²]
};
SwingOrientation swing_orientation(const model::Matrix3d& R0, const model::Matrix3d& R1, double tau, double T);

}  // namespace hpr::balance
