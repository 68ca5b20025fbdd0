// shapes2tracks: follow every grain through a series of scans (docs/methods.md, matching and tracking).
//   shapes2tracks scan0/shapes.h5 scan1/shapes.h5 scan2/shapes.h5 tracks.h5 --vtk tracks.vtp
#include <spdlog/spdlog.h>

#include <cmath>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/track/series.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::track;

namespace {

/// The options: the shapes files then the tracks file, matching, chaining and rotation settings.
void usage(cli::Tool& tool, std::vector<fs::path>& positional, std::string& method, std::string& rotation, ChainOptions& co,
           RotationOptions& ro, fs::path& vtk) {
  auto& app = tool.cli();
  app.add_option("shapes", positional,
                 "Shapes files of the scans in order (.h5, kind=shapes, at least two), then the tracks file to write "
                 "(.h5, kind=tracks)")
      ->required()
      ->expected(3, -1);
  using cli::closed, cli::above, cli::number_in, cli::whole_number_in;
  app.add_option("--method", method, "Matching: improved, paper, nearest or volume")->capture_default_str();
  app.add_option("--window", co.match.window_d50,
                 "Candidate window (d50 of the reference scan): paper and baselines; improved's first pass and its largest window")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--volume-tol", co.match.volume_tol,
                 "Largest relative volume change |v_j - v_i| / v_i of a candidate (negative: no filter, e.g. -1); default 0.10 "
                 "for paper and volume (the paper's), none for improved (its cost weighs the volume change); nearest "
                 "never filters")
      ->check(number_in(closed(-1, 10)));
  app.add_option("--passes", co.match.passes, "improved: prediction and assignment passes")
      ->check(whole_number_in(1, 10))->capture_default_str();
  app.add_option("--local-radius", co.match.local_radius_d50, "improved: radius of the local affine fits (d50)")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--window-sigmas", co.match.window_sigmas,
                 "improved: candidate window around the prediction, in local position residual spreads")
      ->check(number_in(above(0, 1000)))->capture_default_str();
  app.add_option("--min-window", co.match.min_window_d50, "improved: smallest candidate window (d50)")
      ->check(number_in(above(0, 100, "d50")))->capture_default_str();
  app.add_option("--lost-cost", co.match.lost_cost,
                 "improved: cost of reporting a grain lost (a right match costs about 5; higher keeps more doubtful matches)")
      ->check(number_in(above(0, 1e6)))->capture_default_str();
  app.add_flag("!--no-backward-check", co.match.backward_check,
               "Skip matching each step the other way round (confidence then rests on the costs alone; paper: always 1)");
  app.add_option("--max-gap", co.max_gap,
                 "Scans a lost grain may stay missing and still be found again (0: lost is final)")
      ->check(whole_number_in(0, 100))->capture_default_str();
  app.add_option("--rotation", rotation, "Rotations: sh (axes, then surface alignment), axes (principal axes only) or none")
      ->capture_default_str();
  app.add_option("--symmetry-tol", ro.symmetry_tol,
                 "axes: semi-axes closer than this relative difference make a rotation undefined")
      ->check(number_in(closed(0, 0.99)))->capture_default_str();
  app.add_option("--rotation-margin", ro.min_margin,
                 "A rotation is defined when it fits the surfaces at least this much better than any other")
      ->check(number_in(closed(1, 100)))->capture_default_str();
  app.add_option("--rotation-degree", ro.degree, "SH degree of the surface comparison for rotations")
      ->check(whole_number_in(2, 30))->capture_default_str();
  app.add_option("--vtk", vtk, "Also write the tracks as VTK points with displacement vectors (.vtp, ParaView)");
  tool.set_examples({"shapes2tracks scan_000/shapes.h5 scan_001/shapes.h5 tracks.h5",
                     "shapes2tracks runs/sand_small/scan_*/shapes.h5 tracks.h5 --vtk tracks.vtp",
                     "shapes2tracks a.h5 b.h5 tracks.h5 --method paper --rotation axes"});
}

