// Progress output of the tool wrapper (non-terminal mode) and the text of its lines.
#include <gtest/gtest.h>

#include <algorithm>

#include "graintwin/cli/progress.hpp"

using namespace graintwin;

TEST(Progress, PrintsOneLinePerTenPercentWhenNotATerminal) {
  testing::internal::CaptureStderr();  // stderr is a pipe here, not a terminal
  {
    cli::Progress p("tool: work", 200, true, [] { return 0.0; });
    for (int i = 0; i < 200; ++i) p.advance();
  }
  const std::string out = testing::internal::GetCapturedStderr();
  EXPECT_NE(out.find("tool: work:  10%  0s elapsed\n"), std::string::npos) << out;
  EXPECT_NE(out.find("tool: work: 100%  0s elapsed\n"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 11) << out;  // 0 %, 10 %, ..., 100 %
}

TEST(Progress, LinesCarryTheTimeElapsedAndLeftAndComeOnceAMinuteBetweenTenPercents) {
  double now = 100.0;  // the clock's zero is not the display's
  testing::internal::CaptureStderr();
  {
    cli::Progress p("fdemrun: shearing steps", 1000, true, [&] { return now; });
    now = 101.0;
    p.advance();  // the first line, too early for an estimate
    now = 161.5;
    p.advance();  // a minute since the last line, within the same 10 %
    now = 190.0;
    p.advance();  // half a minute: nothing
    now = 300.0;
    p.advance(298);  // 30 %
    now = 400.0;
    p.done();
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "fdemrun: shearing steps:   0%  1s elapsed\n"
            "fdemrun: shearing steps:   0%  1m02s elapsed\n"
            "fdemrun: shearing steps:  30%  3m20s elapsed, about 7m44s left\n"
            "fdemrun: shearing steps: 100%  5m00s elapsed\n");
}

TEST(Progress, SilentWhenDisabled) {
  testing::internal::CaptureStderr();
  {
    cli::Progress p("quiet", 10, false);
    p.advance(10);
  }
  EXPECT_TRUE(testing::internal::GetCapturedStderr().empty());
}

TEST(ProgressText, TimeLeftFromTheRateSoFarOnceThereIsOne) {
  EXPECT_FALSE(cli::estimate_time_left(0.019, 100.0));  // under 2 % of the work
  EXPECT_FALSE(cli::estimate_time_left(0.5, 0.9));      // under a second
  ASSERT_TRUE(cli::estimate_time_left(0.02, 1.0));
  EXPECT_DOUBLE_EQ(*cli::estimate_time_left(0.02, 1.0), 49.0);
  EXPECT_DOUBLE_EQ(*cli::estimate_time_left(0.4, 72.0), 108.0);
  EXPECT_DOUBLE_EQ(*cli::estimate_time_left(1.0, 10.0), 0.0);
}

TEST(ProgressText, StatusShowsPercentElapsedAndLeft) {
  EXPECT_EQ(cli::progress_status(0.4, 72.0), " 40%  1m12s elapsed, about 1m48s left");
  EXPECT_EQ(cli::progress_status(0.01, 5.0), "  1%  5s elapsed");  // too early for an estimate
  EXPECT_EQ(cli::progress_status(0.999, 4000.0), " 99%  1h07m elapsed, about 4s left");
  EXPECT_EQ(cli::progress_status(1.0, 180.0), "100%  3m00s elapsed");
}

TEST(ProgressText, TheTerminalLineFitsItsColumns) {
  EXPECT_EQ(cli::progress_bar_line("job", 0.4, 72.0, 80),
            "job [############                  ]  40%  1m12s elapsed, about 1m48s left");
  EXPECT_EQ(cli::progress_bar_line("job", 0.4, 72.0, 60),
            "job [####        ]  40%  1m12s elapsed, about 1m48s left");  // a narrower bar
  // Before there is an estimate the bar is as wide: it does not jump when the estimate appears.
  EXPECT_EQ(cli::progress_bar_line("job", 0.4, 0.4, 60), "job [####        ]  40%  0s elapsed");
  EXPECT_EQ(cli::progress_bar_line("job", 0.4, 72.0, 40), "job  40%  1m12s elapsed, about 1m48s le");  // no bar, cut
}
