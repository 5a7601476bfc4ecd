// Stepping's capture point, decision and step planner against the linear inverted pendulum: the
// closed forms are checked against a numerical integration of c̈ = ω² (c − p), and a planned step
// is checked by integrating the pendulum through the swing and after the touchdown.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <random>
#include <vector>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hpr/balance/stepping.hpp"
#include "hpr/balance/task_reference.hpp"
#include "hpr/common/config.hpp"
#include "hpr/model/robot.hpp"

namespace {

using Eigen::Vector2d;
using hpr::balance::Sole;
using hpr::balance::StepPlanner;
using hpr::balance::SteppingConfig;
using hpr::model::kLeft;
using hpr::model::kRight;

struct Lip {
  Vector2d c, cd;
};

/// RK4 of the LIP c̈ = ω² (c − p) + a_ext over `t` with the CMP held at `p` (steps of 0.1 ms);
/// a_ext = F / m of an external force.
Lip integrate(Lip s, const Vector2d& p, double omega, double t, const Vector2d& a_ext = Vector2d::Zero()) {
  const int n = std::max(1, static_cast<int>(std::ceil(t / 1e-4)));
  const double h = t / n;
  const double w2 = omega * omega;
  for (int i = 0; i < n; ++i) {
    const Vector2d k1c = s.cd, k1v = w2 * (s.c - p) + a_ext;
    const Vector2d k2c = s.cd + 0.5 * h * k1v, k2v = w2 * (s.c + 0.5 * h * k1c - p) + a_ext;
    const Vector2d k3c = s.cd + 0.5 * h * k2v, k3v = w2 * (s.c + 0.5 * h * k2c - p) + a_ext;
    const Vector2d k4c = s.cd + h * k3v, k4v = w2 * (s.c + h * k3c - p) + a_ext;
    s.c += h / 6 * (k1c + 2 * k2c + 2 * k3c + k4c);
    s.cd += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
  }
  return s;
}

/// Two 0.2 × 0.1 m soles, 0.2 m apart (right at y = −0.1), facing +x.
std::array<Sole, 2> standing() {
  std::array<Sole, 2> s;
  s[kRight] = {Vector2d(0, -0.1), 0.0, 0.1, 0.05};
  s[kLeft] = {Vector2d(0, 0.1), 0.0, 0.1, 0.05};
  return s;
}

constexpr double kOmega = 3.5;  // z_c ≈ 0.8 m

TEST(Lip, TheDcmClosedFormMatchesTheIntegratedPendulum) {
  EXPECT_NEAR(hpr::balance::lip_omega(0.8), std::sqrt(9.81 / 0.8), 1e-15);
  const Lip s0{Vector2d(0.02, -0.01), Vector2d(0.4, 0.15)};
  const Vector2d p(0.05, 0.02);
  for (const double t : {0.1, 0.3, 0.6}) {
    const Lip s = integrate(s0, p, kOmega, t);
    const Vector2d xi = hpr::balance::capture_point(s.c, s.cd, kOmega);
    const Vector2d expected = hpr::balance::dcm_after(hpr::balance::capture_point(s0.c, s0.cd, kOmega), p, kOmega, t);
    EXPECT_LT((xi - expected).norm(), 1e-9) << "t = " << t;
  }
}

TEST(Lip, WithTheCmpAtTheCapturePointThePendulumComesToRestThere) {
  const Lip s0{Vector2d(0.0, 0.0), Vector2d(0.5, -0.2)};
  const Vector2d xi = hpr::balance::capture_point(s0.c, s0.cd, kOmega);
  const Lip s = integrate(s0, xi, kOmega, 6.0);
  EXPECT_LT((s.c - xi).norm(), 1e-6);
  EXPECT_LT(s.cd.norm(), 1e-5);
}

TEST(Lip, AForceOfKnownDurationShiftsTheCapturePointToTheCmpThatBringsThePendulumToRest) {
  // With the CMP at p = ξ + push_shift(F, m, ω, T) the pendulum pushed by F for T more seconds ends
  // the push with its capture point at p, where it then comes to rest; a force that lasts for good
  // shifts ξ by F / (m ω²), the CMP that holds it.
  const double m = 80.0;
  const Vector2d f(130.0, -40.0);
  const Lip s0{Vector2d(0.01, 0.0), Vector2d(0.2, -0.1)};
  const Vector2d xi0 = hpr::balance::capture_point(s0.c, s0.cd, kOmega);
  for (const double T : {0.05, 0.27, 0.8}) {
    const Vector2d p = xi0 + hpr::balance::push_shift(f, m, kOmega, T);
    const Lip s = integrate(s0, p, kOmega, T, f / m);
    EXPECT_LT((hpr::balance::capture_point(s.c, s.cd, kOmega) - p).norm(), 1e-9) << "T = " << T;
    // A CMP 1 cm short of it loses the pendulum: its capture point runs away from p.
    const Vector2d p_short = p - 0.01 * f.normalized();
    const Lip lost = integrate(integrate(s0, p_short, kOmega, T, f / m), p_short, kOmega, 2.0);
    EXPECT_GT((hpr::balance::capture_point(lost.c, lost.cd, kOmega) - p_short).norm(), 0.1) << "T = " << T;
  }
  EXPECT_LT((hpr::balance::push_shift(f, m, kOmega, std::numeric_limits<double>::infinity()) - f / (m * kOmega * kOmega)).norm(), 1e-15);
  EXPECT_EQ(hpr::balance::push_shift(f, m, kOmega, 0.0), Vector2d::Zero());
  EXPECT_EQ(hpr::balance::push_shift(f, m, kOmega, -1.0), Vector2d::Zero());
}

TEST(SupportDistance, InsideIsNegativeOutsideIsTheDistanceToTheHull) {
  const auto soles = standing();
  const std::array<bool, 2> both{true, true};
  // The hull of both soles is the rectangle [−0.1, 0.1] × [−0.15, 0.15].
  EXPECT_NEAR(hpr::balance::support_distance(soles, both, Vector2d(0, 0)), -0.1, 1e-12);
  EXPECT_NEAR(hpr::balance::support_distance(soles, both, Vector2d(0.13, 0)), 0.03, 1e-12);
  EXPECT_NEAR(hpr::balance::support_distance(soles, both, Vector2d(0, -0.2)), 0.05, 1e-12);
  EXPECT_NEAR(hpr::balance::support_distance(soles, both, Vector2d(0.13, 0.19)), 0.05, 1e-12);  // corner: 3-4-5
  // On the right foot alone the middle is outside, 5 cm from its inner edge.
  EXPECT_NEAR(hpr::balance::support_distance(soles, {true, false}, Vector2d(0, 0)), 0.05, 1e-12);
  // A rotated sole: 45° yaw, the point 0.1 m along its x axis from the centre is on its edge.
  std::array<Sole, 2> turned = soles;
  turned[kRight].yaw = M_PI / 4;
  const Vector2d edge = turned[kRight].to_world({0.1, 0.0});
  EXPECT_NEAR(hpr::balance::support_distance(turned, {true, false}, edge), 0.0, 1e-12);
}

TEST(SupportPoint, InsideItIsThePointItselfOutsideTheNearestPointOfTheShrunkHull) {
  // Against a brute force: the nearest of 4 000 points on the boundary of each shrunk sole and of
  // the segments joining their corners (the hull's boundary lies on them), for points around a
  // step's support (the left sole moved forward and turned).
  std::array<Sole, 2> soles = standing();
  soles[kLeft] = {Vector2d(0.18, 0.16), 0.3, 0.1, 0.05};
  const double inset = 0.02;
  std::vector<Vector2d> corners;
  for (const Sole& sole : soles) {
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) corners.push_back(sole.to_world({sx * (sole.half_length - inset), sy * (sole.half_width - inset)}));
    }
  }
  std::vector<Vector2d> boundary;
  for (size_t i = 0; i < corners.size(); ++i) {
    for (size_t j = i + 1; j < corners.size(); ++j) {
      for (int k = 0; k <= 400; ++k) boundary.push_back(corners[i] + (corners[j] - corners[i]) * (k / 400.0));
    }
  }
  const std::array<bool, 2> both{true, true};
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> ux(-0.3, 0.5), uy(-0.4, 0.5);
  int outside = 0;
  for (int s = 0; s < 300; ++s) {
    const Vector2d x(ux(gen), uy(gen));
    const Vector2d p = hpr::balance::support_point(soles, both, x, inset);
    // Is x inside the hull of the shrunk soles? Then p is x.
    std::array<Sole, 2> shrunk = soles;
    for (Sole& sole : shrunk) {
      sole.half_length -= inset;
      sole.half_width -= inset;
    }
    if (hpr::balance::support_distance(shrunk, both, x) <= 0.0) {
      EXPECT_LT((p - x).norm(), 1e-12);
      continue;
    }
    ++outside;
    double best = 1e9;
    for (const Vector2d& b : boundary) {
      // Only boundary points of the hull qualify: those on its edge (distance 0 from outside).
      if (std::abs(hpr::balance::support_distance(shrunk, both, b)) > 1e-9) continue;
      best = std::min(best, (b - x).norm());
    }
    EXPECT_NEAR((p - x).norm(), best, 2e-3) << "x " << x.transpose();
    EXPECT_NEAR(hpr::balance::support_distance(shrunk, both, p), 0.0, 1e-9) << "p lies on the hull's boundary";
  }
  EXPECT_GT(outside, 100);
  // One sole: the nearest point of that sole, shrunk.
  const Vector2d p = hpr::balance::support_point(soles, {true, false}, Vector2d(0.5, -0.1), inset);
  EXPECT_NEAR(p.x(), 0.08, 1e-12);
  EXPECT_NEAR(p.y(), -0.1, 1e-12);
}

