// tracks2micro: micro-mechanics of a tracked series (docs/methods.md, micro-mechanics).
//   tracks2micro runs/sand_small/tracks.h5 micro.h5 --vtk micro.vtp
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/micro/micro_analysis.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::micro;

namespace {

/// The command line beyond the analysis' options.
struct Options {
  fs::path input, output, vtk;
  std::vector<fs::path> shapes_override, contacts;
  long long from = -1, to = -1;
  std::string region = "cylinder";
};

/// The options: the input and the micro file, the increment, the other files of a tracked series,
/// and the analysis' settings.
void usage(cli::Tool& tool, Options& c, MicroOptions& o) {
  auto& app = tool.cli();
  tool.add_input("input", c.input, "Tracks file (.h5, kind=tracks, from shapes2tracks) or simulation results (.h5, kind=fdem_results, from fdemrun)");
  tool.add_output("micro", c.output, "Micro-mechanics file to write (.h5, kind=micro)");
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in;
  app.add_option("--from", c.from, "First scan (or frame) of one increment (with --to; default: every pair of consecutive scans or frames)")
      ->check(whole_number_in(0, 1000000000));
  app.add_option("--to", c.to, "Second scan (or frame) of that increment")->check(whole_number_in(0, 1000000000));
  app.add_option("--shapes", c.shapes_override,
                 "The scans' shapes files in order, in place of the paths stored in the tracks file (when it was moved; tracks only)")
      ->expected(2, -1);
  app.add_option("--contacts", c.contacts,
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
  app.add_option("--region", c.region, "Region the grain centres fill, for g(r)'s edge correction: cylinder or box")
      ->capture_default_str();
  app.add_option("--displacement-bins", o.displacement_bins, "Bins of the displacement distributions")
      ->check(whole_number_in(1, 100000))->capture_default_str();
  app.add_option("--displacement-range-d50", o.displacement_range_d50,
                 "Displacement distributions over [-range, range] d50 (0: the largest component of each increment)")
      ->check(number_in(closed(0, 1000, "d50")))->capture_default_str();
  app.add_option("--vtk", c.vtk, "Also write the grains as VTK points with D2min, eps_q and cluster per increment (.vtp, ParaView)");
  tool.set_examples({"tracks2micro runs/sand_small/tracks.h5 runs/sand_small/micro.h5 --vtk runs/sand_small/micro.vtp",
                     "tracks2micro tracks.h5 micro.h5 --from 0 --to 2 --contacts scan_000/contacts.h5 scan_001/contacts.h5 scan_002/contacts.h5",
                     "tracks2micro runs/sand_small/results.h5 runs/sand_small/micro_sim.h5 --from 0 --to 4"});
}

/// The states of `c.input`: a simulation's frames, or the tracks with the scans' shapes (and
/// contacts) files; every file read is an input of the run.
MicroFile read_states(cli::RunContext& ctx, const Options& c, bool simulation) {
  if (simulation) {
    ctx.add_input_history(io::open_kind(c.input, schema::kind::fdem_results, "pass the output of fdemrun"));
    return simulated_states(c.input);
  }
  ctx.add_input_history(io::open_kind(c.input, schema::kind::tracks,
                                      "pass the output of shapes2tracks (tracks) or of fdemrun (simulation frames)"));
  track::TracksTable tr = track::read_tracks_file(c.input);
  const TrackedGrains tracks{tr.tracks, tr.scans, std::move(tr.label), std::move(tr.centroid), std::move(tr.scan_files),
                             std::move(tr.scan_d50)};
  return tracked_states(tracks, c.input.string(), c.shapes_override, c.contacts,
                        [&](const io::H5File& f) { ctx.add_input_history(f); });
}

/// Per increment the local deformations and the clusters, per state the coordination and g(r).
void log_result(const MicroResult& result, const std::string& state) {
  for (const IncrementResult& r : result.increments) {
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
  for (std::size_t t = 0; t < result.states.size(); ++t) {
    const StateResult& r = result.states[t];
    spdlog::info("{} {}: mean coordination {:.2f} ({}), g(r) over {} grains", state, t, r.coordination_distribution.mean,
                 r.coordination_from_contacts ? "contacts" : "distance criterion", r.rdf.points);
  }
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
  Options c;
  MicroOptions o;
  usage(tool, c, o);

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any table.
    o.region = parse_region_kind(c.region);
    o.clusters.link_factor = o.contact_factor;  // one definition of touching for cluster links and coordination
    if (c.output.extension() != ".h5") throw UsageError("the micro file " + c.output.string() + " must end in .h5");
    if (!c.vtk.empty() && c.vtk.extension() != ".vtp") throw UsageError("--vtk " + c.vtk.string() + " must end in .vtp");
    if ((c.from < 0) != (c.to < 0)) throw UsageError("--from and --to go together: give both states (scans or frames) of the increment");
    if (c.from >= 0 && c.from == c.to) throw UsageError("--from and --to name the same state; give two different scans or frames");
    io::AtomicOutput out(c.output, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!c.vtk.empty()) vtk_out.emplace(c.vtk, ctx.force());
    const std::string kind = io::file_kind(io::H5File::open(c.input));
    const bool simulation = kind == schema::kind::fdem_results;
    if (simulation && (!c.shapes_override.empty() || !c.contacts.empty()))
      throw UsageError("--shapes and --contacts belong to tracks; " + c.input.string() +
                       " holds simulation frames, whose volumes and contacts it carries itself");

    MicroFile content = read_states(ctx, c, simulation);
    const std::string source = simulation ? schema::kind::fdem_results : schema::kind::tracks;
    analyse_states(content, c.input.string(), source, c.from, c.to, o,
                   [&](const std::string& step) { return ctx.progress_callback(step); });
    log_result(content.result, state_noun(source));
    write_micro_file(out.temp_path(), content, ctx.history());
    if (vtk_out) write_micro_vtp(vtk_out->temp_path(), content);
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
  });
}
