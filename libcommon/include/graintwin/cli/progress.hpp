#pragma once
// Progress on stderr: a bar redrawn at most 10 times a second on a terminal, a line every 10 %
// otherwise, nothing when disabled (-q). advance() is thread-safe and cheap enough for loops.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace graintwin::cli {

class Progress {
 public:
  /// `total` units of work; `enabled` false makes every call a no-op.
  Progress(std::string label, std::size_t total, bool enabled);
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
  std::atomic<std::size_t> value_{0};
  std::mutex draw_mutex_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point last_draw_{};
  bool finished_ = false;
};

}  // namespace graintwin::cli