/// A decision that steps, with the hip strategy's reach `cmp_reach` [m] ahead and to the sides.
SteppingConfig deciding(double cmp_reach) {
  SteppingConfig c;
  c.enabled = true;
  c.cmp_reach = c.cmp_reach_backward = c.cmp_reach_sideways = cmp_reach;
  return c;
}

TEST(StepDecision, NoStepWhileTheAnkleAndHipStrategiesSufficeAndAStepBeyond) {
  SteppingConfig c = deciding(0.04);
  c.margin = 0.01;
  StepPlanner planner(c);
  const auto soles = standing();
  const std::array<bool, 2> both{true, true};
  EXPECT_FALSE(planner.step_needed(soles, both, Vector2d(0.0, 0.0)));
  EXPECT_FALSE(planner.step_needed(soles, both, Vector2d(0.12, 0.0))) << "2 cm out: the hip strategy holds it";
  EXPECT_FALSE(planner.step_needed(soles, both, Vector2d(0.129, 0.0)));
  EXPECT_TRUE(planner.step_needed(soles, both, Vector2d(0.131, 0.0))) << "beyond the CMP reach less the margin";
  EXPECT_NEAR(planner.excess(soles, both, Vector2d(0.2, 0.0)), 0.1 - 0.04 + 0.01, 1e-12);
  c.enabled = false;
  EXPECT_FALSE(StepPlanner(c).step_needed(soles, both, Vector2d(1.0, 0.0))) << "disabled: never";
}