void log_series(const TracksFile& content, const ChainOptions& co, const RotationOptions& ro) {
  for (std::size_t t = 0; t < content.scans.size(); ++t)
    spdlog::info("scan {}: {} grains, d50 {:.4g} mm ({})", t, content.scan_labels[t].size(), content.d50[t] * 1e3, content.scans[t]);
  const Tracks& tr = content.tracks;
  for (std::size_t t = 1; t < tr.scans; ++t) {
    const StepCounts& s = tr.steps[t];
    const MatchDiagnostics& d = tr.diagnostics[t - 1];
    const std::size_t before = tr.steps[t - 1].grains;
    spdlog::info("step {} -> {}: {} matched ({:.1f} % of {}), {} lost, {} found again, {} new; mean confidence {:.3f}, "
                 "{} backward disagreements, {:.1f} candidates per grain",
                 t - 1, t, s.matched, 100.0 * s.matched / before, before, s.lost, s.found, s.started, s.mean_confidence,
                 d.backward_disagreements, d.mean_candidates);
    if (co.match.method == Method::improved)
      spdlog::info("  prediction from {} bootstrap pairs; residual spreads: position {:.3g} um, shape {:.3g}, volume {:.3g}",
                   d.anchors, d.sigma_position * 1e6, d.sigma_shape, d.sigma_volume);
  }
  std::size_t defined = 0, steps = 0;
  for (std::size_t i = 0; i < tr.size(); ++i)
    for (std::size_t t = 1; t < tr.scans; ++t)
      if (std::isfinite(content.kinematics.increment[3 * (i * tr.scans + t)]))
        ++steps, defined += content.kinematics.rotation_defined[i * tr.scans + t];
  if (ro.method != RotationMethod::none)
    spdlog::info("rotations defined for {} of {} grain steps ({:.1f} %)", defined, steps, steps ? 100.0 * defined / steps : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool(
      "shapes2tracks",
      "Follow every grain through a series of scans: match the grains of each scan (kind=shapes, from "
      "labels2shapes) to the next, chain the matches into trajectories with lost and found grains, and measure each "
      "grain's displacement and rotation (kind=tracks, plus VTK points with displacement vectors for ParaView). "
      "--method improved (default) predicts where each grain went from the grains matched around it (robust global "
      "affine, then local weighted affine fits), scores the candidates near the prediction by SH invariant distance, "
      "volume change and position residual, each normalised by its spread over the matches, solves one global "
      "minimum-cost assignment in which a grain may be lost, and rates each match by its cost against the "
      "alternatives and a backward match. --method paper is the CT-FDEM paper's Algorithm 1 exactly (candidates "
      "within 3 d50 of the reference scan, volume change <= 10 %, SH invariant distance, conflicts resolved by the "
      "smallest score); nearest and volume are baselines. A grain lost at one step is looked for again in the next "
      "scan(s) (--max-gap). Rotations: principal axes of the inertia ellipsoid with their signs chosen by comparing "
      "the SH surfaces, refined by aligning the surfaces (--rotation sh), and flagged undefined when the surfaces "
      "cannot tell (near-symmetric grains).");
  std::vector<fs::path> positional;
  std::string method = "improved", rotation = "sh";
  ChainOptions co;
  RotationOptions ro;
  fs::path vtk;
  usage(tool, positional, method, rotation, co, ro, vtk);

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options and files first, before reading any table.
    co.match.method = parse_method(method);
    ro.method = parse_rotation_method(rotation);
    const fs::path output = positional.back();
    positional.pop_back();
    if (output.extension() != ".h5") throw UsageError("the tracks file " + output.string() + " must end in .h5 (the last argument is the output)");
    if (!vtk.empty() && vtk.extension() != ".vtp") throw UsageError("--vtk " + vtk.string() + " must end in .vtp");
    for (const fs::path& p : positional) {
      std::error_code ec;
      if (!fs::exists(p, ec)) throw UsageError("input " + p.string() + " does not exist; check the path");
      if (fs::equivalent(p, output, ec)) throw UsageError("the output " + output.string() + " is also an input");
    }
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> vtk_out;
    if (!vtk.empty()) vtk_out.emplace(vtk, ctx.force());
    for (const fs::path& p : positional)
      ctx.add_input_history(io::open_kind(p, schema::kind::shapes, "pass the output of labels2shapes"));

    const TracksFile content =
        track_series(positional, co, ro, [&](const std::string& step) { return ctx.progress_callback(step); });
    log_series(content, co, ro);
    write_tracks_file(out.temp_path(), content, ctx.history());
    if (vtk_out) write_tracks_vtp(vtk_out->temp_path(), content);
    io::commit_outputs({&out, vtk_out ? &*vtk_out : nullptr});
    spdlog::info("{} tracks over {} scans", content.tracks.size(), content.tracks.scans);
  });
}
