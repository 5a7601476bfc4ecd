#include <gtest/gtest.h>

#include "hpr/common/stats.hpp"

TEST(RollingStats, PercentilesOverTheWindowOnly) {
  hpr::RollingStats s(100);
  for (int i = 0; i < 1000; ++i) s.add(i < 900 ? 1e6 : static_cast<double>(i - 900 + 1));  // last 100: 1..100
  EXPECT_EQ(s.size(), 100U);
  EXPECT_EQ(s.total(), 1000U);
  EXPECT_DOUBLE_EQ(s.median(), 50.0);
  EXPECT_DOUBLE_EQ(s.percentile(0.99), 99.0);
  EXPECT_DOUBLE_EQ(s.max(), 100.0);
  EXPECT_DOUBLE_EQ(s.mean(), 50.5);
}

TEST(RollingStats, EmptyIsZero) {
  hpr::RollingStats s(10);
  EXPECT_EQ(s.median(), 0.0);
  EXPECT_EQ(s.max(), 0.0);
}
