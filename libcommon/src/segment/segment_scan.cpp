#include "graintwin/segment/segment_scan.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/preview.hpp"

namespace graintwin::segment {

namespace {

/// The steps segment_grains announces through on_step, for the fraction done.
constexpr double kSteps = 11.0;

/// The automatic h, the threshold, the grains and the void ratio, as the run's summary.
void log_segmentation(const SegmentResult& r, const SegmentOptions& options, double voxel_m) {
  const bool automatic_h = r.h_proposal && r.marker_parameter_automatic && r.marker_method == MarkerMethod::h_maxima;
  if (automatic_h && !r.h_proposal->plateau_found)
    spdlog::warn("h = {:.3g} voxels (the floor): the marker count has no plateau against h (grains of {:.1f} voxels "
                 "radius may be too small or too fused to separate); check the labels, or give --h or --markers peaks",
                 r.marker_parameter_vox, r.reference_radius_m / voxel_m);
  else if (automatic_h)
    spdlog::info("h = {:.3g} voxels chosen from the image: marker count stable ({} to {}) for h in [{:.3g}, {:.3g}] "
                 "voxels; reference grain radius {:.1f} voxels ({})",
                 r.marker_parameter_vox, r.h_proposal->markers_at_hi, r.h_proposal->markers_at_lo,
                 r.h_proposal->plateau_lo_vox, r.h_proposal->plateau_hi_vox,
                 r.reference_radius_m / voxel_m, r.h_proposal->radius_estimated ? "estimated from the distance map" : "d50 / 2");
  spdlog::info("threshold {:.6g} ({}), solid fraction {:.3f}; {} markers -> {} grains ({} fragments merged, {} removed{})",
               r.threshold, r.threshold_from_otsu ? "Otsu" : "given", r.solid_fraction, r.markers, r.grains.size(),
               r.fragments.merged, r.fragments.removed,
               options.remove_edge_grains ? fmt::format(", {} edge grains removed", r.edge_grains_removed) : "");
  if (r.region_mode == RegionMode::whole_volume)
    spdlog::info("void ratio {:.4f} over the whole volume", r.void_ratio.e);
  else
    spdlog::info("void ratio {:.4f} inside the cylinder centred ({:.4g}, {:.4g}) mm of radius {:.4g} mm",
                 r.void_ratio.e, r.region.centre_x * 1e3, r.region.centre_y * 1e3, r.region.radius * 1e3);
}

}  // namespace

std::string segmentation_parameters_json(const SegmentOptions& s, const SegmentResult& r) {
  nlohmann::json j;
  j["denoise"] = to_string(s.denoise);
  if (s.denoise == Denoise::gaussian) j["sigma_vox"] = s.gaussian_sigma_vox;
  j["threshold"] = r.threshold;
  j["threshold_method"] = r.threshold_from_otsu ? "otsu" : "given";
  j["fill_holes"] = s.fill_holes;
  j["open_vox"] = s.open_radius_vox;
  j["solid_fraction"] = r.solid_fraction;
  j["markers"] = to_string(r.marker_method);
  j[r.marker_method == MarkerMethod::h_maxima ? "h_vox" : "min_distance_vox"] = r.marker_parameter_vox;
  j["marker_parameter_automatic"] = r.marker_parameter_automatic;
  j["marker_count"] = r.markers;
  if (r.h_proposal) {
    const HProposal& p = *r.h_proposal;
    j["h_proposal"] = {{"h_vox", p.h_vox},
                       {"markers", p.markers},
                       {"plateau_found", p.plateau_found},
                       {"plateau_vox", {p.plateau_lo_vox, p.plateau_hi_vox}},
                       {"markers_at_plateau_ends", {p.markers_at_lo, p.markers_at_hi}},
                       {"regional_maxima", p.regional_maxima}};
  }
  j["reference_radius_m"] = r.reference_radius_m;
  j["reference_radius_estimated"] = s.expected_d50_m <= 0.0;
  j["connectivity"] = static_cast<int>(s.connectivity);
  j["min_volume_vox"] = r.min_volume_vox;
  j["fragments"] = to_string(s.fragments);
  j["fragments_merged"] = r.fragments.merged;
  j["fragments_removed"] = r.fragments.removed;
  j["remove_edge_grains"] = s.remove_edge_grains;
  j["edge_grains_removed"] = r.edge_grains_removed;
  j["region"] = to_string(r.region_mode);
  j["grains"] = r.grains.size();
  j["void_ratio"] = r.void_ratio.e;
  return j.dump();
}

ScanSegmentation segment_scan(const io::H5File& scan, SegmentOptions options,
                              const std::function<std::function<void(double)>(const std::string&)>& progress) {
  const std::string name = scan.path().string();
  const io::ImageHeader header = io::read_image_header(scan, schema::path::volume);
  const double voxel_m = std::min({header.voxel_size[0], header.voxel_size[1], header.voxel_size[2]});
  if (options.denoise == Denoise::gaussian)
    check_kernel_fits(std::ceil(3.0 * options.gaussian_sigma_vox), header.shape,
                      fmt::format("--sigma-vox {:g} (a Gaussian cut at 3 sigma)", options.gaussian_sigma_vox),
                      "give a smaller --sigma-vox");

  AnyVolume grey = io::read_image(scan, schema::path::volume);
  const Shape3& shape = header.shape;
  spdlog::info("{}: {} x {} x {} voxels ({})", name, shape[0], shape[1], shape[2], dtype_name(dtype_of_any(grey)));
  std::function<void(double)> steps_done = progress ? progress("segment") : nullptr;
  auto started = std::chrono::steady_clock::now();
  std::string current;
  double steps = 0.0;
  options.on_step = [&](const std::string& step) {
    const auto now = std::chrono::steady_clock::now();
    if (!current.empty()) spdlog::debug("{}: {:.2f} s", current, std::chrono::duration<double>(now - started).count());
    current = step;
    started = now;
    if (steps_done) steps_done(++steps / kSteps);
    throw_if_interrupted();
  };
  SegmentResult r;
  try {
    r = std::visit(
        [&](auto& v) -> SegmentResult {
          using T = typename std::decay_t<decltype(v)>::value_type;
          if constexpr (std::is_same_v<T, std::uint32_t>)
            throw UsageError(name + " is uint32; segment uint8, uint16 or float32 scans (volconvert --cast uint16)");
          else
            return segment_grains(std::move(v), options);
        },
        grey);
  } catch (Error& e) {
    e.add_context("while segmenting " + name);
    throw;
  }
  if (steps_done) steps_done(1.0);
  steps_done = nullptr;  // the display ends before the summary
  log_segmentation(r, options, voxel_m);

  std::string parameters = segmentation_parameters_json(options, r);
  return {LabelsFile{std::move(r.labels), std::move(r.grains), {r.region, r.void_ratio}, std::move(parameters)}, r.threshold};
}

void write_segmentation_preview(const std::filesystem::path& png, const io::H5File& scan, const Volume<std::uint32_t>& labels,
                                double threshold) {
  const Shape3& s = labels.shape();
  const std::size_t zm = s[0] / 2, ym = s[1] / 2;
  std::vector<float> grey_z(s[1] * s[2]), grey_y(s[0] * s[2]);
  scan.read_box<float>(schema::path::volume, {zm, 0, 0}, {1, s[1], s[2]}, grey_z.data());
  scan.read_box<float>(schema::path::volume, {0, ym, 0}, {s[0], 1, s[2]}, grey_y.data());
  std::vector<std::uint32_t> lab_z(&labels(zm, 0, 0), &labels(zm, 0, 0) + s[1] * s[2]), lab_y(s[0] * s[2]);
  std::vector<float> flipped(s[0] * s[2]);
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t x = 0; x < s[2]; ++x) {
      const std::size_t row = s[0] - 1 - z;  // z upwards in the picture
      lab_y[row * s[2] + x] = labels(z, ym, x);
      flipped[row * s[2] + x] = grey_y[z * s[2] + x];
    }
  // Grey window: the whole range of the two slices, which keeps void, membrane and grain apart.
  const auto [lo, hi] = std::minmax_element(grey_z.begin(), grey_z.end());
  const double g_lo = std::min<double>(*lo, threshold), g_hi = std::max<double>(*hi, threshold);
  const RgbImage pic = side_by_side({overlay_labels(grey_z, lab_z, s[1], s[2], g_lo, g_hi),
                                     overlay_labels(flipped, lab_y, s[0], s[2], g_lo, g_hi)},
                                    8);
  io::write_png_rgb(png, pic.width, pic.height, pic.rgb);
}

}  // namespace graintwin::segment
