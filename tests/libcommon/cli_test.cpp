// Progress output of the tool wrapper (non-terminal mode).
#include <gtest/gtest.h>

#include <algorithm>

#include "graintwin/cli/progress.hpp"

using namespace graintwin;

TEST(Progress, PrintsOneLinePerTenPercentWhenNotATerminal) {
  testing::internal::CaptureStderr();  // stderr is a pipe here, not a terminal
  {
    cli::Progress p("tool: work", 200, true);
    for (int i = 0; i < 200; ++i) p.advance();
  }
  const std::string out = testing::internal::GetCapturedStderr();
  EXPECT_NE(out.find("tool: work: 10%\n"), std::string::npos) << out;
  EXPECT_NE(out.find("tool: work: 100%\n"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 11) << out;  // 0 %, 10 %, ..., 100 %
}

TEST(Progress, SilentWhenDisabled) {
  testing::internal::CaptureStderr();
  {
    cli::Progress p("quiet", 10, false);
    p.advance(10);
  }
  EXPECT_TRUE(testing::internal::GetCapturedStderr().empty());
}
