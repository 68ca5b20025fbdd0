// SIGINT and SIGTERM as a flag that the next safe point turns into InterruptedError (core/interrupt).
#include <gtest/gtest.h>

#include <csignal>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"

using namespace graintwin;

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