TEST(StepDecision, BehindTheSupportTheBackwardReachHoldsBetweenTheDirectionsItBlends) {
  SteppingConfig c = deciding(0.02);
  c.cmp_reach_backward = 0.05;
  StepPlanner planner(c);
  const std::array<bool, 2> both{true, true};
  for (const double yaw : {0.0, 0.7}) {
    // The same soles turned by `yaw` about the origin: the reach follows their heading.
    auto soles = standing();
    const Eigen::Rotation2Dd R(yaw);
    for (auto& sole : soles) {
      sole.centre = R * sole.centre;
      sole.yaw = yaw;
    }
    // 4 cm ahead of the toes and behind the heels: beyond the reach ahead, inside the one behind.
    EXPECT_NEAR(planner.excess(soles, both, R * Vector2d(0.14, 0.0)), 0.04 - 0.02, 1e-12) << yaw;
    EXPECT_NEAR(planner.excess(soles, both, R * Vector2d(-0.14, 0.0)), 0.04 - 0.05, 1e-12) << yaw;
    EXPECT_TRUE(planner.step_needed(soles, both, R * Vector2d(0.14, 0.0)));
    EXPECT_FALSE(planner.step_needed(soles, both, R * Vector2d(-0.14, 0.0)));
    // Sideways the reach ahead; behind at 45° half of each (cos² 45° = 1/2).
    EXPECT_NEAR(planner.excess(soles, both, R * Vector2d(0.0, 0.19)), 0.04 - 0.02, 1e-12) << yaw;
    const Vector2d diagonal = R * Vector2d(-0.13, -0.13);
    const double d = hpr::balance::support_distance(soles, both, diagonal);
    EXPECT_NEAR(planner.excess(soles, both, diagonal), d - 0.035, 1e-12) << yaw;
  }
}

