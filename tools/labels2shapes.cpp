// labels2shapes: measure every grain of a labels file and fit its spherical-harmonic surface
// (docs/methods.md: grain properties, spherical harmonics).
//   labels2shapes labels.h5 shapes.h5
//   labels2shapes labels.h5 scan.h5 shapes.h5 --surfaces grains.vtp
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/scan_shapes.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::shape;

namespace {

/// The command line beyond the stage's parameters.
struct Options {
  ShapesParams params;
  std::string surface = "auto";
  bool no_blur_correction = false;
  fs::path surfaces;
  int surface_subdivisions = 3;
};

/// The options: the labels, the optional scan and the shapes file, the fit, the surface and the
/// star-shape test.
void usage(cli::Tool& tool, fs::path& labels_path, fs::path& volume_path, fs::path& output, Options& o) {
  ShapesParams& p = o.params;
  auto& app = tool.cli();
  tool.add_input("labels", labels_path, "Labels file (.h5, kind=labels, from ct2labels)");
  tool.add_optional_input("volume", volume_path, "The scan that was segmented (.h5, kind=volume): sub-voxel surfaces from grey levels");
  tool.add_output("shapes", output, "Shapes file to write (.h5, kind=shapes)");
  using cli::closed, cli::number_in, cli::whole_number_in;
  app.add_option("--degree", p.degree, "Largest SH degree")->check(whole_number_in(0, 40))->capture_default_str();
  app.add_option("--directions", p.directions, "Sample directions per grain (0 = twice the coefficients)")
      ->check(whole_number_in(0, 1000000))->capture_default_str();
  app.add_option("--tol", p.tol,
                 "Per-grain degree: the smallest whose RMS radial residual is at most tol x equivalent radius "
                 "(0 = always --degree)")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--surface", o.surface, "Sub-voxel surface: auto (grey when VOLUME is given), grey or labels")
      ->capture_default_str();
  app.add_option("--smooth-vox", p.smooth_vox,
                 "Gaussian sigma (voxels) of the grain indicator (labels surface, default 0.7) or of the grey levels "
                 "(grey surface, default 0)")
      ->check(number_in(closed(0, 10, "voxels")));
  app.add_option("--grey-void", p.grey_void, "grey surface: grey level of void (default: median of interior void)")
      ->check(cli::finite_number());
  app.add_option("--grey-grain", p.grey_grain, "grey surface: grey level of grain (default: median of grain interiors)")
      ->check(cli::finite_number());
  app.add_option("--min-reentry-depth", p.min_reentry_depth_vox,
                 "Star-shape noise floor (voxels): a centroid ray's re-entry counts only where the surface it misses "
                 "lies at least this far inside the radial surface")
      ->check(number_in(closed(0, 100, "voxels")))->capture_default_str();
  app.add_option("--max-hidden-void", p.max_hidden_void,
                 "Flag the fit unreliable when the radial surface encloses more than this share of the grain's volume "
                 "as void")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--max-reentry-depth", p.max_reentry_depth_vox,
                 "Flag the fit unreliable when it misses a surface deeper than this (voxels) inside the radial surface")
      ->check(number_in(closed(0, 100, "voxels")))->capture_default_str();
  app.add_option("--point-spread", p.point_spread_vox,
                 "grey surface: the scanner's point spread (Gaussian sigma, voxels) whose share from neighbouring grains is "
                 "taken off each grain's grey levels (default: estimated from the grains' edges; 0 = keep the neighbours' light)")
      ->check(number_in(closed(0, 10, "voxels")));
  app.add_flag("--no-blur-correction", o.no_blur_correction,
               "Keep the iso-surface as found: do not undo the inward shift that the edge blur gives curved surfaces");
  app.add_option("--surfaces", o.surfaces, "Also write the reconstructed SH surfaces: .vtp (ParaView) or .stl");
  app.add_option("--surface-subdivisions", o.surface_subdivisions,
                 "Icosphere subdivisions of each reconstructed surface (3: 1280 triangles per grain)")
      ->check(whole_number_in(0, 6))->capture_default_str();
  tool.set_examples({"labels2shapes labels.h5 shapes.h5",
                     "labels2shapes labels.h5 scan.h5 shapes.h5 --surfaces grains.vtp",
                     "labels2shapes labels.h5 shapes.h5 --degree 20 --tol 0.005"});
}

