// report: experiment against simulation on one self-contained HTML page (docs/report.md).
//   report runs/sand_small runs/sand_small/report.html --scan-strains sample_volumes/sand_small/series.json
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fstream>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/report/page.hpp"
#include "graintwin/report/panels.hpp"
#include "graintwin/report/run_data.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::report;

namespace {

std::string or_none(bool present, const std::string& what, const std::string& stage) {
  return present ? what : "none (the " + stage + " stage makes it)";
}

std::vector<std::pair<std::string, std::string>> run_summary(const fs::path& run_dir, const RunFiles& f, const ExperimentData& e,
                                                             const SimulationData& s) {
  std::vector<std::pair<std::string, std::string>> rows{{"run directory", run_dir.string()}};
  for (const ScanData& sc : e.scans)
    rows.emplace_back(sc.name, fmt::format("{} grains, {} contacts, void ratio {:.4f}", sc.grains, sc.contacts, sc.void_ratio));
  rows.emplace_back("tracks", or_none(!f.tracks.empty(), fmt::format("{} tracks over {} scans", e.tracks, e.scans.size()), "track"));
  rows.emplace_back("micro-mechanics of the scans",
                    or_none(e.micro.has_value(), fmt::format("{} increments", e.micro ? e.micro->increments.size() : 0), "micro"));
  rows.emplace_back("FDEM model", or_none(!f.model.empty(), f.model.string(), "mesh"));
  rows.emplace_back("simulation", or_none(s.present, fmt::format("{} grains, {} frames", s.grains, s.frames), "simulate"));
  rows.emplace_back("micro-mechanics of the simulation",
                    s.micro ? fmt::format("{} increments", s.micro->increments.size()) : "none (tracks2micro on simulation.h5 makes it)");
  rows.emplace_back("force statistics", or_none(s.forces.has_value(),
                                                fmt::format("{} frames, {} windows", s.forces ? s.forces->frames.size() : 0,
                                                            s.forces ? s.forces->windows.size() : 0),
                                                "forces"));
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "report",
      "Experiment against simulation on one self-contained HTML page (PNG charts embedded as data URIs, so it opens from "
      "disk; the PNGs and the numbers behind them, charts.json, are also kept in REPORT_img/ beside it). Reads what "
      "Makefile.pipeline wrote into RUNDIR: every scan_*/labels.h5 with its contacts.h5 and shapes.h5, tracks.h5, micro.h5, "
      "model.h5, and the simulation side simulation.h5 (fdemrun), forces.h5 (fdem2forces) and simulation_micro.h5 "
      "(tracks2micro on the simulation frames); options name any of them explicitly. Panels, experiment left and "
      "simulation right: stress ratio and volumetric strain against axial strain (the simulation's triaxial series, the "
      "scans' strains as points), PSD, coordination numbers, roses of contact normals, branch vectors and mean normal "
      "force, g(r), incremental displacement distributions, PDFs of D2min and eps_q, cluster size distribution with its "
      "power-law fit, R_g against s with d_f, force PDF with its strong and weak fits, volatility of grain stress against "
      "D2min with Pearson's r; then each stage's accuracy-against-time charts from --bench-img, and the files' "
      "provenance. Where a side has no data (CT measures no forces; a stage has not run) the panel says so in one "
      "sentence. Charts are drawn by --chart-script with Debian's python3-matplotlib.");
  fs::path run_dir, output, python = "/usr/bin/python3", script, bench_img;
  std::string title;
  RunFiles given;
  PanelOptions po;
  auto& app = tool.cli();
  tool.add_input("rundir", run_dir, "Run directory of Makefile.pipeline (runs/<series>)", false);
  tool.add_output("report", output, "HTML page to write (.html); its PNGs go to the folder <stem>_img beside it");
  app.add_option("--labels", given.labels, "The scans' labels files in order (kind=labels), in place of RUNDIR/scan_*/labels.h5");
  app.add_option("--contacts", given.contacts, "The scans' contacts files in order (kind=contacts), one per scan");
  app.add_option("--shapes", given.shapes, "The scans' shapes files in order (kind=shapes), one per scan");
  app.add_option("--tracks", given.tracks, "Tracks file (kind=tracks) in place of RUNDIR/tracks.h5");
  app.add_option("--micro", given.micro, "Micro-mechanics of the scans (kind=micro) in place of RUNDIR/micro.h5");
  app.add_option("--model", given.model, "FDEM model (kind=fdem_model) in place of RUNDIR/model.h5");
  app.add_option("--simulation", given.simulation, "Simulation results (kind=fdem_results) in place of RUNDIR/simulation.h5");
  app.add_option("--forces", given.forces, "Force statistics (kind=forces) in place of RUNDIR/forces.h5");
  app.add_option("--simulation-micro", given.simulation_micro,
                 "Micro-mechanics of the simulation frames (kind=micro) in place of RUNDIR/simulation_micro.h5");
  app.add_option("--scan-strains", given.scan_strains,
                 "JSON with the scans' applied axial strains, {\"scans\": [{\"axial_strain\": ...}, ...]} (ctsynth's series.json); "
                 "without it the scans' axial strains are measured from the tracks only");
  app.add_option("--bench-img", bench_img, "Folder of the benchmark charts (<tool>_<measure>.png); default: docs/img of the source tree this build came from");
  app.add_option("--max-series", po.max_series, "Scans, increments or frames drawn per chart (evenly spread, first and last always)")
      ->check(cli::whole_number_in(1, 20))->capture_default_str();
  app.add_option("--title", title, "Page title (default: Experiment against simulation: <RUNDIR name>)");
  app.add_option("--python", python, "Python with matplotlib that runs the chart script")->capture_default_str();
  app.add_option("--chart-script", script, "The chart script; default: pipelines/plots/report_charts.py of the source tree this build came from");
  tool.set_examples({"report runs/sand_small runs/sand_small/report.html --scan-strains sample_volumes/sand_small/series.json",
                     "report runs/sand_small /tmp/report.html --simulation other/simulation.h5 --forces other/forces.h5 --bench-img docs/img"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any table.
    if (output.extension() != ".html") throw UsageError("the report " + output.string() + " must end in .html");
    if (script.empty()) script = fs::path(GRAINTWIN_SOURCE_DIR) / "pipelines/plots/report_charts.py";
    std::error_code ec;
    if (!fs::exists(python, ec))
      throw UsageError("--python " + python.string() + " does not exist; install Debian's python3 and python3-matplotlib (scripts/deps.sh)");
    require_file(python, "--python", "name the python3 program itself");
    require_file(script, "--chart-script");
    if (!bench_img.empty()) require_folder(bench_img, "--bench-img", "pass the repository's docs/img");
    if (bench_img.empty()) bench_img = fs::path(GRAINTWIN_SOURCE_DIR) / "docs/img";
    const fs::path img_dir = output.parent_path() / (output.stem().string() + "_img");
    io::AtomicOutput html_out(output, ctx.force());
    io::AtomicOutput img_out(img_dir, ctx.force());
    const RunFiles files = locate_run_files(run_dir, given);
    const auto provenance = check_run_files(files);
    if (title.empty()) {
      fs::path name = fs::absolute(run_dir).lexically_normal();
      if (name.filename().empty()) name = name.parent_path();  // "runs/sand_small/"
      title = "Experiment against simulation: " + name.filename().string();
    }

    auto progress = ctx.progress("reading and drawing", 4);
    const ExperimentData experiment = read_experiment(files);
    progress->advance();
    const auto& rose = experiment.scans[0].rose_normal.theta_edges;
    const int theta_bins = rose.size() > 1 ? int(rose.size() - 1) : 9;
    const SimulationData simulation = read_simulation(files, po.max_series, theta_bins);
    progress->advance();
    spdlog::info("{} scans ({}tracks, {}micro-mechanics); simulation: {}, its micro-mechanics: {}, forces: {}", experiment.scans.size(),
                 files.tracks.empty() ? "no " : "", experiment.micro ? "" : "no ", simulation.present ? "yes" : "no",
                 simulation.micro ? "yes" : "no", simulation.forces ? "yes" : "no");

    PageContent page;
    page.title = title;
    page.panels = build_panels(experiment, simulation, po);
    fs::create_directories(img_out.temp_path());
    nlohmann::json spec = {{"charts", nlohmann::json::array()}};
    for (const Chart* c : panel_charts(page.panels)) spec["charts"].push_back(to_json(*c));
    const fs::path spec_path = img_out.temp_path() / "charts.json";
    std::ofstream(spec_path) << spec.dump(1) << "\n";
    run_chart_script(python, script, spec_path, img_out.temp_path());
    for (const Chart* c : panel_charts(page.panels)) page.images[c->file] = read_binary_file(img_out.temp_path() / c->file);
    progress->advance();

    const auto bench = find_bench_charts(bench_img);
    if (bench.empty()) spdlog::warn("no benchmark charts in {}; the page says so", bench_img.string());
    if (!bench.empty()) fs::create_directories(img_out.temp_path() / "bench");
    for (const BenchChart& b : bench) {
      fs::copy_file(b.file, img_out.temp_path() / "bench" / b.file.filename(), fs::copy_options::overwrite_existing);
      page.bench_charts.emplace_back(b, read_binary_file(b.file));
    }
    page.summary = run_summary(run_dir, files, experiment, simulation);
    page.provenance = provenance;
    page.generated_by = ctx.history_line();
    std::ofstream(html_out.temp_path(), std::ios::binary) << report_html(page);
    progress->advance();
    std::size_t shown = 0, absent = 0;
    for (const Panel& p : page.panels)
      for (const Side* side : {&p.experiment, &p.simulation}) (side->chart ? shown : absent) += 1;
    spdlog::info("{} panels: {} charts drawn, {} sides without data (the page says why); {} benchmark charts", page.panels.size(), shown,
                 absent, bench.size());
    io::commit_outputs({&html_out, &img_out});
  });
}