TEST(StepDecision, BesideTheSupportTheSidewaysReachHoldsAndTheDiagonalsKeepLittleOfIt) {
  SteppingConfig c = deciding(0.02);
  c.cmp_reach_backward = 0.04;
  c.cmp_reach_sideways = 0.06;
  StepPlanner planner(c);
  const std::array<bool, 2> both{true, true};
  for (const double yaw : {0.0, -1.1}) {
    auto soles = standing();
    const Eigen::Rotation2Dd R(yaw);
    for (auto& sole : soles) {
      sole.centre = R * sole.centre;
      sole.yaw = yaw;
    }
    // 4 cm beside either foot: inside the sideways reach; ahead and behind as without it.
    for (const double side : {1.0, -1.0}) {
      const Vector2d xi = R * Vector2d(0.0, side * 0.19);
      EXPECT_NEAR(planner.excess(soles, both, xi), 0.04 - 0.06, 1e-12) << yaw;
      EXPECT_FALSE(planner.step_needed(soles, both, xi)) << yaw;
    }
    EXPECT_NEAR(planner.excess(soles, both, R * Vector2d(0.14, 0.0)), 0.04 - 0.02, 1e-12) << yaw;
    EXPECT_NEAR(planner.excess(soles, both, R * Vector2d(-0.14, 0.0)), 0.04 - 0.04, 1e-12) << yaw;
    // At 45° ahead: sin⁸ 45° = 1/16 of the sideways gain; at 45° behind also half the backward one.
    const Vector2d ahead = R * Vector2d(0.13, 0.13), behind = R * Vector2d(-0.13, 0.13);
    EXPECT_NEAR(planner.excess(soles, both, ahead), hpr::balance::support_distance(soles, both, ahead) - 0.0225, 1e-12);
    EXPECT_NEAR(planner.excess(soles, both, behind),
                hpr::balance::support_distance(soles, both, behind) - (0.02 + 0.5 * 0.02 + 0.04 / 16), 1e-12);
    // At 60° from ahead (sin² = 3/4): (3/4)⁴ of it.
    const Vector2d steep = R * Vector2d(0.5 * 0.3, std::sqrt(0.75) * 0.3);
    EXPECT_NEAR(planner.excess(soles, both, steep),
                hpr::balance::support_distance(soles, both, steep) - (0.02 + 0.04 * std::pow(0.75, 4)), 1e-12);
  }
}

