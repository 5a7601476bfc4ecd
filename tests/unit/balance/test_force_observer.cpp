// The external-force observer against closed forms: a point mass under a known external force
// (and ground forces, which it must not count), the first-order response in discrete time, the
// restart on a gap or a non-finite velocity, the compensated force's low-pass and clamp, and the
// push's onset.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "hpr/balance/force_observer.hpp"

namespace {

using hpr::balance::ExternalForceObserver;
using Eigen::Vector2d;

constexpr double kMass = 60.0, kTau = 0.04, kDt = 0.001;

// A point mass at rest at t0 under the external force F and the ground force g from then on:
// m v̇ = F + g, integrated exactly. The observer sees v and g, never F. F̂_k after k steps is
// F (1 − (1 − Δt/τ)^k), whatever g.
TEST(ExternalForceObserver, FollowsAConstantForceAsAFirstOrderLagAndCountsNoGroundForce) {
  ExternalForceObserver obs({.mass = kMass, .time_constant = kTau});
  const Vector2d F(40.0, -25.0), g(-15.0, 30.0);
  const double t0 = 2.0;
  obs.update(t0, Vector2d(0.1, 0.2), g);  // starts the integration
  EXPECT_EQ(obs.force(), Vector2d::Zero());
  for (int k = 1; k <= 400; ++k) {
    const double t = t0 + k * kDt;
    const Vector2d v = Vector2d(0.1, 0.2) + (F + g) / kMass * (k * kDt);
    obs.update(t, v, g);
    const Vector2d expected = F * (1.0 - std::pow(1.0 - kDt / kTau, k));
    ASSERT_LT((obs.force() - expected).norm(), 1e-9 * F.norm()) << "step " << k;
  }
  // After 10 τ: F itself (to e^-10).
  EXPECT_LT((obs.force() - F).norm(), 1e-4 * F.norm());

  // The ground force alone accelerating the mass is no external force.
  ExternalForceObserver ground_only({.mass = kMass, .time_constant = kTau});
  for (int k = 0; k <= 200; ++k) ground_only.update(k * kDt, g / kMass * (k * kDt), g);
  EXPECT_LT(ground_only.force().norm(), 1e-9);
}

TEST(ExternalForceObserver, RestartsOnAGapAndOnANonFiniteVelocity) {
  ExternalForceObserver obs({.mass = kMass, .time_constant = kTau, .compensate = true});
  const Vector2d F(50.0, 0.0);
  int k = 0;
  auto run = [&](int steps, double t_start) {
    for (int i = 0; i <= steps; ++i, ++k) obs.update(t_start + i * kDt, F / kMass * (i * kDt), Vector2d::Zero());
  };
  run(200, 0.0);
  EXPECT_NEAR(obs.force().x(), 50.0 * (1.0 - std::pow(1.0 - kDt / kTau, 200)), 1e-9);
  EXPECT_GT(obs.compensated().x(), 10.0);
  // A gap of more than kMaxGap: the next update starts again (F̂ zero), from the velocity then.
  obs.update(0.2 + ExternalForceObserver::kMaxGap + 0.01, Vector2d(5.0, 0.0), Vector2d::Zero());
  EXPECT_EQ(obs.force(), Vector2d::Zero());
  EXPECT_GT(obs.compensated().x(), 10.0) << "the compensation decays through its low-pass, it does not jump";
  // A NaN velocity: F̂ and the compensation are zero, and the next finite samples start again.
  const double t = 1.0;
  obs.update(t, Vector2d(5.0, 0.0), Vector2d::Zero());
  obs.update(t + kDt, Vector2d(std::numeric_limits<double>::quiet_NaN(), 0.0), Vector2d::Zero());
  EXPECT_EQ(obs.force(), Vector2d::Zero());
  EXPECT_EQ(obs.compensated(), Vector2d::Zero());
  obs.update(t + 2 * kDt, Vector2d(1.0, 0.0), Vector2d::Zero());
  EXPECT_EQ(obs.force(), Vector2d::Zero()) << "the first finite sample after the NaN only starts the integration";
  obs.update(t + 3 * kDt, Vector2d(1.0, 0.0) + F / kMass * kDt, Vector2d::Zero());
  EXPECT_NEAR(obs.force().x(), 50.0 * kDt / kTau, 1e-9);
  // restart() (a clock that restarted) forgets everything, the compensation too: the next
  // updates give what a new observer gives.
  run(100, 2.0);
  ASSERT_GT(obs.compensated().norm(), 1.0);
  obs.restart();
  EXPECT_EQ(obs.force(), Vector2d::Zero());
  EXPECT_EQ(obs.compensated(), Vector2d::Zero());
  EXPECT_LT(obs.push_start(), 0.0);
  ExternalForceObserver fresh({.mass = kMass, .time_constant = kTau, .compensate = true});
  for (int i = 0; i <= 50; ++i) {
    const Vector2d v = F / kMass * (i * kDt);
    obs.update(3.0 + i * kDt, v, Vector2d::Zero());
    fresh.update(3.0 + i * kDt, v, Vector2d::Zero());
    ASSERT_EQ(obs.force(), fresh.force()) << i;
    ASSERT_EQ(obs.compensated(), fresh.compensated()) << i;
  }
}

// The compensated force: a first-order low-pass of F̂ with its own time constant (discrete:
// c_k = c_{k−1} + (Δt/T)(F̂_k − c_{k−1})), clamped to max_force; zero without compensate.
TEST(ExternalForceObserver, TheCompensatedForceIsALowPassOfTheEstimateClampedToItsLimit) {
  const double T = 0.1;
  ExternalForceObserver obs({.mass = kMass, .time_constant = kTau, .compensate = true, .compensation_filter = T, .max_force = 80.0});
  ExternalForceObserver off({.mass = kMass, .time_constant = kTau});
  const Vector2d F(60.0, 80.0);  // |F| = 100 N, beyond the clamp
  Vector2d c = Vector2d::Zero();
  bool clamped = false;
  for (int k = 0; k <= 1000; ++k) {
    const Vector2d v = F / kMass * (k * kDt);
    obs.update(k * kDt, v, Vector2d::Zero());
    off.update(k * kDt, v, Vector2d::Zero());
    if (k > 0) {
      c += (kDt / T) * (obs.force() - c);
      if (c.norm() > 80.0) {
        c *= 80.0 / c.norm();
        clamped = true;
      }
    }
    ASSERT_LT((obs.compensated() - c).norm(), 1e-9) << "step " << k;
    ASSERT_LE(obs.compensated().norm(), 80.0 + 1e-9);
    ASSERT_EQ(off.compensated(), Vector2d::Zero());
  }
  EXPECT_TRUE(clamped);
  EXPECT_NEAR(obs.compensated().norm(), 80.0, 1e-9);
  EXPECT_LT((obs.compensated().normalized() - F.normalized()).norm(), 1e-6) << "clamped along the force";
}

TEST(ExternalForceObserver, APushStartsWhenTheEstimateRisesAboveTheOnsetAndEndsBelowIt) {
  ExternalForceObserver obs({.mass = kMass, .time_constant = kTau, .push_onset = 10.0});
  const Vector2d F(30.0, 0.0);
  // F̂_k = 30 (1 − 0.975^k) first exceeds 10 N at the k where 0.975^k < 2/3.
  const int k_onset = static_cast<int>(std::ceil(std::log(2.0 / 3.0) / std::log(1.0 - kDt / kTau)));
  Vector2d v = Vector2d::Zero();
  obs.update(0.0, v, Vector2d::Zero());
  for (int k = 1; k <= 100; ++k) {
    v += F / kMass * kDt;
    obs.update(k * kDt, v, Vector2d::Zero());
    if (k < k_onset) {
      ASSERT_LT(obs.push_start(), 0.0) << "step " << k;
    } else {
      ASSERT_DOUBLE_EQ(obs.push_start(), k_onset * kDt) << "step " << k;
    }
  }
  // The force ends: the velocity stays; F̂ decays, and the push ends once it is below the onset.
  int k = 101;
  for (; obs.force().norm() >= 10.0; ++k) obs.update(k * kDt, v, Vector2d::Zero());
  EXPECT_LT(obs.push_start(), 0.0);
}

}  // namespace
