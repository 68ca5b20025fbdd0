// core/statistics: the one median and the one d50.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "graintwin/core/statistics.hpp"

using namespace graintwin;

TEST(Median, IsTheElementAtHalfTheCount) {
  EXPECT_EQ(median(std::vector<double>{}), 0.0);
  EXPECT_EQ(median(std::vector<double>{3.0}), 3.0);
  EXPECT_EQ(median(std::vector<double>{5.0, 1.0, 3.0}), 3.0);
  EXPECT_EQ(median(std::vector<double>{4.0, 1.0, 3.0, 2.0}), 3.0);  // the upper middle for an even count
  EXPECT_EQ(median(std::vector<float>{2.5f, 0.5f, 1.5f}), 1.5);
}

TEST(D50, InterpolatesTheSieveCurveAtFiftyPercent) {
  EXPECT_DOUBLE_EQ(d50_of_curve({1.0, 2.0, 3.0}, {20.0, 40.0, 100.0}), 2.0 + (50.0 - 40.0) / 60.0);
  EXPECT_DOUBLE_EQ(d50_of_curve({1.0, 2.0}, {60.0, 100.0}), 1.0);  // starts above 50 %
  EXPECT_DOUBLE_EQ(d50_of_curve({1.0, 2.0}, {50.0, 100.0}), 1.0);
  EXPECT_EQ(d50_of_curve({}, {}), 0.0);
}

TEST(D50, OfVolumesIsTheEquivalentDiameterAtHalfTheVolume) {
  const auto volume_of = [](double d) { return std::numbers::pi * d * d * d / 6.0; };
  // Two grains of equal volume: 50 % passes at the smaller one, whatever their order.
  EXPECT_NEAR(d50_of_volumes({volume_of(2.0), volume_of(2.0)}), 2.0, 1e-12);
  // One grain of diameter 1 (1/9 of the volume) and one of 2 (8/9): 50 % lies between them.
  const double p0 = 100.0 / 9.0;
  EXPECT_NEAR(d50_of_volumes({volume_of(2.0), volume_of(1.0)}), 1.0 + (50.0 - p0) / (100.0 - p0), 1e-12);
  EXPECT_EQ(d50_of_volumes({}), 0.0);
}
