// Progress output (non-terminal mode) and interruption handling of the tool wrapper.
#include <gtest/gtest.h>

#include <csignal>

#include "graintwin/cli/progress.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"

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

TEST(Interrupt, SignalBecomesInterruptedErrorAtTheNextSafePoint) {
  install_interrupt_handlers();
  EXPECT_NO_THROW(throw_if_interrupted());
  std::raise(SIGINT);
  EXPECT_TRUE(interrupted());
  try {
    throw_if_interrupted();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.exit_code(), ExitCode::interrupted);
  }
}
