#pragma once
// An output written under a temporary name beside its final path and renamed on commit(), so a
// killed or failing run never leaves a file that Make would take as done.
#include <filesystem>

namespace graintwin::io {

class AtomicOutput {
 public:
  /// Refuses (UsageError) when `final_path` exists and `force` is false; the check happens here,
  /// before any heavy work. Works for files and directories.
  AtomicOutput(std::filesystem::path final_path, bool force);
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  /// Removes the temporary file or directory unless committed.
  ~AtomicOutput();

  /// Where to write: ".<name>.tmp-<pid>" in the same directory.
  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }
  /// Replaces the final path by the temporary one (atomic rename for files).
  void commit();

 private:
  std::filesystem::path final_;
  std::filesystem::path temp_;
  bool force_ = false;
  bool committed_ = false;
};

/// Throws UsageError when `path` exists and `force` is false (same sentence as AtomicOutput).
void check_output_allowed(const std::filesystem::path& path, bool force);

}  // namespace graintwin::io
