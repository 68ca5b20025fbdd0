#pragma once
// Wall-clock time for progress lines: the clock, and durations as people read them.
#include <string>

namespace graintwin {

/// Seconds on the steady (monotonic) clock, from an unspecified start.
double monotonic_seconds();

/// A duration as a person reads it, rounded to its smallest unit shown: "7s", "1m12s", "2h05m",
/// "3d04h" (seconds are dropped from an hour up, minutes from a day up).
std::string format_duration(double seconds);

}  // namespace graintwin
