#include "graintwin/report/run_report.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fstream>

#include "graintwin/report/clusters_3d.hpp"
#include "graintwin/report/force_network.hpp"
#include "graintwin/report/page.hpp"
#include "graintwin/report/sections.hpp"
#include "graintwin/report/surfaces_3d.hpp"

namespace graintwin::report {

namespace {

std::string or_none(bool present, const std::string& what, const std::string& stage) {
  return present ? what : "none (the " + stage + " stage makes it)";
}

/// The stages of building the report, for the fraction done.
constexpr double kStages = 4.0;

}  // namespace

std::string report_title(const fs::path& run_dir, const std::string& title) {
  if (!title.empty()) return title;
  fs::path name = fs::absolute(run_dir).lexically_normal();
  if (name.filename().empty()) name = name.parent_path();  // "runs/sand_small/"
  return "Experiment against simulation: " + name.filename().string();
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
  rows.emplace_back("error budget against the truth", or_none(!f.validation.empty(), f.validation.string(), "validate"));
  return rows;
}

ReportPage build_report(const fs::path& run_dir, const RunFiles& files,
                        const std::vector<std::pair<std::string, std::vector<std::string>>>& provenance,
                        const ReportOptions& options, const fs::path& img_dir, const std::string& generated_by,
                        const std::function<void(double)>& progress) {
  const auto done = [&](double stages) {
    if (progress) progress(stages / kStages);
  };
  const ExperimentData experiment = read_experiment(files);
  done(1);
  const auto& rose = experiment.scans[0].rose_normal.theta_edges;
  const int theta_bins = rose.size() > 1 ? int(rose.size() - 1) : 9;
  const SimulationData simulation = read_simulation(files, options.panels.max_series, theta_bins);
  done(2);
  spdlog::info("{} scans ({}tracks, {}micro-mechanics); simulation: {}, its micro-mechanics: {}, forces: {}", experiment.scans.size(),
               files.tracks.empty() ? "no " : "", experiment.micro ? "" : "no ", simulation.present ? "yes" : "no",
               simulation.micro ? "yes" : "no", simulation.forces ? "yes" : "no");

  PageContent page;
  page.title = report_title(run_dir, options.title);
  // The sample itself first (sections, the grains, D2min clusters, eps_q and force chains in 3D), then the statistics.
  page.panels = section_panels(files, experiment, simulation, options.panels);
  page.panels.push_back(grain_surface_panel(files, experiment, simulation));
  for (Panel& p : cluster_3d_panels(files, experiment, simulation, options.panels)) page.panels.push_back(std::move(p));
  for (Panel& p : eps_q_3d_panels(files, experiment, simulation, options.panels)) page.panels.push_back(std::move(p));
  for (Panel& p : force_network_panels(files, simulation, options.panels)) page.panels.push_back(std::move(p));
  for (Panel& p : build_panels(experiment, simulation, options.panels)) page.panels.push_back(std::move(p));
  if (!files.validation.empty()) page.budget = error_budget(validate::read_validation(files.validation));
  std::vector<const Chart*> charts = panel_charts(page.panels);
  for (const BudgetLine& l : page.budget)
    if (l.chart) charts.push_back(&*l.chart);
  fs::create_directories(img_dir);
  nlohmann::json spec = {{"charts", nlohmann::json::array()}};
  for (const Chart* c : charts) spec["charts"].push_back(to_json(*c));
  const fs::path spec_path = img_dir / "charts.json";
  // Compact: the twin's outlines run to hundreds of thousands of points at 16 000 grains.
  std::ofstream(spec_path) << spec.dump() << "\n";
  // The grains' triangles go to the script in files of their own, gone once drawn (charts.json
  // keeps how many and from where): at 15 000 grains they are tens of megabytes.
  for (const Chart* c : charts)
    if (c->surfaces) write_surface_mesh(*c->surfaces, img_dir / c->surfaces->mesh_file);
  run_chart_script(options.python, options.script, spec_path, img_dir);
  for (const Chart* c : charts)
    if (c->surfaces) fs::remove(img_dir / c->surfaces->mesh_file);
  for (const Chart* c : charts) page.images[c->file] = read_binary_file(img_dir / c->file);
  done(3);

  const auto bench = find_bench_charts(options.bench_img);
  if (bench.empty()) spdlog::warn("no benchmark charts in {}; the page says so", options.bench_img.string());
  if (!bench.empty()) fs::create_directories(img_dir / "bench");
  for (const BenchChart& b : bench) {
    fs::copy_file(b.file, img_dir / "bench" / b.file.filename(), fs::copy_options::overwrite_existing);
    page.bench_charts.emplace_back(b, read_binary_file(b.file));
  }
  page.summary = run_summary(run_dir, files, experiment, simulation);
  page.provenance = provenance;
  page.generated_by = generated_by;
  ReportPage out;
  out.html = report_html(page);
  done(4);
  out.panels = page.panels.size();
  out.bench_charts = bench.size();
  for (const Panel& p : page.panels)
    for (const Side* side : {&p.experiment, &p.simulation}) (side->chart ? out.charts : out.sides_without) += 1;
  out.budget_lines = page.budget.size();
  for (const BudgetLine& l : page.budget) out.budget_charts += l.chart ? 1 : 0;
  return out;
}

}  // namespace graintwin::report
