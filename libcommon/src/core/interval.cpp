#include "graintwin/core/interval.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace graintwin {

double monotonic_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string format_duration(double seconds) {
  seconds = seconds > 0 ? std::min(seconds, 1e12) : 0.0;  // NaN too: a display must not break on it
  const long long s = std::llround(seconds);
  if (s < 60) return fmt::format("{}s", s);
  if (s < 3600) return fmt::format("{}m{:02}s", s / 60, s % 60);
  const long long minutes = std::llround(seconds / 60);
  if (minutes < 24 * 60) return fmt::format("{}h{:02}m", minutes / 60, minutes % 60);
  const long long hours = std::llround(seconds / 3600);
  return fmt::format("{}d{:02}h", hours / 24, hours % 24);
}

Interval::Interval(double period, Clock clock)
    : period_(period), clock_(clock ? std::move(clock) : Clock(monotonic_seconds)), start_(clock_()), last_(start_) {}

bool Interval::due() {
  const double now = clock_();
  if (now - last_ < period_) return false;
  last_ = now;
  return true;
}

}  // namespace graintwin