TEST(StepDecision, TheReachShrinksWithTheTrunksLeanTowardsTheCapturePoint) {
  SteppingConfig c = deciding(0.04);
  c.lean_range = 0.3;
  StepPlanner planner(c);
  const auto soles = standing();
  const std::array<bool, 2> both{true, true};
  const Vector2d xi(0.13, 0.0);  // 3 cm ahead of the toes: inside the reach of an upright trunk
  const double d = hpr::balance::support_distance(soles, both, xi);
  const double s = std::sin(0.3);
  EXPECT_NEAR(planner.excess(soles, both, xi), d - 0.04, 1e-12) << "upright: the whole reach";
  EXPECT_NEAR(planner.excess(soles, both, xi, Vector2d(0.5 * s, 0.0)), d - 0.02, 1e-12) << "half the range spent";
  EXPECT_NEAR(planner.excess(soles, both, xi, Vector2d(2.0 * s, 0.0)), d, 1e-12) << "beyond the range: no reach left";
  EXPECT_NEAR(planner.excess(soles, both, xi, Vector2d(-0.5 * s, 0.0)), d - 0.04, 1e-12) << "leaning away spends none";
  EXPECT_NEAR(planner.excess(soles, both, xi, Vector2d(0.0, 0.5 * s)), d - 0.04, 1e-12) << "nor across";
  EXPECT_FALSE(planner.step_needed(soles, both, xi));
  EXPECT_TRUE(planner.step_needed(soles, both, xi, Vector2d(0.5 * s, 0.0))) << "a trunk leaning into the push steps sooner";
  // A lean at 45° to ξ counts with its component towards ξ.
  EXPECT_NEAR(planner.excess(soles, both, xi, Vector2d(0.5 * s, 0.5 * s)), d - 0.04 * (1.0 - 0.5), 1e-12);
  c.lean_range = 0.0;
  EXPECT_NEAR(StepPlanner(c).excess(soles, both, xi, Vector2d(0.5, 0.0)), d - 0.04, 1e-12) << "0: the lean is not looked at";
}

TEST(StepDecision, TheFootOnTheSideTheDcmRunsToSwingsElseTheLessLoadedOne) {
  const StepPlanner planner(SteppingConfig{});
  const auto soles = standing();
  EXPECT_EQ(planner.choose_swing(soles, Vector2d(0.05, 0.3), {0.5, 0.5}), kLeft);
  EXPECT_EQ(planner.choose_swing(soles, Vector2d(0.05, -0.3), {0.5, 0.5}), kRight);
  EXPECT_EQ(planner.choose_swing(soles, Vector2d(0.3, 0.02), {0.7, 0.3}), kLeft);
  EXPECT_EQ(planner.choose_swing(soles, Vector2d(0.3, 0.02), {0.3, 0.7}), kRight);
}

/// A configuration with a reach that never binds and the position cost off: the landing is the
/// LIP's own answer u = ξ_T − b.
SteppingConfig unconstrained() {
  SteppingConfig c;
  c.enabled = true;
  c.reach_forward = c.reach_backward = 5.0;
  c.min_width = 0.0;
  c.max_width = 5.0;
  c.weight_position = 0.0;
  c.weight_time = 1.0;
  return c;
}

