#include "graintwin/cli/progress.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/interval.hpp"

#include <fmt/format.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace graintwin::cli {

namespace {

/// Below this share of the work or this many seconds, the rate so far is mostly start-up cost.
constexpr double kEstimateFromFraction = 0.02;
constexpr double kEstimateFromSeconds = 1.0;
/// Seconds between lines in a log when the work goes slower than 10 % in this time.
constexpr double kLogLineInterval = 60.0;
/// Seconds between redraws of the bar on a terminal.
constexpr double kRedrawInterval = 0.1;
/// The widest bar, and the narrowest worth drawing.
constexpr int kBarWidth = 30, kNarrowestBar = 10;
/// Columns kept for the status beside the bar, so that the bar does not narrow when the estimate
/// appears: " 99%  59m59s elapsed, about 59m59s left" and one spare.
constexpr std::size_t kStatusColumns = 40;

int terminal_columns() {
  winsize w{};
  return ::ioctl(STDERR_FILENO, TIOCGWINSZ, &w) == 0 && w.ws_col > 0 ? w.ws_col : 80;
}

}  // namespace

std::optional<double> estimate_time_left(double fraction, double elapsed) {
  if (!(fraction >= kEstimateFromFraction) || !(elapsed >= kEstimateFromSeconds)) return std::nullopt;
  return elapsed * (1.0 - std::min(fraction, 1.0)) / fraction;
}

std::string progress_status(double fraction, double elapsed) {
  std::string s = fmt::format("{:3d}%  {} elapsed", static_cast<int>(fraction * 100.0), format_duration(elapsed));
  if (const auto left = estimate_time_left(fraction, elapsed); left && fraction < 1.0)
    s += ", about " + format_duration(*left) + " left";
  return s;
}

std::string progress_bar_line(const std::string& label, double fraction, double elapsed, int columns) {
  const std::string status = progress_status(fraction, elapsed);
  // The bar's brackets and spaces take 4 columns; the last column stays free.
  const int room = columns - 1 - static_cast<int>(label.size() + std::max(status.size(), kStatusColumns)) - 4;
  const int width = std::min(room, kBarWidth);
  std::string line = label;
  if (width >= kNarrowestBar) {
    const int filled = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * width);
    line += " [" + std::string(filled, '#') + std::string(width - filled, ' ') + "]";
  }
  line += " " + status;
  if (columns > 1 && line.size() >= static_cast<std::size_t>(columns)) line.resize(columns - 1);
  return line;
}

Progress::Progress(std::string label, std::size_t total, bool enabled, Clock clock)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      tty_(::isatty(STDERR_FILENO) != 0),
      columns_(tty_ ? terminal_columns() : 80),
      clock_(clock ? std::move(clock) : Clock(monotonic_seconds)),
      start_(clock_()),
      last_draw_(start_) {}

Progress::~Progress() { done(); }

void Progress::advance(std::size_t n) {
  if (!enabled_) return;
  const std::size_t v = value_.fetch_add(n, std::memory_order_relaxed) + n;
  draw(v);
}

void Progress::draw(std::size_t value) {
  const double frac = total_ ? std::min(1.0, static_cast<double>(value) / static_cast<double>(total_)) : 1.0;
  const double now = clock_();
  if (tty_) {
    if (now - last_draw_.load(std::memory_order_relaxed) < kRedrawInterval && frac < 1.0) return;
    std::lock_guard<std::mutex> lock(draw_mutex_);
    if (finished_) return;
    last_draw_.store(now, std::memory_order_relaxed);
    // \033[K clears what a longer line drawn before left.
    std::fprintf(stderr, "\r%s\033[K", progress_bar_line(label_, frac, now - start_, columns_).c_str());
    std::fflush(stderr);
  } else {
    const int decile = static_cast<int>(frac * 10.0);
    const auto due = [&] {
      return decile > last_decile_.load(std::memory_order_relaxed) ||
             now - last_draw_.load(std::memory_order_relaxed) >= kLogLineInterval;
    };
    if (!due()) return;
    std::lock_guard<std::mutex> lock(draw_mutex_);
    if (!due() || finished_) return;
    last_decile_.store(std::max(decile, last_decile_.load(std::memory_order_relaxed)), std::memory_order_relaxed);
    last_draw_.store(now, std::memory_order_relaxed);
    std::fprintf(stderr, "%s: %s\n", label_.c_str(), progress_status(frac, now - start_).c_str());
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
