#pragma once
// The report page: one self-contained HTML file (CSS inline, every PNG embedded as a base64 data
// URI, so it opens from disk with no server), the benchmark charts of docs/img with the stage
// each belongs to, the run's provenance in a collapsible section; and the call of the chart
// script that draws the panels' PNGs.
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "graintwin/report/error_budget.hpp"
#include "graintwin/report/panels.hpp"

namespace graintwin::report {

namespace fs = std::filesystem;

/// RFC 4648 base64 of `bytes` (with padding).
std::string base64(std::string_view bytes);
/// The bytes of a file (DataError naming it when it cannot be read).
std::string read_binary_file(const fs::path& path);
/// `text` with &, <, >, " and ' replaced by entities.
std::string html_escape(std::string_view text);

/// A benchmark chart: `<tool>_<measure>.png` (or `fdem_<measure>.png` for fdemrun's library parts)
/// drawn by one of bench/ (a CSV of the same stem beside it, or "accuracy" in the name), and the
/// pipeline stage its tool runs.
struct BenchChart {
  fs::path file;
  std::string tool;
  std::string stage;
};
/// The pipeline stage (Makefile.pipeline target) of a tool, or how the tool is used when it is no
/// stage; empty for a name that is no GrainTwin tool.
std::string stage_of_tool(const std::string& tool);
/// The benchmark charts in `dir`, by stage order then name; none when `dir` does not exist.
std::vector<BenchChart> find_bench_charts(const fs::path& dir);

struct PageContent {
  std::string title;
  std::vector<std::pair<std::string, std::string>> summary;  ///< (item, value) rows of the run summary
  std::vector<Panel> panels;
  /// The error budget's lines (error_budget); empty when the run has no validation.json, and then
  /// the section says so (kNoValidation).
  std::vector<BudgetLine> budget;
  std::map<std::string, std::string> images;  ///< chart file name -> PNG bytes
  std::vector<std::pair<BenchChart, std::string>> bench_charts;  ///< with their PNG bytes
  std::vector<std::pair<std::string, std::vector<std::string>>> provenance;  ///< file -> history lines
  std::string generated_by;  ///< the report run's own history line
};

/// The whole page. Every <img> is a data URI; a small script counts the images that decoded
/// (naturalWidth > 0) into the body's data-images-loaded attribute beside data-images-total, so a
/// headless browser can check the page. DataError when a panel's or a budget line's chart has no image.
std::string report_html(const PageContent& content);

/// Runs `python` `script` `charts_json` `out_dir` as a child process (no shell) and waits; the
/// script draws every chart of the JSON into out_dir. DataError with the script's last stderr
/// lines when it fails or cannot start; InterruptedError (the script killed) when the run is
/// interrupted meanwhile. The script dies with the calling thread, so call it from the main
/// thread: it cannot outlive a report killed by SIGKILL.
void run_chart_script(const fs::path& python, const fs::path& script, const fs::path& charts_json, const fs::path& out_dir);

}  // namespace graintwin::report
