#pragma once
// Progress on stderr: a bar redrawn at most 10 times a second on a terminal; otherwise a line every
// 10 %, and once a minute between them, so that a log of a long run shows it alive. Each carries the
// time elapsed and an estimate of the time left from the rate so far. Nothing when disabled (-q).
// advance() is thread-safe and cheap enough for loops.
#include <atomic>
#include <cstddef>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

namespace graintwin::cli {

/// Seconds left when `fraction` of the work took `elapsed` seconds, at the rate so far; none before
/// 2 % of the work and the first second, when that rate says little.
std::optional<double> estimate_time_left(double fraction, double elapsed);

/// What a progress display shows after its label: " 40%  1m12s elapsed, about 1m48s left"
/// (durations by format_duration; no estimate when estimate_time_left gives none or the work is
/// done).
std::string progress_status(double fraction, double elapsed);

/// A terminal's progress line: "label [#####     ]  40%  1m12s elapsed, about 1m48s left", the bar
/// narrowed or left out, and the line cut, to fit `columns`: a line that wraps cannot be redrawn.
std::string progress_bar_line(const std::string& label, double fraction, double elapsed, int columns);

class Progress {
 public:
  /// Seconds on a monotonic clock; tests pass their own.
  using Clock = std::function<double()>;

  /// `total` units of work; `enabled` false makes every call a no-op. The time elapsed counts from
  /// here.
  Progress(std::string label, std::size_t total, bool enabled, Clock clock = {});
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  ~Progress();

  void advance(std::size_t n = 1);
  /// Marks the work complete and ends the line (called by the destructor too).
  void done();

 private:
  void draw(std::size_t value);
  std::string label_;
  std::size_t total_;
  bool enabled_;
  bool tty_;
  int columns_;
  Clock clock_;
  double start_;
  std::atomic<std::size_t> value_{0};
  std::mutex draw_mutex_;
  // Read before taking the lock, so that most calls return without it.
  std::atomic<int> last_decile_{-1};
  std::atomic<double> last_draw_;
  bool finished_ = false;
};

}  // namespace graintwin::cli
