#pragma once
// The wrapper every tool's main() goes through: CLI11 with the standard options, logging to stderr
// prefixed with the tool name, input/output checks before any heavy work, provenance, and the
// mapping of errors to exit codes (0 ok, 1 data error, 2 usage error, 130 interrupted).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "graintwin/cli/progress.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::cli {

/// The most worker threads -j/--threads takes: far beyond any core count this toolkit is used on,
/// low enough that per-thread buffers cannot exhaust memory.
inline constexpr int kMaxThreads = 1024;

/// What a tool's body sees: the standard options' values, progress, and provenance.
class RunContext {
 public:
  const std::string& tool_name() const { return name_; }
  bool force() const { return force_; }
  bool quiet() const { return quiet_; }
  /// Worker threads in use (OpenMP is set to this).
  int threads() const { return threads_; }
  /// A progress display for `total` units, silent with -q.
  std::unique_ptr<Progress> progress(const std::string& label, std::size_t total) const;
  /// The same display driven by a fraction done in [0, 1], for library functions that report
  /// progress that way; the display ends when the last copy of the callback is destroyed.
  std::function<void(double)> progress_callback(const std::string& label) const;

  /// Merges an input file's /provenance/history into this run's history, and declares the file an
  /// input (io::declare_input), so that no output of the run can replace it.
  void add_input_history(const io::H5File& input);
  /// Input histories followed by this run's own line.
  std::vector<std::string> history() const;
  /// This run's line: quoted command line, then "(graintwin <version>, git <rev>, <UTC>)".
  const std::string& history_line() const { return line_; }

 private:
  friend class Tool;
  std::string name_;
  bool force_ = false;
  bool quiet_ = false;
  int threads_ = 1;
  std::vector<std::string> inputs_history_;
  std::string line_;
};

class Tool {
 public:
  Tool(std::string name, std::string description);
  CLI::App& cli() { return app_; }

  /// A positional input that must exist before the body runs (exit 2 naming it otherwise). With
  /// `must_exist` false the tool checks it itself (globs, optional inputs).
  CLI::Option* add_input(const std::string& name, std::filesystem::path& target,
                         const std::string& description, bool must_exist = true);
  /// An optional positional input between the required inputs and the outputs, as in
  /// `labels2contacts LABELS [VOLUME] CONTACTS`: with one argument fewer it stays empty and the
  /// arguments move on to the outputs. At most one per tool, declared before the outputs.
  CLI::Option* add_optional_input(const std::string& name, std::filesystem::path& target,
                                  const std::string& description);
  /// A positional output; an existing one is refused unless --force, before the body runs.
  CLI::Option* add_output(const std::string& name, std::filesystem::path& target,
                          const std::string& description);
  /// Makes a positional argument the tool's configuration file (e.g. ctsynth's SCENE.toml) in
  /// place of --config: its keys are option names, and options given on the command line win.
  void use_positional_config(const std::string& name, std::filesystem::path& target,
                             const std::string& description);
  /// The parsed options as a configuration file that gives this run again (CLI11's TOML of every
  /// option and its value), less the options left empty: "" means "the default", which leaving the
  /// key out gives too, and a length option would refuse "" when the file is read back.
  std::string effective_config() const;
  /// Processes of one run that share this machine's cores (the MPI ranks on it): -j 0 then gives
  /// each its share, at least one thread. 1 by default.
  void share_cores_with(int processes);
  /// Example lines shown under "Examples:" at the end of --help, plus the docs pointer.
  void set_examples(const std::vector<std::string>& examples);

  /// Parses, sets up logging and threads, checks inputs and outputs, runs `body`, and returns the
  /// exit code. Never throws.
  int run(int argc, char** argv, const std::function<void(RunContext&)>& body);

 private:
  /// What is wrong with the run's configuration file (TOML syntax, a key that names no option,
  /// with the closest option name), as one sentence naming the file; empty when nothing is.
  std::string config_file_problem(int argc, char** argv) const;

  std::string name_;
  CLI::App app_;
  int verbosity_ = 0;
  bool quiet_ = false;
  bool force_ = false;
  int threads_ = 0;
  int sharing_processes_ = 1;
  std::vector<std::filesystem::path*> inputs_;
  std::vector<std::filesystem::path*> unchecked_inputs_;  // add_input(..., must_exist = false)
  std::vector<std::filesystem::path*> outputs_;
  std::vector<std::string> output_names_;
  std::filesystem::path* optional_input_ = nullptr;
  CLI::Option* config_positional_ = nullptr;
  std::filesystem::path* config_target_ = nullptr;
};

}  // namespace graintwin::cli