TEST(StepPlanner, ThePendulumLandsWithItsDcmAtTheOffsetAndComesToRestOverTheNewFoot) {
  for (const double b : {0.0, 0.03}) {
    SteppingConfig c = unconstrained();
    c.dcm_offset = b;
    const StepPlanner planner(c);
    const auto soles = standing();
    // A push from behind: the CoM over the middle moving forward at 0.6 m/s.
    const Lip s0{Vector2d(0.0, 0.0), Vector2d(0.6, 0.0)};
    const Vector2d xi0 = hpr::balance::capture_point(s0.c, s0.cd, kOmega);
    const auto plan = planner.plan(soles, kLeft, xi0, kOmega);
    ASSERT_EQ(plan.swing, kLeft);
    EXPECT_TRUE(plan.reachable);
    EXPECT_NEAR(plan.duration, c.t_nominal, 0.5 * (c.t_max - c.t_min) / (c.time_samples - 1) + 1e-12);
    // Through the swing on the right foot, the CMP at its sole point nearest the DCM: (0.1, −0.05).
    const Lip at_touchdown = integrate(s0, Vector2d(0.1, -0.05), kOmega, plan.duration);
    const Vector2d xi_T = hpr::balance::capture_point(at_touchdown.c, at_touchdown.cd, kOmega);
    EXPECT_LT((xi_T - plan.xi_touchdown).norm(), 1e-9);
    EXPECT_NEAR((xi_T - plan.target).norm(), b, 1e-9) << "ξ_T − u = b";
    if (b == 0.0) {
      // The CMP at the new sole centre: the pendulum comes to rest over it.
      const Lip after = integrate(at_touchdown, plan.target, kOmega, 4.0);
      // (the pendulum's unstable mode amplifies the integration error by e^{ωt} ≈ 10⁶ here)
      EXPECT_LT((after.c - plan.target).norm(), 1e-4);
      EXPECT_LT(after.cd.norm(), 1e-4);
    }
  }
}

TEST(StepPlanner, TheReachBoxBindsTheLandingNeverCrossesAndAStrongPushStepsSooner) {
  SteppingConfig c;
  c.enabled = true;
  const StepPlanner planner(c);
  const auto soles = standing();
  // Mild push: the nominal step fits, away from the stance foot.
  const auto mild = planner.plan(soles, kLeft, Vector2d(0.16, 0.0), kOmega);
  const Vector2d local = soles[kRight].to_local(mild.target);
  EXPECT_GE(local.y(), c.min_width - 1e-12);
  EXPECT_LE(local.x(), c.reach_forward + 1e-12);
  // A push across the stance foot (DCM to the right while the left foot swings): the left foot
  // still lands at least min_width to the left of the right foot.
  const auto across = planner.plan(soles, kLeft, Vector2d(0.05, -0.4), kOmega);
  EXPECT_GE(soles[kRight].to_local(across.target).y(), c.min_width - 1e-12);
  // Strong push: the landing is at the forward reach, out of reach of the LIP's answer, and the
  // swing is as short as allowed (a later touchdown only lets the DCM run further).
  const auto strong = planner.plan(soles, kRight, Vector2d(0.6, 0.0), kOmega);
  EXPECT_FALSE(strong.reachable);
  EXPECT_NEAR(soles[kLeft].to_local(strong.target).x(), c.reach_forward, 1e-12);
  EXPECT_NEAR(strong.duration, c.t_min, 1e-12);
  // Replanning with the touchdown time kept: the landing for exactly the time left, the same as
  // the search finds when that is the only duration it may choose.
  SteppingConfig fixed = c;
  fixed.t_min = fixed.t_max = fixed.t_nominal = 0.3;
  const auto searched = StepPlanner(fixed).plan(soles, kLeft, Vector2d(0.2, 0.02), kOmega);
  const auto kept = planner.plan_landing(soles, kLeft, Vector2d(0.2, 0.02), kOmega, 0.3);
  EXPECT_EQ(kept.duration, 0.3);
  EXPECT_LT((kept.target - searched.target).norm(), 1e-12);
  EXPECT_LT((kept.xi_touchdown - hpr::balance::dcm_after(Vector2d(0.2, 0.02), hpr::balance::stance_cmp(soles[kRight], Vector2d(0.2, 0.02)), kOmega, 0.3)).norm(), 1e-12);
  // Replanning half-way through the swing searches only the time that is left.
  const auto replanned = planner.plan(soles, kLeft, Vector2d(0.16, 0.0), kOmega, 0.2);
  EXPECT_LE(replanned.duration, c.t_max - 0.2 + 1e-12);
  EXPECT_GE(replanned.duration, c.t_min - 0.2 - 1e-12);
}

