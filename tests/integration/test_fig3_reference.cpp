// fig3_reference on a log it did not make: a synthetic ankle-torque trace written as BALANCE_STATUS
// into an LCM log file. Its CSV must follow the paper's definitions for every α and β: phase 1
// begins at the first sample beyond α τ^lim (23), phase 2 lasts T = 3 |l(t₂)| / (2 β max|l̇|) (26),
// (27); a larger α starts later and generates less CAM, a larger β reduces it sooner.
#include <gtest/gtest.h>

#include <humanoid/balance_status_t.hpp>

#include <cmath>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "process_group.hpp"
#include "shell.hpp"

namespace {

constexpr double kLimit = 77.7;  // τ^lim of the synthetic trace [N m]
constexpr double kPushStart = 1.0, kPushWidth = 0.6, kPeak = 95.0;

double tau_ankle(double t) {
  if (t < kPushStart || t > kPushStart + kPushWidth) return 0.0;
  const double s = std::sin(M_PI * (t - kPushStart) / kPushWidth);
  return -kPeak * s * s;  // a push from behind: the CoP forward, τ_y negative
}

struct Row {
  double t, tau, thres, l, ldot;
  int phase;
};

void write_log(const std::string& path) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good());
  std::vector<uint8_t> buf;
  for (int k = 0; k <= 4000; ++k) {
    humanoid::balance_status_t m{};
    m.tick = k;
    m.utime = static_cast<int64_t>(k) * 1000;
    m.tau_ankle_V[1] = tau_ankle(k * 1e-3);
    for (int i = 0; i < 3; ++i) {
      m.tau_min_V[i] = -kLimit;
      m.tau_max_V[i] = kLimit;
    }
    m.num_contacts = 0;
    buf.resize(static_cast<size_t>(m.getEncodedSize()));
    ASSERT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
    lcm::LogEvent e{};
    e.eventnum = k;
    e.timestamp = m.utime;
    e.channel = "BALANCE_STATUS";
    e.datalen = static_cast<int32_t>(buf.size());
    e.data = buf.data();
    ASSERT_EQ(log.writeEvent(&e), 0);
  }
}

TEST(Fig3Reference, FollowsThePapersDefinitionsForEveryAlphaAndBeta) {
  const std::string dir = hpr::test::temp_dir("fig3-reference");
  write_log(dir + "/ankle.lcm");
  const auto r = hpr::test::run_command({hpr::test::bin_dir() + "/fig3_reference", dir + "/ankle.lcm", dir + "/fig3.csv",
                                         "--alphas", "0.7,0.8,0.9", "--betas", "0.3,0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // series → (α, β) → rows
  std::map<std::string, std::map<std::pair<double, double>, std::vector<Row>>> runs;
  std::istringstream csv(hpr::test::read_file(dir + "/fig3.csv"));
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "series,alpha,beta,t,tau_ankle,tau_min,tau_max,tau_thres,l_ref,ldot_ref,phase");
  while (std::getline(csv, line)) {
    std::istringstream in(line);
    std::string series, f;
    std::getline(in, series, ',');
    std::vector<double> v;
    while (std::getline(in, f, ',')) v.push_back(std::stod(f));
    ASSERT_EQ(v.size(), 10U) << line;
    runs[series][{v[0], v[1]}].push_back({v[2], v[3], v[6], v[7], v[8], static_cast<int>(v[9])});
  }
  ASSERT_EQ(runs["alpha"].size(), 3U);
  ASSERT_EQ(runs["beta"].size(), 2U);
  double last_start = 0.0, last_peak = 1e9;
  for (const auto& [series, by_params] : runs) {
    for (const auto& [params, rows] : by_params) {
      const auto [alpha, beta] = params;
      ASSERT_EQ(rows.size(), 4001U);
      size_t k1 = 0, k2 = 0, k3 = 0;
      double peak = 0.0, peak_rate = 0.0;
      for (size_t k = 1; k < rows.size(); ++k) {
        EXPECT_DOUBLE_EQ(rows[k].tau, tau_ankle(static_cast<double>(k) * 1e-3)) << "the log's torque, sample " << k;
        if (rows[k].phase == 1 && rows[k - 1].phase == 0) k1 = k;
        if (rows[k].phase == 2 && rows[k - 1].phase == 1) k2 = k;
        if (rows[k].phase == 3 && rows[k - 1].phase == 2) k3 = k;
        if (rows[k].phase == 1) peak_rate = std::max(peak_rate, std::abs(rows[k].ldot));
        peak = std::max(peak, std::abs(rows[k].l));
      }
      ASSERT_GT(k1, 0U) << series << " alpha " << alpha;
      ASSERT_GT(k2, k1);
      ASSERT_GT(k3, k2);
      // (23): the first sample beyond α τ^lim.
      EXPECT_LT(rows[k1].tau, -alpha * kLimit);
      EXPECT_GE(rows[k1 - 1].tau, -alpha * kLimit);
      // (24) in phase 1: l̇ = τ^thres − τ^ankle.
      EXPECT_NEAR(rows[k1 + 5].ldot, -alpha * kLimit - rows[k1 + 5].tau, 1e-9);
      // (26), (27): the reduction lasts T = 3 |l(t₂)| / (2 β max|l̇|), to one sample.
      const double T = 3.0 * std::abs(rows[k2 - 1].l) / (2.0 * beta * peak_rate);
      EXPECT_NEAR(rows[k3].t - rows[k2].t, T, 2e-3) << series << " alpha " << alpha << " beta " << beta;
      if (series == "alpha") {
        EXPECT_DOUBLE_EQ(beta, 0.4) << "the configured beta";
        EXPECT_GT(rows[k1].t, last_start) << "a larger alpha starts later";
        EXPECT_LT(peak, last_peak) << "and generates less CAM";
        last_start = rows[k1].t;
        last_peak = peak;
      } else {
        EXPECT_DOUBLE_EQ(alpha, 0.9) << "the configured alpha";
      }
    }
  }
  const auto& b = runs["beta"];
  const auto phase2 = [](const std::vector<Row>& rows) {
    int n = 0;
    for (const auto& x : rows) n += x.phase == 2 ? 1 : 0;
    return n;
  };
  EXPECT_GT(phase2(b.at({0.9, 0.3})), phase2(b.at({0.9, 0.5}))) << "a larger beta reduces the CAM sooner";
}

TEST(Fig3Reference, ALogWithoutBalanceStatusIsAnErrorNamingIt) {
  const std::string dir = hpr::test::temp_dir("fig3-reference-empty");
  {
    lcm::LogFile log(dir + "/empty.lcm", "w");
    ASSERT_TRUE(log.good());
  }
  const auto r = hpr::test::run_command({"sh", "-c", hpr::test::quote(hpr::test::bin_dir() + "/fig3_reference") + " " +
                                                         hpr::test::quote(dir + "/empty.lcm") + " " +
                                                         hpr::test::quote(dir + "/x.csv") + " 2>&1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("fewer than two BALANCE_STATUS"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("empty.lcm"), std::string::npos) << r.out;
}

}  // namespace
