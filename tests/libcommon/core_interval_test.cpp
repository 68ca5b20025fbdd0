// Durations as people read them.
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
