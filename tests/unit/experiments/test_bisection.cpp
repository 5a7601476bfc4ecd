// The envelope search on synthetic robots whose largest recoverable impulse is known: the bracket it
// returns holds that threshold and is at most the resolution wide, whatever the threshold; a robot
// that recovers the largest push allowed costs two trials; no impulse is tried twice or beyond the
// maximum.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "hpr/experiments/bisection.hpp"

namespace {

using hpr::experiments::ImpulseBracket;
using hpr::experiments::largest_recovered;

constexpr double kStart = 15.0, kMax = 80.0, kResolution = 0.5;

/// A robot that recovers every impulse up to `threshold` [N s], recording the impulses tried.
struct ThresholdRobot {
  double threshold;
  std::vector<double> tried;
  bool operator()(double impulse) {
    tried.push_back(impulse);
    return impulse <= threshold;
  }
};

ImpulseBracket search(ThresholdRobot& robot) {
  return largest_recovered([&](double i) { return robot(i); }, kStart, kMax, kResolution);
}

TEST(LargestRecovered, TheBracketHoldsTheThresholdAndIsAtMostTheResolutionWide) {
  for (double threshold = 0.3; threshold < kMax; threshold += 1.37) {
    ThresholdRobot robot{threshold, {}};
    const ImpulseBracket b = search(robot);
    SCOPED_TRACE(threshold);
    EXPECT_FALSE(b.reached_max);
    EXPECT_LE(b.max_recovered, threshold);
    EXPECT_GT(b.min_lost, threshold);
    EXPECT_LE(b.min_lost - b.max_recovered, kResolution + 1e-12);
    // Every impulse tried at most once, none beyond the maximum, the start first.
    std::vector<double> sorted = robot.tried;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    EXPECT_LE(sorted.back(), kMax);
    EXPECT_EQ(robot.tried.front(), kStart);
    // The bracket's ends were tried (one is 0 when nothing was recovered down to the resolution).
    EXPECT_TRUE(b.max_recovered == 0.0 || std::count(sorted.begin(), sorted.end(), b.max_recovered) == 1);
    EXPECT_EQ(std::count(sorted.begin(), sorted.end(), b.min_lost), 1);
    // Bracketing by ×1.5 and bisection: a logarithmic number of trials.
    EXPECT_LE(robot.tried.size(), 12u);
  }
}

TEST(LargestRecovered, ARobotThatWithstandsTheLargestPushCostsTwoTrials) {
  ThresholdRobot robot{1e9, {}};
  const ImpulseBracket b = search(robot);
  EXPECT_TRUE(b.reached_max);
  EXPECT_EQ(b.max_recovered, kMax);
  EXPECT_EQ(b.min_lost, 0.0);
  EXPECT_EQ(robot.tried, (std::vector<double>{kStart, kMax}));
}

TEST(LargestRecovered, AThresholdBetweenTheStartAndTheMaximumClimbsTheLadderBelowTheFailedMaximum) {
  ThresholdRobot robot{40.0, {}};
  const ImpulseBracket b = search(robot);
  ASSERT_GE(robot.tried.size(), 5u);
  // 15 recovered, 80 lost, then 22.5 and 33.75 recovered and 50.625 lost: bisection inside [33.75, 50.625].
  EXPECT_EQ(robot.tried[0], kStart);
  EXPECT_EQ(robot.tried[1], kMax);
  EXPECT_DOUBLE_EQ(robot.tried[2], 22.5);
  EXPECT_DOUBLE_EQ(robot.tried[3], 33.75);
  EXPECT_DOUBLE_EQ(robot.tried[4], 50.625);
  EXPECT_GE(b.max_recovered, 33.75);
  EXPECT_LE(b.min_lost, 50.625);
}

TEST(LargestRecovered, AStartAtOrAboveTheMaximumTriesTheMaximumOnce) {
  ThresholdRobot robot{1e9, {}};
  const ImpulseBracket b = largest_recovered([&](double i) { return robot(i); }, 90.0, kMax, kResolution);
  EXPECT_TRUE(b.reached_max);
  EXPECT_EQ(b.max_recovered, kMax);
  EXPECT_EQ(robot.tried, (std::vector<double>{kMax}));
}

}  // namespace
