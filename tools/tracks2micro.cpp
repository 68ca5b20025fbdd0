// tracks2micro: micro-mechanics of a tracked series (docs/methods.md, micro-mechanics).
//   tracks2micro runs/sand_small/tracks.h5 micro.h5 --vtk micro.vtp
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>
#include <map>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/contacts/contacts_file.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/micro_file.hpp"
#include "graintwin/micro/simulation.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::micro;

namespace {

void check_exists(const fs::path& p, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(p, ec)) throw UsageError(what + " " + p.string() + " does not exist; check the path");
}

/// Per grain (track) of one state, a value looked up by the grain's label in that state.
template <class T, class F>
void by_label(const track::TracksTable& tr, std::size_t t, const std::vector<std::uint32_t>& labels, F&& set) {
  std::map<std::uint32_t, std::size_t> row;
  for (std::size_t k = 0; k < labels.size(); ++k) row[labels[k]] = k;
  for (std::size_t i = 0; i < tr.tracks; ++i) {
    const std::uint32_t l = tr.label[i * tr.scans + t];
    if (l == 0) continue;
    const auto it = row.find(l);
    if (it != row.end()) set(i, it->second);
  }
}

/// The states of a tracked series: the tracks' centroids, the scans' shapes files for volumes, d50
/// and PSD, coordination numbers from contacts files when given.
MicroFile tracks_content(cli::RunContext& ctx, const fs::path& input, const std::vector<fs::path>& shapes_override,
                         const std::vector<fs::path>& contacts) {
  const io::H5File tracks_h5 = io::open_kind(input, schema::kind::tracks, "pass the output of shapes2tracks (tracks) or of fdemrun (simulation frames)");
  ctx.add_input_history(tracks_h5);
  const track::TracksTable tr = track::read_tracks_file(input);
  if (tr.scans < 2)
    throw UsageError(input.string() + " holds a single scan; micro-mechanics needs two states, so track two scans or more with shapes2tracks");
  std::vector<fs::path> shapes_paths(tr.scan_files.begin(), tr.scan_files.end());
  if (!shapes_override.empty()) {
    if (shapes_override.size() != tr.scans)
      throw UsageError("--shapes lists " + std::to_string(shapes_override.size()) + " files but " + input.string() + " has " +
                       std::to_string(tr.scans) + " scans; give one per scan");
    shapes_paths = shapes_override;
  }
  for (const fs::path& p : shapes_paths) {
    std::error_code ec;
    if (!fs::exists(p, ec))
      throw UsageError("the shapes file " + p.string() + " listed in " + input.string() +
                       " does not exist; run from the directory shapes2tracks ran in, or pass --shapes");
  }
  if (!contacts.empty() && contacts.size() != tr.scans)
    throw UsageError("--contacts lists " + std::to_string(contacts.size()) + " files but " + input.string() + " has " +
                     std::to_string(tr.scans) + " scans; give one per scan");
  for (const fs::path& p : contacts) check_exists(p, "contacts file");

  MicroFile content;
  SeriesStates& s = content.series;
  s.grains = tr.tracks, s.states = tr.scans, s.d50 = tr.scan_d50;
  s.position.resize(tr.tracks * tr.scans);
  for (std::size_t c = 0; c < s.position.size(); ++c)
    s.position[c] = Eigen::Vector3d(tr.centroid[3 * c], tr.centroid[3 * c + 1], tr.centroid[3 * c + 2]);
  s.volume.assign(s.position.size(), std::nan(""));
  for (std::size_t t = 0; t < tr.scans; ++t) {
    ctx.add_input_history(io::open_kind(shapes_paths[t], schema::kind::shapes, "pass the labels2shapes output of that scan"));
    const shape::ShapesFile sh = shape::read_shapes_file(shapes_paths[t]);
    std::vector<std::uint32_t> labels;
    for (const auto& g : sh.grains) labels.push_back(g.label);
    std::size_t found = 0;
    by_label<double>(tr, t, labels, [&](std::size_t i, std::size_t k) { s.volume[i * s.states + t] = sh.grains[k].volume, ++found; });
    std::size_t present = 0;
    for (std::size_t i = 0; i < tr.tracks; ++i) present += tr.label[i * tr.scans + t] != 0;
    if (found != present)
      throw DataError(shapes_paths[t].string() + " lacks " + std::to_string(present - found) + " grains the tracks name in scan " +
                      std::to_string(t) + "; pass the shapes files the tracks were made from (--shapes)");
    s.psd.push_back(sh.psd);
    content.state_files.push_back(shapes_paths[t].string());
  }
  if (!contacts.empty()) {
    s.coordination.resize(tr.scans);
    for (std::size_t t = 0; t < tr.scans; ++t) {
      ctx.add_input_history(io::open_kind(contacts[t], schema::kind::contacts, "pass the labels2contacts output of that scan"));
      // Only the grains' coordination is used, but the reader refuses a file whose tables disagree (a damaged file).
      const contacts::ContactsFile cf = contacts::read_contacts_file(contacts[t]);
      const auto& z = cf.coordination.per_grain;
      s.coordination[t].assign(tr.tracks, 0);
      by_label<std::uint32_t>(tr, t, cf.grain_label, [&](std::size_t i, std::size_t k) { s.coordination[t][i] = z[k]; });
    }
  }
  content.label = tr.label;
  return content;
}

