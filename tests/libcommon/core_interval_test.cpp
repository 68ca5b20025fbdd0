// Durations as people read them, and the pace of status lines about work of unknown length.
#include <gtest/gtest.h>

#include <limits>

#include "graintwin/core/interval.hpp"

using namespace graintwin;

TEST(FormatDuration, ReadsAsSecondsMinutesHoursAndDays) {
  EXPECT_EQ(format_duration(0.0), "0s");
  EXPECT_EQ(format_duration(7.4), "7s");
  EXPECT_EQ(format_duration(59.6), "1m00s");
  EXPECT_EQ(format_duration(72.0), "1m12s");
  EXPECT_EQ(format_duration(3599.4), "59m59s");
  EXPECT_EQ(format_duration(3599.6), "1h00m");
  EXPECT_EQ(format_duration(7529.0), "2h05m");  // 2 h 5 min 29 s: to the minute
  EXPECT_EQ(format_duration(7531.0), "2h06m");
  EXPECT_EQ(format_duration(86399.0), "1d00h");
  EXPECT_EQ(format_duration(3 * 86400.0 + 4 * 3600.0 + 1000.0), "3d04h");
  EXPECT_EQ(format_duration(-5.0), "0s");
  EXPECT_EQ(format_duration(std::numeric_limits<double>::quiet_NaN()), "0s");
}

TEST(Interval, DueOncePerPeriodCountedFromTheLastTimeItWasDue) {
  double now = 50.0;
  Interval every(30.0, [&] { return now; });
  now = 79.9;
  EXPECT_FALSE(every.due());
  now = 80.0;
  EXPECT_TRUE(every.due());
  EXPECT_FALSE(every.due());  // asked again at once
  now = 105.0;
  EXPECT_FALSE(every.due());  // 25 s after the last
  now = 200.0;
  EXPECT_TRUE(every.due());   // one line after a long gap, not one per period missed
  now = 229.0;
  EXPECT_FALSE(every.due());
  EXPECT_DOUBLE_EQ(every.elapsed(), 179.0);
}

TEST(Interval, TheSteadyClockRuns) {
  const double t0 = monotonic_seconds();
  EXPECT_GE(monotonic_seconds(), t0);
  EXPECT_FALSE(Interval(3600.0).due());
}
