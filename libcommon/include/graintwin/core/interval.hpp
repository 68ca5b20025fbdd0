#pragma once
// Wall-clock time for progress and status lines: durations as people read them, and the pace of
// status lines about work whose length is not known in advance (a consolidation that runs until
// it settles): a line every so many seconds, however fast the steps go.
#include <functional>
#include <string>

namespace graintwin {

/// Seconds on the steady (monotonic) clock, from an unspecified start.
double monotonic_seconds();

/// A duration as a person reads it, rounded to its smallest unit shown: "7s", "1m12s", "2h05m",
/// "3d04h" (seconds are dropped from an hour up, minutes from a day up).
std::string format_duration(double seconds);

/// Seconds between the status lines of work whose length is not known in advance: often enough to
/// show it alive, seldom enough that a day-long run's log stays readable.
inline constexpr double kStatusLineSeconds = 30;

/// Says "due" once every period, however often it is asked. Not thread-safe.
class Interval {
 public:
  /// Seconds on a monotonic clock; tests pass their own.
  using Clock = std::function<double()>;
  explicit Interval(double period, Clock clock = {});
  /// True when a period has passed since it last said so (or since it was made).
  bool due();
  /// Seconds since it was made.
  double elapsed() const { return clock_() - start_; }

 private:
  double period_;
  Clock clock_;
  double start_, last_;
};

}  // namespace graintwin
