// The dominance table's checks (push_sweep --dominance) and the strategy names the tools accept.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "hpr/experiments/dominance.hpp"
#include "hpr/experiments/trial.hpp"

namespace {

using hpr::experiments::DominanceCell;
using hpr::experiments::DominanceRow;

std::vector<DominanceCell> push(double peak, const std::string& support, double direction, double a, double b, double c,
                                bool b_capped = false) {
  return {{support, "cam", peak, direction, a, false},
          {support, "cam-standing", peak, direction, b, b_capped},
          {support, "ankle-standing", peak, direction, c, false}};
}

}  // namespace

TEST(Dominance, TheDefaultMayTrailTheBetterSingleStrategyByTheToleranceAndNoMore) {
  std::vector<DominanceCell> cells = push(65, "double", 0, 40.0, 40.5, 30.0);  // 0.5 below: holds
  for (const auto& c : push(65, "double", 45, 40.0, 30.0, 40.6)) cells.push_back(c);  // 0.6 below the ankle: fails
  for (const auto& c : push(130, "left", 90, 20.0, 10.0, 12.0)) cells.push_back(c);
  const std::vector<DominanceRow> rows = hpr::experiments::dominance_rows(cells);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(rows[0].dominates);
  EXPECT_FALSE(rows[1].dominates);
  EXPECT_TRUE(rows[2].dominates);
  EXPECT_EQ(rows[2].support, "left");
  EXPECT_EQ(rows[2].peak, 130.0);
  const std::string md = hpr::experiments::dominance_table(cells, "toro.yaml", 120, 0.5);
  EXPECT_NE(md.find("### 65 N peak"), std::string::npos) << md;
  EXPECT_NE(md.find("### 130 N peak"), std::string::npos) << md;
  EXPECT_NE(md.find("- 65 N, double support, 45 deg: the default 40.00 N s against 30.00 / 40.60 N s standing"), std::string::npos) << md;
  EXPECT_EQ(md.find("Every check holds"), std::string::npos) << md;
}

TEST(Dominance, TheHipStrategysRatioIsCheckedOnlySagittallyInDoubleSupportBelowTheCap) {
  std::vector<DominanceCell> cells = push(65, "double", 0, 50, 40, 32.5);  // 1.23: fails
  for (const auto& c : push(65, "double", 180, 50, 40, 32.0)) cells.push_back(c);  // 1.25: holds
  for (const auto& c : push(65, "double", 90, 50, 30, 30)) cells.push_back(c);  // sideways: not checked
  for (const auto& c : push(65, "double", 360 + 180, 50, 120, 100, true)) cells.push_back(c);  // capped: not checked
  for (const auto& c : push(65, "left", 0, 50, 30, 30)) cells.push_back(c);  // single support: not checked
  const auto rows = hpr::experiments::dominance_rows(cells);
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_TRUE(rows[0].ratio_applies);
  EXPECT_FALSE(rows[0].ratio_met);
  EXPECT_TRUE(rows[1].ratio_applies);
  EXPECT_TRUE(rows[1].ratio_met);
  EXPECT_FALSE(rows[2].ratio_applies);
  EXPECT_FALSE(rows[3].ratio_applies);
  EXPECT_FALSE(rows[4].ratio_applies);
  const std::string md = hpr::experiments::dominance_table(cells, "toro.yaml", 120, 0.5);
  EXPECT_NE(md.find("CAM / ankle standing 1.23 (below 1.25)"), std::string::npos) << md;
  EXPECT_NE(md.find("120.00+"), std::string::npos) << md;
}

TEST(Dominance, AMissingFigureNeverCountsAsHeld) {
  std::vector<DominanceCell> cells = push(65, "double", 0, 40, 30, 30);
  cells[0].max_recovered.reset();  // the default's search failed
  const auto rows = hpr::experiments::dominance_rows(cells);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_FALSE(rows[0].dominates);
  EXPECT_NE(hpr::experiments::dominance_table(cells, "x", 80, 0.5).find("failed"), std::string::npos);
}

TEST(Variant, StandingTurnsSteppingOffAfterTheConfigurationAndItsOverrides) {
  using namespace hpr::experiments;
  EXPECT_THROW(variant_from_string("hip"), std::invalid_argument);
  EXPECT_THROW(variant_from_string("-standing"), std::invalid_argument);
  const Variant v = variant_from_string("ankle-standing");
  EXPECT_EQ(v.strategy, Strategy::kAnkle);
  EXPECT_TRUE(v.standing);

  const auto dir = std::filesystem::temp_directory_path() / "hpr_test_variant";
  std::filesystem::create_directories(dir);
  const std::string stepping = (dir / "stepping.yaml").string();
  std::ofstream(stepping) << "balance:\n  stepping:\n    enabled: true\n";
  TrialSpec spec;
  spec.config = stepping;
  spec.overrides = {"balance.stepping.enabled=false", "balance.stepping.enabled=true"};
  EXPECT_TRUE(steps_enabled(spec));
  EXPECT_EQ(variant_name(spec), "cam");
  apply(v, spec);
  EXPECT_EQ(spec.strategy, Strategy::kAnkle);
  EXPECT_FALSE(steps_enabled(spec)) << "the variant's override comes last";
  EXPECT_EQ(variant_name(spec), "ankle-standing");

  spec.overrides.clear();
  EXPECT_TRUE(steps_enabled(spec)) << "the configuration steps";
  const std::string bad = (dir / "bad.yaml").string();
  std::ofstream(bad) << "balance:\n  stepping:\n    enabled: sometimes\n";
  spec.config = bad;
  try {
    (void)steps_enabled(spec);
    ADD_FAILURE() << "a non-boolean was read as one";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("balance.stepping.enabled"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}
