// push_tune's parameters: the unit cube maps onto each range and back (logarithmically where the
// search runs on the logarithm), the top of a bound's range switches it off, a configured value is
// read where the configuration keeps it, and a value survives its text.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/experiments/tuning.hpp"
#include "scratch_dir.hpp"

namespace {

using namespace hpr::experiments;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Tuning, TheUnitIntervalMapsOntoEveryRangeAndBack) {
  for (const TunedParam& p : tuned_params()) {
    EXPECT_DOUBLE_EQ(from_unit(p, 0.0), p.lo) << p.name;
    if (!p.off_at_top) {
      EXPECT_NEAR(from_unit(p, 1.0), p.hi, 1e-12 * p.hi) << p.name;
    }
    for (const double u : {0.1, 0.37, 0.5, 0.9}) EXPECT_NEAR(to_unit(p, from_unit(p, u)), u, 1e-12) << p.name;
    EXPECT_DOUBLE_EQ(to_unit(p, p.lo / 10.0), 0.0) << p.name << ": below the range, clamped";
    EXPECT_DOUBLE_EQ(to_unit(p, kInf), 1.0) << p.name << ": above the range, clamped";
  }
  // Logarithmic: the middle of the interval is the geometric mean.
  const TunedParam& q_l = tuned_param("Q_l");
  ASSERT_TRUE(q_l.log_scale);
  EXPECT_NEAR(from_unit(q_l, 0.5), std::sqrt(q_l.lo * q_l.hi), 1e-12);
  const TunedParam& alpha = tuned_param("alpha");
  ASSERT_FALSE(alpha.log_scale);
  EXPECT_NEAR(from_unit(alpha, 0.5), 0.5 * (alpha.lo + alpha.hi), 1e-12);
}

TEST(Tuning, TheTopOfALeanBudgetsRangeSwitchesItOff) {
  const TunedParam& lean = tuned_param("lean_y_pos");
  ASSERT_TRUE(lean.off_at_top);
  EXPECT_EQ(from_unit(lean, 1.0), kInf);
  EXPECT_LT(from_unit(lean, 0.999), lean.hi);
  EXPECT_EQ(value_text(kInf), ".inf");
  EXPECT_EQ(text_value(".inf"), kInf);
}

TEST(Tuning, AnUnknownNameIsRefusedNamingTheKnownOnes) {
  try {
    (void)tuned_param("gamma");
    FAIL() << "gamma accepted";
  } catch (const hpr::UsageError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'gamma'"), std::string::npos) << what;
    for (const TunedParam& p : tuned_params()) EXPECT_NE(what.find(p.name), std::string::npos) << what;
  }
}

TEST(Tuning, TheConfiguredValueIsReadWhereTheConfigurationKeepsIt) {
  const hpr::test::ScratchDir dir("tuning");
  const auto file = (dir.path() / "robot.yaml").string();
  std::ofstream(file) << "reference_gen:\n  alpha: 0.85\n  y:\n    lean_budget_negative: [4.5]\n"
                      << "motion_opt:\n  weights:\n    cam: 2.5\n";
  const hpr::Config cfg = hpr::Config::load(file);
  EXPECT_DOUBLE_EQ(configured_value(cfg, tuned_param("alpha")), 0.85);
  EXPECT_DOUBLE_EQ(configured_value(cfg, tuned_param("Q_l")), 2.5);
  EXPECT_DOUBLE_EQ(configured_value(cfg, tuned_param("lean_y_neg")), 4.5) << "the first entry of a list";
  EXPECT_EQ(configured_value(cfg, tuned_param("lean_y_pos")), kInf) << "not configured: off";
}

TEST(Tuning, AValueSurvivesItsTextToSixDigits) {
  for (const double v : {0.9, 3.0, 0.123456, 17.25, 1e-3}) {
    EXPECT_EQ(text_value(value_text(v)), v) << value_text(v);
  }
  EXPECT_EQ(value_text(0.1234567), "0.123457");
}

}  // namespace