/// Takes both inputs' histories after checking their kinds, and that the scan has the labels' shape.
void check_inputs(cli::RunContext& ctx, const fs::path& labels_path, const fs::path& volume_path) {
  const io::H5File lf = io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels");
  ctx.add_input_history(lf);
  if (volume_path.empty()) return;
  const io::H5File vf = io::open_kind(volume_path, schema::kind::volume, "pass the scan that was segmented");
  ctx.add_input_history(vf);
  const Shape3 ls = io::read_image_header(lf, schema::path::labels).shape;
  const Shape3 vs = io::read_image_header(vf, schema::path::volume).shape;
  if (vs != ls)
    throw UsageError(volume_path.string() + " is " + std::to_string(vs[0]) + " x " + std::to_string(vs[1]) + " x " +
                     std::to_string(vs[2]) + " but the labels are " + std::to_string(ls[0]) + " x " +
                     std::to_string(ls[1]) + " x " + std::to_string(ls[2]) + "; pass the scan that was segmented");
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("labels2shapes",
                 "Measure every grain of a labels file (kind=labels) and fit its spherical-harmonic surface "
                 "(kind=shapes): volume, centroid, surface area of an isosurface (marching tetrahedra, not voxel "
                 "faces), inertia-equivalent ellipsoid (semi-axes, principal directions, aspect ratios), equivalent "
                 "diameter, sphericity, the size distribution and d50; radii along shared Fibonacci directions from "
                 "each centroid, with sub-voxel accuracy from the grey levels (when VOLUME is given) or from the "
                 "smoothed label surface; a least-squares SH fit through one precomputed pseudo-inverse, a per-grain "
                 "degree from --tol, rotation invariants, reconstruction errors, and flags for grains that are not "
                 "star-shaped from their centroid, cut by the volume edge or too small.");
  Options o;
  fs::path labels_path, volume_path, output;
  usage(tool, labels_path, volume_path, output, o);

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options first (PDAL style), then the inputs' kinds, then the heavy work.
    o.params.surface = parse_surface_choice(o.surface);
    o.params.blur_correction = !o.no_blur_correction;
    const SurfaceSource source = surface_source(o.params.surface, !volume_path.empty());
    if (!o.surfaces.empty() && o.surfaces.extension() != ".vtp" && o.surfaces.extension() != ".stl")
      throw UsageError("--surfaces " + o.surfaces.string() + " must end in .vtp or .stl");
    if (!o.surfaces.empty()) io::check_output_allowed(o.surfaces, ctx.force());
    check_inputs(ctx, labels_path, volume_path);
    const ShFitter fitter = shapes_fitter(o.params);
    const segment::LabelsFile labels = segment::read_labels_file(labels_path);
    SegmentedScan scan{&labels.labels, {}, nullptr, labels_path.string(), volume_path.string()};
    for (const auto& g : labels.grains) scan.grains.push_back({g.label, g.bbox});
    AnyVolume grey;
    if (source == SurfaceSource::grey) scan.grey = &(grey = io::read_image(io::H5File::open(volume_path), schema::path::volume));
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> surfaces;
    if (!o.surfaces.empty()) surfaces.emplace(o.surfaces, ctx.force());

    const ShapesFile content =
        scan_shapes(scan, fitter, o.params, [&](const std::string& step) { return ctx.progress_callback(step); });
    write_shapes_file(out.temp_path(), content, ctx.history());
    if (surfaces)
      write_shape_surfaces(surfaces->temp_path(), o.surfaces.extension() == ".stl", content.grains, content.degree,
                           o.surface_subdivisions);
    io::commit_outputs({&out, surfaces ? &*surfaces : nullptr});
  });
}