TEST(StepPlanner, TheLandingStaysOnTheDeclaredGroundAtTheCheapestPlaceAndNoneMeansNoStep) {
  // A strong push forwards: without a ground the left foot lands at the forward reach. With the
  // ground ending 0.2 m ahead of the stance foot the whole landed sole stays on it, at the landing
  // a brute-force search over the box and the ground finds cheapest (the planner's cost for the
  // duration it chose); the stance foot turned 0.3 rad checks the rotated box and sole. A ground
  // that leaves no landing within reach gives no placeable step.
  SteppingConfig c;
  c.enabled = true;
  auto soles = standing();
  const Vector2d xi(0.5, 0.05);
  ASSERT_GT(StepPlanner(c).plan(soles, kLeft, xi, kOmega).target.x(), 0.3);
  for (const double yaw : {0.0, 0.3}) {
    for (auto& sole : soles) sole.yaw = yaw;
    SteppingConfig g = c;
    g.ground = std::array<double, 4>{-1.0, 0.2, -1.0, 1.0};
    const StepPlanner planner(g);
    const auto p = planner.plan(soles, kLeft, xi, kOmega);
    ASSERT_TRUE(p.placeable);
    const Sole landed{p.target, p.yaw, soles[kLeft].half_length, soles[kLeft].half_width};
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        EXPECT_LE(landed.to_world({sx * landed.half_length, sy * landed.half_width}).x(), 0.2 + 1e-9) << "yaw " << yaw;
      }
    }
    // The cost of a landing u for the chosen duration, as the planner states it (its terms in the
    // stance frame): w_p ‖u − u_nom‖² + w_b ‖ξ_T − b − u‖².
    const Sole& st = soles[kRight];
    Vector2d nominal = st.to_local(soles[kLeft].centre);
    nominal.y() = std::clamp(nominal.y(), c.min_width, c.max_width);
    const Vector2d want = st.to_local(p.xi_touchdown);  // b = 0
    auto cost = [&](const Vector2d& u) { return c.weight_position * (u - nominal).squaredNorm() + c.weight_offset * (want - u).squaredNorm(); };
    const double ex = landed.half_length * std::cos(yaw) + landed.half_width * std::sin(yaw);
    double best = std::numeric_limits<double>::infinity();
    for (double x = -c.reach_backward; x <= c.reach_forward; x += 5e-4) {
      for (double y = c.min_width; y <= c.max_width; y += 5e-4) {
        if (st.to_world({x, y}).x() + ex > 0.2) continue;
        best = std::min(best, cost({x, y}));
      }
    }
    const double planned = cost(st.to_local(p.target));
    EXPECT_LE(planned, best + 1e-9) << "no landing on the ground is cheaper";
    EXPECT_GT(planned, best - 1e-2) << "nor cheaper than the best on the grid by more than its spacing allows (0.1 %)";
  }
  for (auto& sole : soles) sole.yaw = 0.0;
  SteppingConfig none = c;
  none.ground = std::array<double, 4>{-1.0, 1.0, -1.0, 0.10};  // the left foot has nowhere to go
  EXPECT_FALSE(StepPlanner(none).plan(soles, kLeft, xi, kOmega).placeable);
  EXPECT_TRUE(StepPlanner(none).plan(soles, kRight, Vector2d(0.5, -0.05), kOmega).placeable) << "the right foot has";
}

