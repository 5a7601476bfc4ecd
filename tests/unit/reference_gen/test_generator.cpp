// The three-phase CAM reference generator on synthetic ankle torque traces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "hpr/reference_gen/generator.hpp"
#include "process_group.hpp"

namespace {

using namespace hpr::reference_gen;

constexpr double kDt = 1e-3;
constexpr double kLimit = 77.7;  // f_vz 777 N, sole half-length 0.1 m

// Ankle torque about y of a push from behind at t0 (CoP forward: negative τ_y), peak `peak`.
double push_trace(double t, double t0, double peak, double width = 0.8) {
  if (t < t0 || t > t0 + width) return 0.0;
  const double s = std::sin(M_PI * (t - t0) / width);
  return -peak * s * s;
}

struct Sample {
  double t, tau, thres, l, ldot;
  Phase phase;
};

std::vector<Sample> run_axis(AxisParams p, const std::function<double(double)>& tau, double t_end = 6.0) {
  GeneratorConfig cfg;
  AxisGenerator g(p);
  std::vector<Sample> out;
  for (int k = 0; k * kDt <= t_end; ++k) {
    const double t = k * kDt;
    g.step(t, kDt, tau(t), -kLimit, kLimit, true, cfg);
    out.push_back({t, tau(t), g.threshold(), g.l(), g.ldot(), g.phase()});
  }
  return out;
}

TEST(ReferenceGenerator, PhaseBoundariesFollowTheDefinitions) {
  const AxisParams p{0.9, 0.4};
  const auto s = run_axis(p, [](double t) { return push_trace(t, 1.0, 100.0); });
  int k1 = -1, k2 = -1, k3 = -1;
  for (size_t k = 1; k < s.size(); ++k) {
    if (s[k].phase == Phase::kGenerate && s[k - 1].phase != Phase::kGenerate && k1 < 0) k1 = static_cast<int>(k);
    if (s[k].phase == Phase::kReduce && s[k - 1].phase == Phase::kGenerate) k2 = static_cast<int>(k);
    if (s[k].phase == Phase::kRecover && s[k - 1].phase == Phase::kReduce) k3 = static_cast<int>(k);
  }
  ASSERT_GT(k1, 0);
  ASSERT_GT(k2, k1);
  ASSERT_GT(k3, k2);
  // t₁: the first sample with |τ| above α τ^lim; t₂: the first one below again.
  EXPECT_GT(std::abs(s[static_cast<size_t>(k1)].tau), p.alpha * kLimit);
  EXPECT_LE(std::abs(s[static_cast<size_t>(k1) - 1].tau), p.alpha * kLimit);
  EXPECT_LT(std::abs(s[static_cast<size_t>(k2)].tau), p.alpha * kLimit);
  EXPECT_GE(std::abs(s[static_cast<size_t>(k2) - 1].tau), p.alpha * kLimit);
  // Phase 1: l̇ = τ^thres − τ^ankle (24), positive here, so l rises monotonically.
  for (int k = k1; k < k2; ++k) {
    EXPECT_NEAR(s[static_cast<size_t>(k)].ldot, -p.alpha * kLimit - s[static_cast<size_t>(k)].tau, 1e-12);
    EXPECT_GE(s[static_cast<size_t>(k)].l, s[static_cast<size_t>(k) - 1].l);
  }
  EXPECT_GT(s[static_cast<size_t>(k2) - 1].l, 0.1) << "CAM must build up";
  // After phase 2: exactly zero.
  EXPECT_EQ(s[static_cast<size_t>(k3)].l, 0.0);
  EXPECT_EQ(s[static_cast<size_t>(k3)].ldot, 0.0);
}

TEST(ReferenceGenerator, ReductionIsC1AndItsPeakRateIsLdotMax) {
  GeneratorConfig cfg;
  AxisGenerator g({0.8, 0.4});
  double l_end1 = 0, ldot_end1 = 0, t2 = -1;
  double peak2 = 0;
  for (int k = 0; k * kDt <= 6.0; ++k) {
    const double t = k * kDt;
    const Phase before = g.phase();
    const double l_before = g.l(), ldot_before = g.ldot();
    g.step(t, kDt, push_trace(t, 1.0, 110.0), -kLimit, kLimit, true, cfg);
    if (before == Phase::kGenerate && g.phase() == Phase::kReduce) {
      l_end1 = l_before;
      ldot_end1 = ldot_before;
      t2 = t;
    }
    if (g.phase() == Phase::kReduce) peak2 = std::max(peak2, std::abs(g.ldot()));
  }
  ASSERT_GT(t2, 0);
  // C¹ at t₂: the cubic starts at the last phase-1 value and rate.
  const Eigen::Vector2d start = g.cubic(t2);
  EXPECT_NEAR(start(0), l_end1, 1e-9);
  EXPECT_NEAR(start(1), ldot_end1, 1e-9);
  // At t₃ = t₂ + T: zero CAM and zero rate (25).
  const Eigen::Vector2d end = g.cubic(t2 + g.duration());
  EXPECT_NEAR(end(0), 0.0, 1e-9);
  EXPECT_NEAR(end(1), 0.0, 1e-9);
  // T = 3 |l(t₂)| / (2 l̇^max) (26), l̇^max = β max|l̇| (27): the cubic's peak rate is l̇^max.
  EXPECT_NEAR(g.duration(), 1.5 * std::abs(l_end1) / g.ldot_max(), 1e-12);
  EXPECT_NEAR(g.ldot_max(), 0.4 * g.peak_rate(), 1e-12);
  EXPECT_NEAR(peak2, g.ldot_max(), 0.02 * g.ldot_max());
}

TEST(ReferenceGenerator, LargerAlphaStartsLaterWithASmallerPeak) {
  double last_t1 = -1, last_peak = 1e9;
  for (double alpha : {0.7, 0.8, 0.9}) {
    const auto s = run_axis({alpha, 0.4}, [](double t) { return push_trace(t, 1.0, 100.0); });
    double t1 = -1, peak = 0;
    for (const auto& x : s) {
      if (x.phase == Phase::kGenerate && t1 < 0) t1 = x.t;
      peak = std::max(peak, std::abs(x.l));
    }
    EXPECT_GT(t1, last_t1) << "alpha " << alpha;
    EXPECT_LT(peak, last_peak) << "alpha " << alpha;
    last_t1 = t1;
    last_peak = peak;
  }
}

TEST(ReferenceGenerator, SecondPushInPhase2ReentersPhase1WithoutAJump) {
  GeneratorConfig cfg;
  AxisGenerator g({0.9, 0.4});
  bool seen_reduce = false, reentered = false;
  double prev_l = 0;
  double second = -1;
  for (int k = 0; k * kDt <= 8.0; ++k) {
    const double t = k * kDt;
    if (g.phase() == Phase::kReduce && !seen_reduce) {
      seen_reduce = true;
      second = t + 0.05;  // a second push shortly after phase 2 began
    }
    const double tau = push_trace(t, 1.0, 100.0) + (second > 0 ? push_trace(t, second, 100.0) : 0.0);
    const Phase before = g.phase();
    g.step(t, kDt, tau, -kLimit, kLimit, true, cfg);
    if (before == Phase::kReduce && g.phase() == Phase::kGenerate) {
      reentered = true;
      EXPECT_LT(std::abs(g.l() - prev_l), std::abs(g.ldot()) * kDt + 1e-9) << "no jump at re-entry";
    }
    prev_l = g.l();
  }
  EXPECT_TRUE(reentered);
}

TEST(ReferenceGenerator, ABriefReentryDuringTheReductionKeepsItsRate) {
  // A push, then during phase 2 the ankle torque touches the threshold again for 20 ms, just above
  // it: phase 1 again, with rates far below the push's. The reduction that follows keeps the rate
  // of the whole episode (27): it ends within the duration (26) of the push's own peak rate, not
  // after the tens of seconds the brief re-entry's rates would give.
  GeneratorConfig cfg;
  const AxisParams p{0.9, 0.4};
  AxisGenerator g(p);
  double reentry = -1, peak = 0, t_end_reduce = -1, l_at_reentry_exit = 0;
  int reentries = 0;
  for (int k = 0; k * kDt <= 12.0; ++k) {
    const double t = k * kDt;
    if (g.phase() == Phase::kReduce && reentry < 0) reentry = t + 0.05;
    double tau = push_trace(t, 1.0, 100.0);
    if (reentry > 0 && t >= reentry && t < reentry + 0.02) tau = -0.9 * kLimit - 0.1;  // just beyond the threshold
    const Phase before = g.phase();
    g.step(t, kDt, tau, -kLimit, kLimit, true, cfg);
    if (before != Phase::kGenerate && g.phase() == Phase::kGenerate && reentry > 0) ++reentries;
    if (before == Phase::kGenerate && g.phase() == Phase::kReduce && reentry > 0) l_at_reentry_exit = g.l();
    if (g.phase() == Phase::kGenerate && reentry < 0) peak = std::max(peak, std::abs(g.ldot()));
    if (before == Phase::kReduce && g.phase() == Phase::kRecover && reentries > 0) t_end_reduce = t;
  }
  ASSERT_EQ(reentries, 1);
  ASSERT_GT(std::abs(l_at_reentry_exit), 0.1);
  const double T_push = 3.0 * std::abs(l_at_reentry_exit) / (2.0 * p.beta * peak);
  ASSERT_GT(t_end_reduce, 0.0) << "the reduction ended";
  EXPECT_LT(t_end_reduce - (reentry + 0.02), T_push + 0.01);
}

TEST(ReferenceGenerator, AxesAreIndependent) {
  GeneratorConfig cfg;
  ReferenceGenerator both(cfg), y_only(cfg);
  BalanceInput b;
  b.tau_min_V = Eigen::Vector3d(-40, -kLimit, -20);
  b.tau_max_V = Eigen::Vector3d(40, kLimit, 20);
  for (int k = 0; k * kDt <= 5.0; ++k) {
    const double t = k * kDt;
    b.time = t;
    b.tau_ankle_V = Eigen::Vector3d(-0.8 * push_trace(t, 1.5, 60.0), push_trace(t, 1.0, 100.0), 0.0);
    const auto& o1 = both.step(t, kDt, b, true, 0.0);
    BalanceInput by = b;
    by.tau_ankle_V.x() = 0;
    const auto& o2 = y_only.step(t, kDt, by, true, 0.0);
    ASSERT_EQ(o1.l_ref_V.y(), o2.l_ref_V.y()) << "y must not depend on x, t = " << t;
    ASSERT_EQ(o2.l_ref_V.x(), 0.0);
    ASSERT_EQ(o1.l_ref_V.z(), 0.0);
  }
}

TEST(ReferenceGenerator, StaleBalanceStatusHoldsThenRampsToZero) {
  GeneratorConfig cfg;
  ReferenceGenerator g(cfg);
  BalanceInput b;
  b.tau_min_V = Eigen::Vector3d(-40, -kLimit, -20);
  b.tau_max_V = Eigen::Vector3d(40, kLimit, 20);
  double t = 0, l_at_loss = 0;
  for (; t < 1.3; t += kDt) {  // in phase 1 at 1.3 s
    b.time = t;
    b.tau_ankle_V = Eigen::Vector3d(0, push_trace(t, 1.0, 100.0), 0);
    l_at_loss = g.step(t, kDt, b, true, 1.0).l_ref_V.y();
  }
  ASSERT_GT(l_at_loss, 0.0);
  const double t_loss = t;
  double held = -1;
  for (; t < t_loss + 3.0; t += kDt) {
    const auto& o = g.step(t, kDt, b, true, 1.0);  // b.time stays at the last message
    const double age = t - b.time;
    if (age <= cfg.stale_hold_time) continue;  // a message this recent is still used
    EXPECT_TRUE(o.stale);
    if (age < cfg.stale_hold_time + cfg.stale_ramp_time - kDt) {
      if (held < 0) held = o.l_ref_V.y();
      EXPECT_DOUBLE_EQ(o.l_ref_V.y(), held) << "held while stale";
    }
  }
  EXPECT_GT(held, 0.0);
  EXPECT_NEAR(g.output().l_ref_V.y(), 0.0, 1e-12) << "ramped to zero";
}

// ∫ l dt of one episode (the generator's own sum is not used).
double episode_integral(const std::vector<Sample>& s) {
  double sum = 0;
  for (const Sample& x : s) sum += x.l * kDt;
  return sum;
}

TEST(ReferenceGenerator, TheLeanBudgetBoundsTheIntegralOfTheEpisode) {
  // A push from behind builds l > 0. Unbounded, its episode's ∫ l dt is S; with a budget of S/3 for
  // l > 0 phase 2 begins early, the episode's ∫ l dt (summed here from the samples) comes to the
  // budget within one tick's worth, and l stays below the unbounded peak. A budget for l < 0 alone
  // changes nothing.
  const auto trace = [](double t) { return push_trace(t, 1.0, 110.0); };
  const AxisParams paper{0.9, 0.4};
  const auto free = run_axis(paper, trace);
  const double S = episode_integral(free);
  ASSERT_GT(S, 0.05);
  AxisParams bounded = paper;
  bounded.budget_positive = S / 3.0;
  const auto b = run_axis(bounded, trace);
  const double peak_free = std::max_element(free.begin(), free.end(), [](auto& x, auto& y) { return x.l < y.l; })->l;
  const double peak_b = std::max_element(b.begin(), b.end(), [](auto& x, auto& y) { return x.l < y.l; })->l;
  EXPECT_NEAR(episode_integral(b), S / 3.0, 0.01 * S / 3.0);
  EXPECT_LT(peak_b, 0.8 * peak_free);
  EXPECT_EQ(b.back().phase, Phase::kIdle) << "the episode ends";
  // Phase 2 began while the ankle torque was still beyond the threshold, and phase 1 did not come back.
  size_t k2 = 0;
  while (k2 < b.size() && b[k2].phase != Phase::kReduce) ++k2;
  ASSERT_LT(k2, b.size());
  EXPECT_GT(std::abs(b[k2].tau), std::abs(b[k2].thres));
  for (size_t k = k2; k < b.size(); ++k) ASSERT_NE(b[k].phase, Phase::kGenerate) << "t = " << b[k].t;

  AxisParams other_sign = paper;
  other_sign.budget_negative = S / 3.0;
  const auto o = run_axis(other_sign, trace);
  ASSERT_EQ(o.size(), free.size());
  for (size_t k = 0; k < o.size(); ++k) ASSERT_EQ(o[k].l, free[k].l) << "t = " << o[k].t;
}

TEST(ReferenceGenerator, AfterASpentBudgetTheNextEpisodeBuildsAgain) {
  // Phase 1 stays shut after the budget ended it, while the push goes on, until the axis is idle
  // (the posture back once the push is over); a push after that gets a new budget.
  GeneratorConfig cfg;
  AxisParams p{0.9, 0.4};
  p.budget_positive = 0.02;
  AxisGenerator g(p);
  int episodes = 0, spent_in = 0;
  double second = -1;
  for (int k = 0; k * kDt <= 10.0; ++k) {
    const double t = k * kDt;
    if (episodes == 1 && g.phase() == Phase::kIdle && second < 0) second = t + 0.5;
    const double tau = push_trace(t, 1.0, 110.0) + (second > 0 ? push_trace(t, second, 110.0) : 0.0);
    const Phase before = g.phase();
    const bool spent_before = g.budget_spent();
    g.step(t, kDt, tau, -kLimit, kLimit, /*posture_converged=*/tau == 0.0, cfg);
    if (before != Phase::kGenerate && g.phase() == Phase::kGenerate) ++episodes;
    if (!spent_before && g.budget_spent()) {
      ++spent_in;
      EXPECT_GT(std::abs(tau), std::abs(g.threshold())) << "spent while the push is beyond the threshold, t = " << t;
    }
    if (g.phase() != Phase::kIdle) {
      // 2 %: the sum of 1 ms samples against the cubic's integral, and phase 1's last tick, on a
      // budget this small
      ASSERT_LE(g.stored(), 1.02 * p.budget_positive) << "t = " << t;
    }
  }
  EXPECT_GT(second, 0.0) << "idle after the first push";
  EXPECT_EQ(episodes, 2) << "phase 1 once per push, although each push stayed beyond the threshold after its budget";
  EXPECT_EQ(spent_in, 2) << "each push spent its own budget";
}

TEST(ReferenceGenerator, TheLeanBudgetIsReadPerAxisAndSign) {
  const auto load = [](const std::string& yaml) { return GeneratorConfig::load(hpr::Config::parse(yaml, "gen.yaml")); };
  const GeneratorConfig signs = load("y: {lean_budget_negative: 0.25, lean_budget_positive: 2.0}\n");
  EXPECT_EQ(signs.axes[1].budget_negative, 0.25);
  EXPECT_EQ(signs.axes[1].budget_positive, 2.0);
  EXPECT_TRUE(std::isinf(signs.axes[0].budget_positive)) << "other axes unbounded";
  EXPECT_TRUE(std::isinf(load("y: {lean_budget_positive: .inf}\n").axes[1].budget_positive));
  try {
    (void)load("y: {lean_budget_negative: -1}\n");
    FAIL() << "a negative budget must be rejected";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("gen.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find("y.lean_budget_negative"), std::string::npos) << what;
  }
}

// Golden figure: the Fig. 3 scenario (12 N s from behind at t = 1 s) for α ∈ {0.7, 0.8, 0.9} at
// β = 0.4 and β ∈ {0.3, 0.4, 0.5} at α = 0.7, saved as an image for a person to compare with the paper.
TEST(ReferenceGenerator, Fig3GoldenFigure) {
  const std::string dir = hpr::test::temp_dir("fig3");
  std::ofstream csv(dir + "/fig3.csv");
  csv << "series,alpha,beta,t,tau_ankle,tau_min,tau_max,tau_thres,l_ref,ldot_ref,phase\n";
  auto write = [&](const char* series, AxisParams p) {
    const auto s = run_axis(p, [](double t) { return push_trace(t, 1.0, 95.0, 0.6); }, 4.0);
    for (const auto& x : s) {
      csv << series << "," << p.alpha << "," << p.beta << "," << x.t << "," << x.tau << "," << -kLimit << "," << kLimit << ","
          << x.thres << "," << x.l << "," << x.ldot << "," << static_cast<int>(x.phase) << "\n";
    }
  };
  for (double alpha : {0.7, 0.8, 0.9}) write("alpha", {alpha, 0.4});
  for (double beta : {0.3, 0.4, 0.5}) write("beta", {0.7, beta});
  csv.close();
  const std::string png = dir + "/fig3_reference_generation.png";
  const std::string cmd = "/usr/bin/python3 " + hpr::test::source_dir() + "/tools/plots/plot_fig3.py " + dir +
                          "/fig3.csv " + png;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_GT(std::filesystem::file_size(png), 10000U);
  std::cout << "figure: " << png << std::endl;
}

}  // namespace
