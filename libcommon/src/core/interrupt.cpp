#include "graintwin/core/interrupt.hpp"

#include <csignal>

#include "graintwin/core/error.hpp"

namespace graintwin {

namespace {
volatile std::sig_atomic_t g_interrupted = 0;
volatile std::sig_atomic_t g_committing = 0;

extern "C" void on_signal(int sig) {
  g_interrupted = 1;
  std::signal(sig, SIG_DFL);  // a second signal ends the process at once
}

void set_handlers(void (*handler)(int)) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}
}  // namespace

void install_interrupt_handlers() {
  g_interrupted = 0;
  g_committing = 0;
  set_handlers(on_signal);
}

bool interrupted() { return g_interrupted != 0 && g_committing == 0; }

void throw_if_interrupted() {
  if (interrupted()) throw InterruptedError();
}

void pass_commit_point() {
  if (g_committing != 0) return;
  throw_if_interrupted();
  set_handlers(SIG_IGN);
  // A signal that arrived between the check and SIG_IGN still counts: nothing is in place yet.
  if (g_interrupted != 0) {
    set_handlers(on_signal);
    throw InterruptedError();
  }
  g_committing = 1;
}

bool commit_point_passed() { return g_committing != 0; }

}  // namespace graintwin
