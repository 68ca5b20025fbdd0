#include "graintwin/cli/progress.hpp"
#include "graintwin/core/interrupt.hpp"

#include <unistd.h>

#include <cstdio>


namespace graintwin::cli {

Progress::Progress(std::string label, std::size_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), tty_(::isatty(STDERR_FILENO) != 0) {}

Progress::~Progress() { done(); }

void Progress::advance(std::size_t n) {
  if (!enabled_) return;
  const std::size_t v = value_.fetch_add(n, std::memory_order_relaxed) + n;
  draw(v);
}

void Progress::draw(std::size_t value) {
  const double frac = total_ ? std::min(1.0, static_cast<double>(value) / static_cast<double>(total_)) : 1.0;
  if (tty_) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_draw_ < std::chrono::milliseconds(100) && frac < 1.0) return;  // racy read is harmless
    std::lock_guard<std::mutex> lock(draw_mutex_);
    if (finished_) return;
    last_draw_ = now;
    constexpr int width = 30;
    const int filled = static_cast<int>(frac * width);
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%%", label_.c_str(), filled, "##############################",
                 width - filled, "", static_cast<int>(frac * 100.0));
    std::fflush(stderr);
  } else {
    const int decile = static_cast<int>(frac * 10.0);
    if (decile <= last_decile_) return;
    std::lock_guard<std::mutex> lock(draw_mutex_);
    if (decile <= last_decile_ || finished_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%s: %d%%\n", label_.c_str(), decile * 10);
  }
}

void Progress::done() {
  if (!enabled_) return;
  {
    std::lock_guard<std::mutex> lock(draw_mutex_);
    if (finished_) return;
  }
  if (!interrupted()) draw(total_);
  std::lock_guard<std::mutex> lock(draw_mutex_);
  finished_ = true;
  if (tty_) std::fputc('\n', stderr);
}

}  // namespace graintwin::cli
