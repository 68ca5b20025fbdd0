#include "graintwin/shape/scan_shapes.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/stl.hpp"
#include "graintwin/io/vtk.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_surface.hpp"

namespace graintwin::shape {

namespace {

constexpr std::array<EnumName<SurfaceChoice>, 3> kSurfaceChoiceNames{
    {{SurfaceChoice::automatic, "auto"}, {SurfaceChoice::grey, "grey"}, {SurfaceChoice::labels, "labels"}}};
constexpr std::array<EnumName<SurfaceSource>, 2> kSurfaceSourceNames{
    {{SurfaceSource::grey, "grey"}, {SurfaceSource::labels, "labels"}}};

std::size_t count_flag(const std::vector<GrainShape>& g, std::uint8_t bit) {
  return static_cast<std::size_t>(std::count_if(g.begin(), g.end(), [&](const GrainShape& s) { return s.flags & bit; }));
}

/// The surface lies where the grey level crosses the middle of the void and grain levels: they must
/// be in order and inside the scan's own range, or every surface sits somewhere the data never says.
template <class T>
void check_grey_levels(const MeasureOptions& mo, const Volume<T>& grey, const std::string& grey_name) {
  const auto [lo, hi] = std::minmax_element(grey.values().begin(), grey.values().end());
  const double low = lo == grey.values().end() ? 0.0 : static_cast<double>(*lo), high = hi == grey.values().end() ? 0.0 : static_cast<double>(*hi);
  const auto outside = [&](double v) { return v < low || v > high; };
  if (outside(mo.grey_void) || outside(mo.grey_grain))
    throw UsageError(fmt::format("--grey-void {:.6g} and --grey-grain {:.6g} must lie within the grey values of {} ({:.6g} to {:.6g}); "
                                 "give the void and grain levels of that scan, or leave them out to take its medians",
                                 mo.grey_void, mo.grey_grain, grey_name, low, high));
  if (!(mo.grey_grain > mo.grey_void))
    throw UsageError(fmt::format("the grain grey level {:.6g} must exceed the void grey level {:.6g} (--grey-grain, --grey-void); "
                                 "give the levels of {} in that order, or leave them out to take its medians",
                                 mo.grey_grain, mo.grey_void, grey_name));
}

/// The grains measured on the grey surface of `grey`: its grey levels and point spread first,
/// each the given one or measured, and logged.
template <class T>
std::vector<GrainShape> measure_on_grey(const SegmentedScan& scan, const Volume<T>& grey, const ShFitter& fitter,
                                        const ShapesParams& params, MeasureOptions& mo,
                                        const std::function<std::function<void(double)>()>& progress) {
  if constexpr (std::is_floating_point_v<T>)
    for (float v : grey.values())
      if (!std::isfinite(v)) throw DataError(scan.grey_name + " holds NaN or infinite grey values; use --surface labels");
  const GreyLevels levels = grey_levels(*scan.labels, grey);
  mo.grey_void = params.grey_void.value_or(levels.void_level);
  mo.grey_grain = params.grey_grain.value_or(levels.grain_level);
  spdlog::info("grey levels: void {:.6g}, grain {:.6g}{}", mo.grey_void, mo.grey_grain,
               params.grey_void || params.grey_grain ? " (given)" : " (medians of interior voxels)");
  check_grey_levels(mo, grey, scan.grey_name);
  mo.point_spread_vox = params.point_spread_vox ? *params.point_spread_vox
                                                : estimate_point_spread(*scan.labels, grey, scan.grains, fitter, mo);
  spdlog::info("point spread {:.3g} voxel{}", mo.point_spread_vox,
               params.point_spread_vox ? " (given)" : " (edge width of up to 64 grains, less the voxel's own)");
  return measure_grains(*scan.labels, &grey, scan.grains, fitter, mo, progress());
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

void log_shapes(const ShapesFile& content, const ShFitter& fitter, const ShapesParams& params, double voxel_m) {
  const auto& g = content.grains;
  double mean_degree = 0.0, mean_rms = 0.0;
  for (const auto& s : g) mean_degree += s.sh_degree, mean_rms += s.rms_error;
  spdlog::info("{} grains, d50 {:.4g} mm; SH degree {} ({} directions, condition {:.2f}), mean degree kept {:.1f} at "
               "--tol {}, mean RMS residual {:.2f} % of the equivalent radius",
               g.size(), content.psd.d50 * 1e3, fitter.degree(), fitter.directions().size(), fitter.condition_number(),
               mean_degree / g.size(), params.tol, 100.0 * mean_rms / g.size());
  spdlog::info("flags: {} not star-shaped, {} unreliable fits, {} cut by the volume edge, {} small, {} missing --tol",
               count_flag(g, shape_flag::not_star_shaped), count_flag(g, shape_flag::unreliable_fit),
               count_flag(g, shape_flag::touches_edge), count_flag(g, shape_flag::small),
               count_flag(g, shape_flag::tolerance_not_met));
  log_star_shape_summary(g, params.max_hidden_void, params.max_reentry_depth_vox * voxel_m);
}

}  // namespace

SurfaceChoice parse_surface_choice(const std::string& name) { return parse_enum(kSurfaceChoiceNames, name, "--surface"); }

const char* surface_source_name(SurfaceSource source) { return enum_name(kSurfaceSourceNames, source); }

SurfaceSource surface_source(SurfaceChoice choice, bool have_scan) {
  if (choice == SurfaceChoice::grey && !have_scan) throw UsageError("--surface grey needs the scan: labels2shapes LABELS VOLUME SHAPES");
  return choice == SurfaceChoice::grey || (choice == SurfaceChoice::automatic && have_scan) ? SurfaceSource::grey
                                                                                          : SurfaceSource::labels;
}

ShFitter shapes_fitter(const ShapesParams& params) {
  // The fitter holds directions x coefficients matrices: check that before building them.
  const MemoryLimit memory = memory_limit();
  const double per_direction = ShFitter::memory_bytes(params.degree, 1);
  check_memory(ShFitter::memory_bytes(params.degree, params.directions), "labels2shapes",
               fmt::format("{} sample directions x {} SH coefficients (degree {})",
                           ShFitter::directions_for(params.degree, params.directions), sh_count(params.degree), params.degree),
               fmt::format("give --directions of at most {:.0f} or a lower --degree", std::floor(memory.bytes / per_direction)),
               memory);
  ShFitter fitter(params.degree, params.directions);
  if (!fitter.warning().empty()) spdlog::warn("{}", fitter.warning());
  return fitter;
}

ShapesFile scan_shapes(const SegmentedScan& scan, const ShFitter& fitter, const ShapesParams& params,
                       const std::function<std::function<void(double)>(const std::string&)>& progress) {
  if (scan.grains.empty())
    throw DataError(scan.labels_name + " holds no grain; check the segmentation (ct2labels) that made it");
  const SurfaceSource source = surface_source(params.surface, scan.grey != nullptr);
  MeasureOptions mo;
  mo.source = source;
  mo.smooth_vox = params.smooth_vox.value_or(source == SurfaceSource::grey ? 0.0 : 0.7);
  mo.tol = params.tol;
  mo.min_reentry_depth_vox = params.min_reentry_depth_vox;
  mo.max_hidden_void_fraction = params.max_hidden_void;
  mo.max_reentry_depth_vox = params.max_reentry_depth_vox;
  mo.correct_blur = params.blur_correction;
  // The display starts with the measurement, after the checks that may refuse the scan.
  const auto grains_progress = [&] { return progress ? progress("grains") : std::function<void(double)>(); };
  ShapesFile content;
  try {
    if (source == SurfaceSource::labels) {
      content.grains = measure_grains<std::uint8_t>(*scan.labels, nullptr, scan.grains, fitter, mo, grains_progress());
    } else {
      content.grains = std::visit(
          [&](const auto& g) -> std::vector<GrainShape> {
            using T = typename std::decay_t<decltype(g)>::value_type;
            if constexpr (std::is_same_v<T, std::uint32_t>)
              throw UsageError(scan.grey_name + " is uint32; pass the uint8, uint16 or float32 scan");
            else
              return measure_on_grey(scan, g, fitter, params, mo, grains_progress);
          },
          *scan.grey);
    }
  } catch (Error& e) {
    e.add_context("while measuring the grains of " + scan.labels_name);
    throw;
  }

  content.degree = fitter.degree();
  content.psd = size_distribution(content.grains);
  nlohmann::json p = {{"degree", fitter.degree()},
                      {"requested_degree", params.degree},
                      {"directions", fitter.directions().size()},
                      {"condition_number", fitter.condition_number()},
                      {"tol", params.tol},
                      {"surface", surface_source_name(source)},
                      {"min_reentry_depth_vox", params.min_reentry_depth_vox},
                      {"max_hidden_void", params.max_hidden_void},
                      {"max_reentry_depth_vox", params.max_reentry_depth_vox},
                      {"blur_correction", params.blur_correction}};
  if (source == SurfaceSource::grey) p["grey_levels"] = {mo.grey_void, mo.grey_grain};
  if (source == SurfaceSource::grey) p["point_spread_vox"] = mo.point_spread_vox;
  p["smooth_vox"] = mo.smooth_vox;
  content.parameters_json = p.dump();
  const Vec3& voxel = scan.labels->voxel_size();
  log_shapes(content, fitter, params, std::min({voxel[0], voxel[1], voxel[2]}));
  return content;
}

void write_shape_surfaces(const std::filesystem::path& path, bool stl, const std::vector<GrainShape>& grains, int degree,
                          int subdivisions) {
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

}  // namespace graintwin::shape
