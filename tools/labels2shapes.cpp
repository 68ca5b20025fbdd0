// labels2shapes: measure every grain of a labels file and fit its spherical-harmonic surface
// (docs/methods.md: grain properties, spherical harmonics).
//   labels2shapes labels.h5 shapes.h5
//   labels2shapes labels.h5 scan.h5 shapes.h5 --surfaces grains.vtp
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/stl.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/io/vtk.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_surface.hpp"
#include "graintwin/shape/shapes_file.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::shape;

namespace {

struct Options {
  int degree = 15;
  int directions = 0;
  double tol = 0.01;
  std::string surface = "auto";
  std::optional<double> smooth_vox;
  std::optional<double> grey_void, grey_grain;
  double min_reentry_depth = 0.5;
  double max_hidden_void = 0.01;
  double max_reentry_depth = 1.0;
  bool no_blur_correction = false;
  std::optional<double> point_spread;
  fs::path surfaces;
  int surface_subdivisions = 3;
};

/// Reconstructed SH surfaces of all grains, one mesh: ParaView (.vtp, cell data label and flags)
/// or STL (triangle soup).
void write_surfaces(const fs::path& path, bool stl, const std::vector<GrainShape>& grains, int degree, int subdivisions) {
  const SphereMesh sphere = icosphere(subdivisions);
  const Eigen::MatrixXd basis = sh_design_matrix(degree, sphere.directions);
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::vector<double> label, flags;
  for (const GrainShape& g : grains) {
    const int first = static_cast<int>(vertices.size());
    const auto v = displaced_vertices(sphere, (basis * g.coeffs).cwiseMax(0.0), g.centroid);
    vertices.insert(vertices.end(), v.begin(), v.end());
    for (const auto& t : sphere.triangles) {
      triangles.push_back({first + t[0], first + t[1], first + t[2]});
      label.push_back(g.label);
      flags.push_back(g.flags);
    }
  }
  if (stl) {
    io::write_stl(path, vertices, triangles);
    return;
  }
  io::VtkPolyData d;
  for (const auto& v : vertices) d.points.insert(d.points.end(), {v[0], v[1], v[2]});
  for (const auto& t : triangles) d.add_triangle(t[0], t[1], t[2]);
  d.cell_data.push_back({"label", 1, std::move(label)});
  d.cell_data.push_back({"flags", 1, std::move(flags)});
  io::write_vtp(path, d);
}

std::size_t count_flag(const std::vector<GrainShape>& g, std::uint8_t bit) {
  return static_cast<std::size_t>(std::count_if(g.begin(), g.end(), [&](const GrainShape& s) { return s.flags & bit; }));
}

/// The surface lies where the grey level crosses the middle of the void and grain levels: they must
/// be in order and inside the scan's own range, or every surface sits somewhere the data never says.
template <class T>
void check_grey_levels(const MeasureOptions& mo, const Volume<T>& grey, const fs::path& volume_path) {
  const auto [lo, hi] = std::minmax_element(grey.values().begin(), grey.values().end());
  const double low = lo == grey.values().end() ? 0.0 : static_cast<double>(*lo), high = hi == grey.values().end() ? 0.0 : static_cast<double>(*hi);
  const auto outside = [&](double v) { return v < low || v > high; };
  if (outside(mo.grey_void) || outside(mo.grey_grain))
    throw UsageError(fmt::format("--grey-void {:.6g} and --grey-grain {:.6g} must lie within the grey values of {} ({:.6g} to {:.6g}); "
                                 "give the void and grain levels of that scan, or leave them out to take its medians",
                                 mo.grey_void, mo.grey_grain, volume_path.string(), low, high));
  if (!(mo.grey_grain > mo.grey_void))
    throw UsageError(fmt::format("the grain grey level {:.6g} must exceed the void grey level {:.6g} (--grey-grain, --grey-void); "
                                 "give the levels of {} in that order, or leave them out to take its medians",
                                 mo.grey_grain, mo.grey_void, volume_path.string()));
}

/// The star-shape test in numbers: how many grains re-enter beyond the noise floor, and why the
/// unreliable ones are unreliable; the median edge width behind the blur correction.
void log_star_shape_summary(const std::vector<GrainShape>& g, double max_hidden_void, double max_depth_m) {
  std::size_t by_volume = 0, by_depth = 0;
  std::vector<double> sigma;
  for (const GrainShape& s : g) {
    by_volume += s.hidden_void_fraction > max_hidden_void;
    by_depth += s.reentry_depth > max_depth_m;
    if (s.edge_sigma > 0.0) sigma.push_back(s.edge_sigma);
  }
  spdlog::info("star shape: {} grains with re-entrant rays above the noise floor; {} enclose more than {:.3g} % of "
               "their volume as void, {} miss a surface deeper than {:.3g} um",
               count_flag(g, shape_flag::not_star_shaped), by_volume, 100.0 * max_hidden_void, by_depth, max_depth_m * 1e6);
  if (!sigma.empty()) spdlog::info("edge width (Gaussian sigma, median over grains) {:.3g} um", median(std::move(sigma)) * 1e6);
}

std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> grain_boxes(const segment::LabelsFile& labels) {
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> grains;
  grains.reserve(labels.grains.size());
  for (const auto& r : labels.grains) grains.push_back({r.label, r.bbox});
  return grains;
}

template <class T>
std::vector<GrainShape> measure_all(const segment::LabelsFile& labels, const Volume<T>* grey, const ShFitter& fitter,
                                    const MeasureOptions& options, cli::RunContext& ctx) {
  return measure_grains(labels.labels, grey, grain_boxes(labels), fitter, options, ctx.progress_callback("grains"));
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
  auto& app = tool.cli();
  tool.add_input("labels", labels_path, "Labels file (.h5, kind=labels, from ct2labels)");
  tool.add_optional_input("volume", volume_path, "The scan that was segmented (.h5, kind=volume): sub-voxel surfaces from grey levels");
  tool.add_output("shapes", output, "Shapes file to write (.h5, kind=shapes)");
  using cli::closed, cli::number_in, cli::whole_number_in;
  app.add_option("--degree", o.degree, "Largest SH degree")->check(whole_number_in(0, 40))->capture_default_str();
  app.add_option("--directions", o.directions, "Sample directions per grain (0 = twice the coefficients)")
      ->check(whole_number_in(0, 1000000))->capture_default_str();
  app.add_option("--tol", o.tol,
                 "Per-grain degree: the smallest whose RMS radial residual is at most tol x equivalent radius "
                 "(0 = always --degree)")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--surface", o.surface, "Sub-voxel surface: auto (grey when VOLUME is given), grey or labels")
      ->capture_default_str();
  app.add_option("--smooth-vox", o.smooth_vox,
                 "Gaussian sigma (voxels) of the grain indicator (labels surface, default 0.7) or of the grey levels "
                 "(grey surface, default 0)")
      ->check(number_in(closed(0, 10, "voxels")));
  app.add_option("--grey-void", o.grey_void, "grey surface: grey level of void (default: median of interior void)")
      ->check(cli::finite_number());
  app.add_option("--grey-grain", o.grey_grain, "grey surface: grey level of grain (default: median of grain interiors)")
      ->check(cli::finite_number());
  app.add_option("--min-reentry-depth", o.min_reentry_depth,
                 "Star-shape noise floor (voxels): a centroid ray's re-entry counts only where the surface it misses "
                 "lies at least this far inside the radial surface")
      ->check(number_in(closed(0, 100, "voxels")))->capture_default_str();
  app.add_option("--max-hidden-void", o.max_hidden_void,
                 "Flag the fit unreliable when the radial surface encloses more than this share of the grain's volume "
                 "as void")
      ->check(number_in(closed(0, 1)))->capture_default_str();
  app.add_option("--max-reentry-depth", o.max_reentry_depth,
                 "Flag the fit unreliable when it misses a surface deeper than this (voxels) inside the radial surface")
      ->check(number_in(closed(0, 100, "voxels")))->capture_default_str();
  app.add_option("--point-spread", o.point_spread,
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

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    // Options first (PDAL style), then the inputs' kinds, then the heavy work.
    if (o.surface != "auto" && o.surface != "grey" && o.surface != "labels")
      throw UsageError("--surface '" + o.surface + "' is not auto, grey or labels");
    const bool use_grey = o.surface == "grey" || (o.surface == "auto" && !volume_path.empty());
    if (use_grey && volume_path.empty()) throw UsageError("--surface grey needs the scan: labels2shapes LABELS VOLUME SHAPES");
    if (!o.surfaces.empty() && o.surfaces.extension() != ".vtp" && o.surfaces.extension() != ".stl")
      throw UsageError("--surfaces " + o.surfaces.string() + " must end in .vtp or .stl");
    if (!o.surfaces.empty()) io::check_output_allowed(o.surfaces, ctx.force());
    // Cheap checks of both inputs (kind, geometry) before any heavy work.
    {
      const io::H5File lf = io::open_kind(labels_path, schema::kind::labels, "pass the output of ct2labels");
      ctx.add_input_history(lf);
      if (!volume_path.empty()) {
        const io::H5File vf = io::open_kind(volume_path, schema::kind::volume, "pass the scan that was segmented");
        ctx.add_input_history(vf);
        const Shape3 ls = io::read_image_header(lf, schema::path::labels).shape;
        const Shape3 vs = io::read_image_header(vf, schema::path::volume).shape;
        if (vs != ls)
          throw UsageError(volume_path.string() + " is " + std::to_string(vs[0]) + " x " + std::to_string(vs[1]) + " x " +
                           std::to_string(vs[2]) + " but the labels are " + std::to_string(ls[0]) + " x " +
                           std::to_string(ls[1]) + " x " + std::to_string(ls[2]) + "; pass the scan that was segmented");
      }
    }
    // The fitter holds directions x coefficients matrices: check that before building them.
    const MemoryLimit memory = memory_limit();
    const double per_direction = ShFitter::memory_bytes(o.degree, 1);
    check_memory(ShFitter::memory_bytes(o.degree, o.directions), "labels2shapes",
                 fmt::format("{} sample directions x {} SH coefficients (degree {})",
                             ShFitter::directions_for(o.degree, o.directions), sh_count(o.degree), o.degree),
                 fmt::format("give --directions of at most {:.0f} or a lower --degree", std::floor(memory.bytes / per_direction)),
                 memory);
    const ShFitter fitter(o.degree, o.directions);
    if (!fitter.warning().empty()) spdlog::warn("{}", fitter.warning());
    const segment::LabelsFile labels = segment::read_labels_file(labels_path);
    if (labels.grains.empty())
      throw DataError(labels_path.string() + " holds no grain; check the segmentation (ct2labels) that made it");
    AnyVolume grey;
    if (use_grey) grey = io::read_image(io::H5File::open(volume_path), schema::path::volume);
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> surfaces;
    if (!o.surfaces.empty()) surfaces.emplace(o.surfaces, ctx.force());

    MeasureOptions mo;
    mo.source = use_grey ? SurfaceSource::grey : SurfaceSource::labels;
    mo.smooth_vox = o.smooth_vox.value_or(use_grey ? 0.0 : 0.7);
    mo.tol = o.tol;
    mo.min_reentry_depth_vox = o.min_reentry_depth;
    mo.max_hidden_void_fraction = o.max_hidden_void;
    mo.max_reentry_depth_vox = o.max_reentry_depth;
    mo.correct_blur = !o.no_blur_correction;
    std::vector<GrainShape> grains;
    try {
      grains = std::visit(
          [&](const auto& g) -> std::vector<GrainShape> {
            using T = typename std::decay_t<decltype(g)>::value_type;
            if constexpr (std::is_same_v<T, std::uint32_t>) {
              throw UsageError(volume_path.string() + " is uint32; pass the uint8, uint16 or float32 scan");
            } else {
              if (!use_grey) return measure_all<T>(labels, nullptr, fitter, mo, ctx);
              if constexpr (std::is_floating_point_v<T>)
                for (float v : g.values())
                  if (!std::isfinite(v)) throw DataError(volume_path.string() + " holds NaN or infinite grey values; use --surface labels");
              const GreyLevels levels = grey_levels(labels.labels, g);
              mo.grey_void = o.grey_void.value_or(levels.void_level);
              mo.grey_grain = o.grey_grain.value_or(levels.grain_level);
              spdlog::info("grey levels: void {:.6g}, grain {:.6g}{}", mo.grey_void, mo.grey_grain,
                           o.grey_void || o.grey_grain ? " (given)" : " (medians of interior voxels)");
              check_grey_levels(mo, g, volume_path);
              mo.point_spread_vox = o.point_spread ? *o.point_spread : estimate_point_spread(labels.labels, g, grain_boxes(labels), fitter, mo);
              spdlog::info("point spread {:.3g} voxel{}", mo.point_spread_vox,
                           o.point_spread ? " (given)" : " (edge width of up to 64 grains, less the voxel's own)");
              return measure_all<T>(labels, &g, fitter, mo, ctx);
            }
          },
          use_grey ? grey : AnyVolume(Volume<std::uint8_t>()));
    } catch (Error& e) {
      e.add_context("while measuring the grains of " + labels_path.string());
      throw;
    }

    ShapesFile content;
    content.degree = fitter.degree();
    std::vector<double> d(grains.size()), v(grains.size());
    for (std::size_t i = 0; i < grains.size(); ++i) d[i] = grains[i].equivalent_diameter, v[i] = grains[i].volume;
    content.psd = size_distribution(d, v);
    nlohmann::json p = {{"degree", fitter.degree()},
                        {"requested_degree", o.degree},
                        {"directions", fitter.directions().size()},
                        {"condition_number", fitter.condition_number()},
                        {"tol", o.tol},
                        {"surface", use_grey ? "grey" : "labels"},
                        {"min_reentry_depth_vox", o.min_reentry_depth},
                        {"max_hidden_void", o.max_hidden_void},
                        {"max_reentry_depth_vox", o.max_reentry_depth},
                        {"blur_correction", !o.no_blur_correction}};
    if (use_grey) p["grey_levels"] = {mo.grey_void, mo.grey_grain};
    if (use_grey) p["point_spread_vox"] = mo.point_spread_vox;
    p["smooth_vox"] = mo.smooth_vox;
    content.parameters_json = p.dump();
    content.grains = std::move(grains);
    const auto& g = content.grains;
    double mean_degree = 0.0, mean_rms = 0.0;
    for (const auto& s : g) mean_degree += s.sh_degree, mean_rms += s.rms_error;
    spdlog::info("{} grains, d50 {:.4g} mm; SH degree {} ({} directions, condition {:.2f}), mean degree kept {:.1f} at "
                 "--tol {}, mean RMS residual {:.2f} % of the equivalent radius",
                 g.size(), content.psd.d50 * 1e3, fitter.degree(), fitter.directions().size(), fitter.condition_number(),
                 mean_degree / g.size(), o.tol, 100.0 * mean_rms / g.size());
    spdlog::info("flags: {} not star-shaped, {} unreliable fits, {} cut by the volume edge, {} small, {} missing --tol",
                 count_flag(g, shape_flag::not_star_shaped), count_flag(g, shape_flag::unreliable_fit),
                 count_flag(g, shape_flag::touches_edge), count_flag(g, shape_flag::small),
                 count_flag(g, shape_flag::tolerance_not_met));
    log_star_shape_summary(g, o.max_hidden_void, o.max_reentry_depth * std::min({labels.labels.voxel_size()[0],
                                                                                  labels.labels.voxel_size()[1],
                                                                                  labels.labels.voxel_size()[2]}));
    write_shapes_file(out.temp_path(), content, ctx.history());
    if (surfaces) write_surfaces(surfaces->temp_path(), o.surfaces.extension() == ".stl", g, content.degree, o.surface_subdivisions);
    io::commit_outputs({&out, surfaces ? &*surfaces : nullptr});
  });
}