TEST(SteppingConfig, LoadsAndRefusesOutOfRangeValuesNamingTheKey) {
  const auto cfg = hpr::Config::parse("stepping: {enabled: true, t_min: 0.2, t_max: 0.5, t_nominal: 0.3, cmp_reach: 0.03}", "test.yaml");
  const SteppingConfig c = SteppingConfig::load(cfg.section("stepping"));
  EXPECT_TRUE(c.enabled);
  EXPECT_EQ(c.t_min, 0.2);
  EXPECT_EQ(c.cmp_reach, 0.03);
  EXPECT_EQ(c.cmp_reach_backward, 0.03) << "unset, the reach behind is the reach ahead";
  const auto behind = hpr::Config::parse("stepping: {cmp_reach: 0.03, cmp_reach_backward: 0.05}", "test.yaml");
  EXPECT_EQ(SteppingConfig::load(behind.section("stepping")).cmp_reach_backward, 0.05);
  EXPECT_EQ(c.cmp_reach_sideways, 0.03) << "unset, the reach beside is the reach ahead";
  const auto beside = hpr::Config::parse("stepping: {cmp_reach: 0.03, cmp_reach_sideways: 0.06}", "test.yaml");
  EXPECT_EQ(SteppingConfig::load(beside.section("stepping")).cmp_reach_sideways, 0.06);
  EXPECT_THROW((void)SteppingConfig::load(hpr::Config::parse("stepping: {cmp_reach_sideways: -0.01}", "test.yaml").section("stepping")),
               hpr::ConfigError);
  EXPECT_EQ(c.lean_range, 0.0) << "unset, the lean is not looked at";
  const auto lean = hpr::Config::parse("stepping: {lean_range: 0.25}", "test.yaml");
  EXPECT_EQ(SteppingConfig::load(lean.section("stepping")).lean_range, 0.25);
  // The CoM's drop for a first step backwards is the drop forwards unless it is set.
  const auto drops = hpr::Config::parse("balance: {stepping: {com_drop: 0.03}}", "test.yaml");
  EXPECT_EQ(hpr::balance::PostureReferenceConfig::load(drops.section("balance")).step.com_drop_backward, 0.03);
  const auto backward = hpr::Config::parse("balance: {stepping: {com_drop: 0.03, com_drop_backward: 0.0}}", "test.yaml");
  EXPECT_EQ(hpr::balance::PostureReferenceConfig::load(backward.section("balance")).step.com_drop_backward, 0.0);
  // How long a push is taken to last: 2 times as long again by default, set and bounded.
  EXPECT_EQ(hpr::balance::PostureReferenceConfig::load(drops.section("balance")).step.push_duration_ratio, 2.0);
  const auto ratio = hpr::Config::parse("balance: {stepping: {push_duration_ratio: 1000, push_onset: 20}}", "test.yaml");
  const auto set = hpr::balance::PostureReferenceConfig::load(ratio.section("balance")).step;
  EXPECT_EQ(set.push_duration_ratio, 1000.0);
  EXPECT_EQ(set.push_onset, 20.0);
  try {
    (void)hpr::balance::PostureReferenceConfig::load(
        hpr::Config::parse("balance: {stepping: {push_duration_ratio: -1}}", "test.yaml").section("balance"));
    ADD_FAILURE() << "a negative push_duration_ratio was accepted";
  } catch (const hpr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("push_duration_ratio"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(c.ground.has_value()) << "unset, the ground is unbounded";
  const auto ground = hpr::Config::parse("stepping: {ground: [-1, 2, -0.5, 0.5]}", "test.yaml");
  EXPECT_EQ(SteppingConfig::load(ground.section("stepping")).ground.value()[1], 2.0);
  const auto inverted = hpr::Config::parse("stepping: {ground: [1, -1, -0.5, 0.5]}", "test.yaml");
  EXPECT_THROW((void)SteppingConfig::load(inverted.section("stepping")), hpr::ConfigError);
  const auto bad = hpr::Config::parse("stepping: {t_min: 0.4, t_max: 0.3}", "test.yaml");
  try {
    (void)SteppingConfig::load(bad.section("stepping"));
    FAIL() << "t_max below t_min accepted";
  } catch (const hpr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("t_max"), std::string::npos) << e.what();
  }
}

}  // namespace
