#pragma once
// Benchmark harness shared by every bench/ program: time our code and a named reference side by
// side in one run, print a table with ratios, and rewrite this benchmark's section of
// docs/benchmarks.md (between <!-- bench:NAME --> and <!-- /bench:NAME --> markers).
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace graintwin::bench {

/// One timed run of one implementation on one case.
struct Row {
  std::string case_name;       ///< e.g. "256^3 uint16"
  std::string implementation;  ///< e.g. "graintwin" or "h5py (Debian python3-h5py)"
  double seconds = 0.0;        ///< best wall time over the repetitions
  double peak_bytes = 0.0;     ///< peak resident memory of the run where measured, else 0
  std::string note;            ///< free text (accuracy figure, settings)
};

/// Best wall time of `reps` calls of f.
double best_seconds(int reps, const std::function<void()>& f);

/// Runs argv as a child process; returns its wall time and peak RSS (bytes). Throws on failure.
Row run_child(const std::string& case_name, const std::string& implementation, const std::vector<std::string>& argv,
              int reps = 1);

/// Peak resident set size of this process so far (bytes).
double self_peak_rss_bytes();

class Report {
 public:
  Report(std::string name, std::string title, std::string method);
  void add(Row r) { rows_.push_back(std::move(r)); }
  /// Markdown table; `reference` names the implementation ratios are taken against (time and memory).
  std::string markdown(const std::string& reference) const;
  /// Prints the table to stdout and rewrites the section in docs/benchmarks.md (created if absent).
  void publish(const std::string& reference, const std::filesystem::path& benchmarks_md) const;

 private:
  std::string name_, title_, method_;
  std::vector<Row> rows_;
};

/// The folder of the running benchmark executable (build/bin), where the tools are too.
std::filesystem::path bin_dir();

/// Machine line for the report: CPU model, cores, date.
std::string machine_summary();

/// The options the accuracy benches share, `[--quick] [--work DIR]`, read from argv[1..]. `work`
/// keeps its default unless given. Returns false on anything else (the caller prints its usage).
bool parse_quick_work(int argc, char** argv, bool& quick, std::filesystem::path& work);

/// Draws an accuracy-against-cost chart from a CSV (columns series,label,x,y) with bench/plot_xy.py
/// under Debian's python3. Returns false (and says so on stderr) when the chart was not drawn.
bool plot_xy(const std::filesystem::path& csv, const std::filesystem::path& png, const std::string& title,
             const std::string& x_label, const std::string& y_label);

}  // namespace graintwin::bench
