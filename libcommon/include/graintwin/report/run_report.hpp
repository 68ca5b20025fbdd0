#pragma once
// report's stage (docs/report.md): a pipeline run's checked files read (run_data), the panels built
// (panels), their charts drawn by the chart script, the benchmark charts gathered, and the whole
// page assembled (page) with the run's summary and provenance.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"

namespace graintwin::report {

/// What a report is drawn with.
struct ReportOptions {
  std::string title;    ///< empty: report_title's default
  PanelOptions panels;
  fs::path python;      ///< the Python that runs the chart script
  fs::path script;      ///< the chart script (run_chart_script)
  fs::path bench_img;   ///< the folder of the benchmark charts (find_bench_charts)
};

/// `title`, or "Experiment against simulation: <the run folder's name>" when it is empty.
std::string report_title(const fs::path& run_dir, const std::string& title);

/// The rows of the page's run summary: the run folder, each scan's grains, contacts and void ratio,
/// then each later stage's file, or the stage that makes it when the run has none.
std::vector<std::pair<std::string, std::string>> run_summary(const fs::path& run_dir, const RunFiles& files,
                                                             const ExperimentData& experiment, const SimulationData& simulation);

/// The page and what it shows.
struct ReportPage {
  std::string html;
  std::size_t panels = 0;
  std::size_t charts = 0;          ///< panel sides with a chart
  std::size_t sides_without = 0;   ///< panel sides without data (the page says why)
  std::size_t bench_charts = 0;
  std::size_t budget_lines = 0;    ///< lines of the error budget (0 without validation.json)
  std::size_t budget_charts = 0;   ///< of them, lines with a chart
};

/// The report of the run in `run_dir`: its `files` (located and checked; `provenance` is what
/// check_run_files gave) read, the panels built, charts.json and every chart's PNG written into
/// `img_dir` (created) by the chart script (with the error budget's, from validation.json when the
/// run has one), the benchmark charts copied into `img_dir`/bench, and
/// the self-contained page. `generated_by` is the report run's own history line. What was read is
/// logged, and a missing set of benchmark charts warned about; `progress` (may be empty) gets the
/// fraction done. DataError from the readers and the chart script.
ReportPage build_report(const fs::path& run_dir, const RunFiles& files,
                        const std::vector<std::pair<std::string, std::vector<std::string>>>& provenance,
                        const ReportOptions& options, const fs::path& img_dir, const std::string& generated_by,
                        const std::function<void(double)>& progress = {});

}  // namespace graintwin::report
