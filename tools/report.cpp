// report: experiment against simulation on one self-contained HTML page (docs/report.md).
//   report runs/sand_small runs/sand_small/report.html --scan-strains sample_volumes/sand_small/series.json
#include <spdlog/spdlog.h>

#include <fstream>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/report/paraview_state.hpp"
#include "graintwin/report/run_report.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::report;

int main(int argc, char** argv) {
  cli::Tool tool(
      "report",
      "Experiment against simulation on one self-contained HTML page (PNG charts embedded as data URIs, so it opens from "
      "disk; the PNGs and the numbers behind them, charts.json, are also kept in REPORT_img/ beside it). Reads what "
      "Makefile.pipeline wrote into RUNDIR: every scan_*/labels.h5 with its contacts.h5 and shapes.h5, tracks.h5, micro.h5, "
      "model.h5, and the simulation side simulation.h5 (fdemrun), forces.h5 (fdem2forces) and simulation_micro.h5 "
      "(tracks2micro on the simulation frames); options name any of them explicitly. Panels, experiment left and "
      "simulation right: sections of each scan with its labels (over the scan's grey values with --volumes) beside the same "
      "planes through the FDEM twin's grains; D2min and eps_q of every grain painted on the vertical section through the axis "
      "for each increment, on one colour scale; the high-D2min clusters in 3D for each increment, scans beside the twin; the "
      "twin's strong force-chain network in 3D at each frame; the grains' own surfaces in 3D (the reference scan beside the twin at its "
      "last frame with its membrane, a front quarter cut away) and eps_q of every grain in 3D for each increment (3D pictures by VTK on a private Xvfb); stress ratio and volumetric strain against axial strain (the simulation's triaxial series, the "
      "scans' strains as points), PSD, coordination numbers, roses of contact normals, branch vectors and mean normal "
      "force, g(r), incremental displacement distributions, PDFs of D2min and eps_q, cluster size distribution with its "
      "power-law fit, R_g against s with d_f, force PDF with its strong and weak fits, volatility of grain stress against "
      "D2min with Pearson's r; then the error budget against the series' ground truth (validation.json of the validate stage; "
      "a series without truth says so), each stage's accuracy-against-time charts from --bench-img, and the files' "
      "provenance. Where a side has no data (CT measures no forces; a stage has not run) the panel says so in one "
      "sentence. Charts are drawn by --chart-script with Debian's python3-matplotlib.");
  fs::path run_dir, output, state;
  RunFiles given;
  ReportOptions ro;
  ro.python = "/usr/bin/python3";
  auto& app = tool.cli();
  tool.add_input("rundir", run_dir, "Run directory of Makefile.pipeline (runs/<series>)", false);
  tool.add_output("report", output, "HTML page to write (.html); its PNGs go to the folder <stem>_img beside it");
  app.add_option("--labels", given.labels, "The scans' labels files in order (kind=labels), in place of RUNDIR/scan_*/labels.h5");
  app.add_option("--contacts", given.contacts, "The scans' contacts files in order (kind=contacts), one per scan");
  app.add_option("--shapes", given.shapes, "The scans' shapes files in order (kind=shapes), one per scan");
  app.add_option("--volumes", given.volumes,
                 "The scans themselves in order (kind=volume, ct2labels' inputs), one per scan: the sections draw the labels over "
                 "their grey values (without them, over white)");
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
  app.add_option("--validation", given.validation,
                 "Error budget against the series' ground truth (validate's validation.json) in place of RUNDIR/validation.json");
  app.add_option("--bench-img", ro.bench_img, "Folder of the benchmark charts (<tool>_<measure>.png); default: docs/img of the source tree this build came from");
  app.add_option("--max-series", ro.panels.max_series, "Scans, increments or frames drawn per chart (evenly spread, first and last always)")
      ->check(cli::whole_number_in(1, 20))->capture_default_str();
  app.add_option("--title", ro.title, "Page title (default: Experiment against simulation: <RUNDIR name>)");
  app.add_option("--python", ro.python, "Python with matplotlib that runs the chart script")->capture_default_str();
  app.add_option("--paraview-state", state,
                 "Also write a ParaView state of the run (.pvsm): the scans' grains and tracks beside the twin's frames, membrane "
                 "and force chains (the files the pipeline's stages wrote for ParaView in RUNDIR), paths relative to the state's "
                 "folder; the membrane's balls per frame go to <stem>_membrane/ beside it. Open it with the run folder as the data "
                 "directory (docs/report.md)");
  app.add_option("--chart-script", ro.script, "The chart script; default: pipelines/plots/report_charts.py of the source tree this build came from");
  tool.set_examples({"report runs/sand_small runs/sand_small/report.html --scan-strains sample_volumes/sand_small/series.json",
                     "report runs/sand_small /tmp/report.html --simulation other/simulation.h5 --forces other/forces.h5 --bench-img docs/img"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any table.
    if (output.extension() != ".html") throw UsageError("the report " + output.string() + " must end in .html");
    if (ro.script.empty()) ro.script = fs::path(GRAINTWIN_SOURCE_DIR) / "pipelines/plots/report_charts.py";
    std::error_code ec;
    if (!fs::exists(ro.python, ec))
      throw UsageError("--python " + ro.python.string() + " does not exist; install Debian's python3 and python3-matplotlib (scripts/deps.sh)");
    require_file(ro.python, "--python", "name the python3 program itself");
    require_file(ro.script, "--chart-script");
    if (!ro.bench_img.empty()) require_folder(ro.bench_img, "--bench-img", "pass the repository's docs/img");
    if (ro.bench_img.empty()) ro.bench_img = fs::path(GRAINTWIN_SOURCE_DIR) / "docs/img";
    if (!state.empty() && state.extension() != ".pvsm") throw UsageError("--paraview-state " + state.string() + " must end in .pvsm");
    const fs::path img_dir = output.parent_path() / (output.stem().string() + "_img");
    io::AtomicOutput html_out(output, ctx.force());
    io::AtomicOutput img_out(img_dir, ctx.force());
    std::optional<io::AtomicOutput> state_out, membrane_out;
    if (!state.empty()) {
      state_out.emplace(state, ctx.force());
      membrane_out.emplace(state.parent_path() / (state.stem().string() + "_membrane"), ctx.force());
    }
    const RunFiles files = locate_run_files(run_dir, given);
    const auto provenance = check_run_files(files);

    const ReportPage page = build_report(run_dir, files, provenance, ro, img_out.temp_path(), ctx.history_line(),
                                         ctx.progress_callback("reading and drawing"));
    std::ofstream(html_out.temp_path(), std::ios::binary) << page.html;
    spdlog::info("{} panels: {} charts drawn, {} sides without data (the page says why); error budget: {} lines, {} charts; {} benchmark charts",
                 page.panels, page.charts, page.sides_without, page.budget_lines, page.budget_charts, page.bench_charts);
    if (state_out) {
      const auto sources = write_paraview_state(run_dir, files, state_out->temp_path(), state, membrane_out->temp_path(), membrane_out->final_path());
      spdlog::info("ParaView state {}: {} data sets", state.string(), sources.size());
    }
    // The membrane's folder exists only when the simulation has a membrane.
    const bool membrane_written = membrane_out && fs::exists(membrane_out->temp_path());
    io::commit_outputs({&html_out, &img_out, state_out ? &*state_out : nullptr, membrane_written ? &*membrane_out : nullptr});
  });
}
