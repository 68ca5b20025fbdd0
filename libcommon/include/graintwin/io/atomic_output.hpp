#pragma once
// The output contract (docs/conventions.md, "Outputs"). Every output, file or folder, is written
// under a temporary name beside its final path, and a run's outputs are put in place together at
// its commit point, so a failed, interrupted or killed run never leaves a file that Make would take
// as done, and a refused overwrite is decided by the rename itself, not by an earlier check:
// - a folder output never deletes anything that is not its own: --force replaces a folder only
//   when a GrainTwin tool wrote it (it holds the marker file kOutputFolderMarker);
// - an input is never an output, nor inside a folder output that would be replaced;
// - without --force an existing output is refused, atomically (two runs racing for one path:
//   exactly one wins, the other changes nothing);
// - temporaries of runs that died (their process is gone) are cleared by the next run that writes
//   beside them.
#include <filesystem>
#include <vector>

namespace graintwin::io {

/// The file every folder output holds, naming the tool that wrote it.
inline constexpr const char* kOutputFolderMarker = ".graintwin-output";

/// Declares a file or folder this process reads, so that no output can be it, or a folder
/// holding it (cli::Tool declares the positional inputs).
void declare_input(const std::filesystem::path& input);

class AtomicOutput {
 public:
  /// Refuses (UsageError) when `final_path` exists and `force` is false, when it is an input, when
  /// it is a folder no GrainTwin tool wrote, and when its folder does not exist; the checks happen
  /// here, before any heavy work, and again when the output is put in place. Clears the stale
  /// temporaries of dead runs beside it.
  AtomicOutput(std::filesystem::path final_path, bool force);
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  /// Removes the temporary file or folder unless it was put in place.
  ~AtomicOutput();

  /// Where to write: ".<name>.tmp-<pid>-<n>" in the same folder (a file, or a folder the writer makes).
  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& final_path() const { return final_; }

  /// Puts this output in place now, outside the run's commit point: for a file that a run
  /// replaces while it goes on (checkpoints), which a later interrupt does not take back.
  void replace_now();

 private:
  friend void commit_outputs(const std::vector<AtomicOutput*>& outputs);
  enum class Placed { no, new_path, exchanged };
  void place();
  void put_back() noexcept;
  void drop_replaced() noexcept;

  std::filesystem::path final_;
  std::filesystem::path temp_;
  bool force_ = false;
  Placed placed_ = Placed::no;
};

/// The run's commit point: from here on SIGINT and SIGTERM are ignored (InterruptedError when one
/// came before), then every output (null entries skipped) takes its final name. When one cannot
/// (it appeared meanwhile without --force, or cannot be renamed), those already in place are put
/// back as they were and the error is thrown: all or none. What the outputs replaced is deleted
/// last, once all are in place.
void commit_outputs(const std::vector<AtomicOutput*>& outputs);

/// Throws UsageError when `path` may not be an output: it exists and `force` is false, it is an
/// input or a folder holding one, it is a folder that no GrainTwin tool wrote, or its folder does
/// not exist (same sentences as AtomicOutput).
void check_output_allowed(const std::filesystem::path& path, bool force);

}  // namespace graintwin::io
