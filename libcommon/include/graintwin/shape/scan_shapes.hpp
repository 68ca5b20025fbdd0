#pragma once
// labels2shapes' stage (docs/labels2shapes.md): the grains of a segmented scan measured and fitted
// (grain_measure), the content of a kind=shapes file out: the surface source chosen, the grey
// levels and the scanner's point spread taken from the scan unless given, the size distribution
// and the run's parameters; and the reconstructed SH surfaces for viewers.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sh_fitter.hpp"
#include "graintwin/shape/shapes_file.hpp"

namespace graintwin::shape {

/// The sub-voxel surface asked for (--surface): automatic is grey when the scan is given, else labels.
enum class SurfaceChoice { automatic, grey, labels };
/// "auto", "grey" or "labels"; UsageError "--surface 'x' is not auto, grey or labels" otherwise.
SurfaceChoice parse_surface_choice(const std::string& name);
/// "grey" or "labels", as /shapes/parameters records the surface.
const char* surface_source_name(SurfaceSource source);
/// The surface of a run with the scan (`have_scan`) or without it; UsageError when grey is asked
/// for without the scan.
SurfaceSource surface_source(SurfaceChoice choice, bool have_scan);

/// What labels2shapes is asked: the fit, the surface and the star-shape test. Lengths in voxels.
struct ShapesParams {
  int degree = 15;                          ///< largest SH degree
  int directions = 0;                       ///< sample directions per grain; 0 = twice the coefficients
  double tol = 0.01;                        ///< per-grain degree (MeasureOptions::tol)
  SurfaceChoice surface = SurfaceChoice::automatic;
  std::optional<double> smooth_vox;         ///< default: 0.7 for the labels surface, 0 for the grey one
  std::optional<double> grey_void, grey_grain;  ///< default: grey_levels of the scan
  std::optional<double> point_spread_vox;   ///< default: estimate_point_spread on the scan
  double min_reentry_depth_vox = 0.5;
  double max_hidden_void = 0.01;
  double max_reentry_depth_vox = 1.0;
  bool blur_correction = true;
};

/// The fitter of params.degree over params.directions, once its matrices are known to fit in the
/// memory this process may use (UsageError with the numbers and the largest --directions that
/// fits otherwise); a lowered degree is logged as a warning.
ShFitter shapes_fitter(const ShapesParams& params);

/// A segmented scan as the stage reads it.
struct SegmentedScan {
  const Volume<std::uint32_t>* labels = nullptr;
  /// Each grain's label and half-open box (z0, y0, x0, z1, y1, x1) in `labels`, in label order.
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> grains;
  const AnyVolume* grey = nullptr;  ///< the scan that was segmented (same shape), or null
  std::string labels_name, grey_name;  ///< the files, for messages
};

/// Every grain of `scan` measured and fitted with `fitter` (shapes_fitter(params)), with the size
/// distribution and the parameters JSON, as a kind=shapes file holds them; the grey levels, the
/// point spread and a summary of the grains, their flags and the star-shape test are logged.
/// `progress` (may be empty) makes the progress callback of a named step ("grains", the fraction
/// measured) when the step starts. UsageError for grey levels outside
/// the scan's range or out of order, a uint32 scan, or the grey surface without a scan; DataError
/// for a scan without grains or with non-finite grey values; errors carry the labels file's name.
ShapesFile scan_shapes(const SegmentedScan& scan, const ShFitter& fitter, const ShapesParams& params,
                       const std::function<std::function<void(double)>(const std::string&)>& progress = {});

/// The reconstructed SH surfaces of `grains` (coefficients of `degree`), each an icosphere of
/// `subdivisions` displaced to r(direction), as one mesh: binary STL (a triangle soup) when `stl`,
/// else VTK XML PolyData (ParaView, cell data `label` and `flags`).
void write_shape_surfaces(const std::filesystem::path& path, bool stl, const std::vector<GrainShape>& grains, int degree,
                          int subdivisions);

}  // namespace graintwin::shape