/// The states of a simulation: every frame of a kind=fdem_results file, all grains in each, with
/// volumes from /grains/volume and coordination numbers from the frames' grain-grain contacts.
MicroFile simulation_content(cli::RunContext& ctx, const fs::path& input) {
  ctx.add_input_history(io::open_kind(input, schema::kind::fdem_results, "pass the output of fdemrun"));
  const SimulationGrains grains = read_simulation_grains(input);
  MicroFile content;
  content.series = simulation_states(input, grains, nullptr);
  const std::size_t t = content.series.states;
  if (t < 2) throw UsageError(input.string() + " holds a single frame; micro-mechanics needs two states, so save more frames with fdemrun");
  for (std::size_t k = 0; k < t; ++k) content.state_files.push_back(input.string() + ":" + schema::fdem_results::frames + "/" + std::to_string(k));
  content.label.resize(grains.label.size() * t);
  for (std::size_t i = 0; i < grains.label.size(); ++i)
    for (std::size_t k = 0; k < t; ++k) content.label[i * t + k] = grains.label[i];
  return content;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "tracks2micro",
      "Micro-mechanics of a tracked series (kind=tracks, from shapes2tracks; the scans' shapes files it lists give the "
      "grain volumes, d50 and PSD) or of simulation frames (kind=fdem_results, from fdemrun; every grain in every frame, "
      "volumes from its grain table, coordination from each frame's grain-grain contacts): per grain and increment "
      "(consecutive scans or frames, or --from/--to) the Falk-Langer D2min "
      "over the neighbours within --radius-d50 (reported over d50^2), the affine tensor Lambda, the local strain "
      "eps^L = I - (Lambda + Lambda^T)/2 (compression positive) and eps_q = sqrt(2/3 e_dev:e_dev); log-binned PDFs of "
      "D2min and eps_q; clusters of the --top-fraction highest D2min linked by contact distance, their sizes, "
      "volume-weighted R_g, a maximum-likelihood power-law fit of P(s) (Clauset-Shalizi-Newman) and the fractal "
      "dimension from R_g ~ s^(1/d_f); incremental displacement distributions over d50; per scan g(r) with Ripley's "
      "edge correction in the region the centres fill, the coordination-number distribution (from --contacts files, "
      "else by centroid distance) and the PSD. Writes kind=micro (.h5) and, with --vtk, grain points with D2min and "
      "eps_q for ParaView.");
  fs::path input, output, vtk;
  std::vector<fs::path> shapes_override, contacts;
  long long from = -1, to = -1;
  std::string region = "cylinder";
  MicroOptions o;
  auto& app = tool.cli();
  tool.add_input("input", input, "Tracks file (.h5, kind=tracks, from shapes2tracks) or simulation results (.h5, kind=fdem_results, from fdemrun)");
  tool.add_output("micro", output, "Micro-mechanics file to write (.h5, kind=micro)");
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in;
  app.add_option("--from", from, "First scan (or frame) of one increment (with --to; default: every pair of consecutive scans or frames)")
      ->check(whole_number_in(0, 1000000000));
  app.add_option("--to", to, "Second scan (or frame) of that increment")->check(whole_number_in(0, 1000000000));
  app.add_option("--shapes", shapes_override,
                 "The scans' shapes files in order, in place of the paths stored in the tracks file (when it was moved; tracks only)")
      ->expected(2, -1);
  app.add_option("--contacts", contacts,
                 "One contacts file per scan (kind=contacts, from labels2contacts): coordination numbers from its "
                 "contacts; without it, grains whose centroids are within --contact-factor (r_i + r_j) count as touching (tracks "
                 "only: simulation frames carry their contacts)")
      ->expected(2, -1);
  app.add_option("--radius-d50", o.radius_d50, "D2min neighbourhood radius (d50 of the first state of the increment)")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--min-neighbours", o.min_neighbours, "Fewest neighbours for a local deformation (fewer: flagged, NaN)")
      ->check(whole_number_in(3, 1000))->capture_default_str();
  app.add_option("--top-fraction", o.clusters.top_fraction, "Share of grains with the highest D2min that form clusters")
      ->check(number_in(above(0, 1)))->capture_default_str();
  app.add_option("--contact-factor", o.contact_factor,
                 "Grains touch when their centroids are within this factor times the sum of their volume-equivalent "
                 "radii (cluster links; coordination without --contacts)")
      ->check(number_in(closed(0.5, 3)))->capture_default_str();
  app.add_option("--min-tail", o.clusters.min_tail, "Fewest clusters in the power-law tail of P(s)")
      ->check(whole_number_in(2, 1000000))->capture_default_str();
  app.add_option("--pdf-bins-per-decade", o.pdf_per_decade, "Log bins per decade of the D2min and eps_q PDFs")
      ->check(number_in(closed(1, 100)))->capture_default_str();
  app.add_option("--rdf-max-d50", o.rdf_max_d50, "g(r) up to this distance (d50)")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--rdf-bins", o.rdf_bins, "Bins of g(r)")->check(whole_number_in(1, 100000))->capture_default_str();
  app.add_option("--region", region, "Region the grain centres fill, for g(r)'s edge correction: cylinder or box")
      ->capture_default_str();
  app.add_option("--displacement-bins", o.displacement_bins, "Bins of the displacement distributions")
      ->check(whole_number_in(1, 100000))->capture_default_str();
  app.add_option("--displacement-range-d50", o.displacement_range_d50,
                 "Displacement distributions over [-range, range] d50 (0: the largest component of each increment)")
      ->check(number_in(closed(0, 1000, "d50")))->capture_default_str();
  app.add_option("--vtk", vtk, "Also write the grains as VTK points with D2min, eps_q and cluster per increment (.vtp, ParaView)");
  tool.set_examples({"tracks2micro runs/sand_small/tracks.h5 runs/sand_small/micro.h5 --vtk runs/sand_small/micro.vtp",
                     "tracks2micro tracks.h5 micro.h5 --from 0 --to 2 --contacts scan_000/contacts.h5 scan_001/contacts.h5 scan_002/contacts.h5",
                     "tracks2micro runs/sand_small/results.h5 runs/sand_small/micro_sim.h5 --from 0 --to 4"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any table.
    o.region = parse_region_kind(region);
    o.clusters.link_factor = o.contact_factor;  // one definition of touching for cluster links and coordination
    if (output.extension() != ".h5") throw UsageError("the micro file " + output.string() + " must end in .h5");
    if (!vtk.empty() && vtk.extension() != ".vtp") throw UsageError("--vtk " + vtk.string() + " must end in .vtp");
    if ((from < 0) != (to < 0)) throw UsageError("--from and --to go together: give both states (scans or frames) of the increment");
    if (from >= 0 && from == to) throw UsageError("--from and --to name the same state; give two different scans or frames");
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!vtk.empty()) vtk_out.emplace(vtk, ctx.force());
    const std::string kind = io::file_kind(io::H5File::open(input));
    const bool simulation = kind == schema::kind::fdem_results;
    if (simulation && (!shapes_override.empty() || !contacts.empty()))
      throw UsageError("--shapes and --contacts belong to tracks; " + input.string() +
                       " holds simulation frames, whose volumes and contacts it carries itself");
    MicroFile content = simulation ? simulation_content(ctx, input) : tracks_content(ctx, input, shapes_override, contacts);
    const SeriesStates& s = content.series;
    const std::string state = simulation ? "frame" : "scan";
    if (to >= static_cast<long long>(s.states) || from >= static_cast<long long>(s.states))
      throw UsageError("--from/--to must name " + state + "s 0.." + std::to_string(s.states - 1) + " of " + input.string());
    const auto increments = from >= 0 ? std::vector<std::pair<std::size_t, std::size_t>>{{std::size_t(from), std::size_t(to)}}
                                      : consecutive_increments(s.states);
    spdlog::info("{} grains over {} {}s (d50 {:.4g} mm in {} 0), {} increment(s)", s.grains, s.states, state, s.d50[0] * 1e3, state,
                 increments.size());
    content.result = analyse_series(s, increments, o, ctx.progress_callback("micro-mechanics"));

    for (const IncrementResult& r : content.result.increments) {
      std::size_t ok = 0, few = 0, singular = 0;
      double sum_d2 = 0.0, sum_q = 0.0;
      for (const auto& g : r.grains) {
        ok += g.status == DeformationStatus::ok, few += g.status == DeformationStatus::too_few_neighbours;
        singular += g.status == DeformationStatus::singular;
        if (g.status == DeformationStatus::ok) sum_d2 += g.d2min, sum_q += g.eps_q;
      }
      spdlog::info("{} -> {}: local deformation of {} grains ({} with too few neighbours, {} singular); mean D2min/d50^2 {:.3g}, "
                   "mean eps_q {:.3g}", r.from, r.to, ok, few, singular, ok ? sum_d2 / double(ok) : 0.0, ok ? sum_q / double(ok) : 0.0);
      const ClusterStatistics& c = r.clusters;
      spdlog::info("  {} clusters of the {} highest-D2min grains (D2min/d50^2 >= {:.3g}); P(s) power law {}; d_f {}", c.size.size(),
                   c.selected, c.threshold,
                   c.size_fit.valid ? fmt::format("alpha {:.2f} +- {:.2f} for s >= {:g}", c.size_fit.alpha, c.size_fit.alpha_error, c.size_fit.x_min)
                                    : "not fitted (too few clusters)",
                   std::isfinite(c.fractal_dimension) ? fmt::format("{:.2f} +- {:.2f}", c.fractal_dimension, c.fractal_dimension_error)
                                                      : "not fitted (too few clusters of 2 or more)");
    }
    for (std::size_t t = 0; t < content.result.states.size(); ++t) {
      const StateResult& r = content.result.states[t];
      spdlog::info("{} {}: mean coordination {:.2f} ({}), g(r) over {} grains", state, t, r.coordination_distribution.mean,
                   r.coordination_from_contacts ? "contacts" : "distance criterion", r.rdf.points);
    }
    nlohmann::json p = {{"source", simulation ? "fdem_results" : "tracks"},
                        {"increments", increments},
                        {"radius_d50", o.radius_d50},
                        {"min_neighbours", o.min_neighbours},
                        {"top_fraction", o.clusters.top_fraction},
                        {"contact_factor", o.contact_factor},
                        {"cluster_links", "contact distance"},
                        {"coordination", simulation || !contacts.empty() ? "contacts" : "distance"},
                        {"min_tail", o.clusters.min_tail},
                        {"pdf_bins_per_decade", o.pdf_per_decade},
                        {"rdf_max_d50", o.rdf_max_d50},
                        {"rdf_bins", o.rdf_bins},
                        {"region", region},
                        {"displacement_bins", o.displacement_bins},
                        {"displacement_range_d50", o.displacement_range_d50}};
    content.parameters_json = p.dump();
    write_micro_file(out.temp_path(), content, ctx.history());
    if (vtk_out) write_micro_vtp(vtk_out->temp_path(), content);
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
  });
}
