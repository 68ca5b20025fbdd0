// ct2labels: segment a CT volume into labelled grains (docs/methods.md, segmentation): denoise, threshold,
// EDT, markers, watershed of -EDT, fragments, grain table, sample cylinder and void ratio.
//   ct2labels scan_000.h5 labels_000.h5
//   ct2labels scan.h5 labels.h5 --d50 0.551mm --preview labels.png
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/resources.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/core/volume_ops.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/slices.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/segment/preview.hpp"
#include "graintwin/segment/segment_grains.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::segment;
using nlohmann::json;

namespace {

struct Options {
  std::string denoise = "gaussian";
  double sigma_vox = 0.4;
  std::optional<double> threshold;
  bool fill_holes = true;
  double open_vox = 0.0;
  std::string markers = "h-maxima";
  std::optional<double> h;
  std::optional<double> min_distance_vox;
  std::string d50;
  int connectivity = 26;
  std::optional<double> min_volume_vox;
  std::string fragments = "merge";
  bool remove_edge_grains = false;
  std::string region = "auto";
  std::string cylinder;
  fs::path preview;
};

SegmentOptions to_segment_options(const Options& o) {
  SegmentOptions s;
  if (o.denoise == "none") s.denoise = Denoise::none;
  else if (o.denoise == "median") s.denoise = Denoise::median;
  else if (o.denoise == "gaussian") s.denoise = Denoise::gaussian;
  else throw UsageError("--denoise '" + o.denoise + "' is not none, median or gaussian");
  s.gaussian_sigma_vox = o.sigma_vox;
  s.threshold = o.threshold;
  s.fill_holes = o.fill_holes;
  s.open_radius_vox = o.open_vox;
  if (o.markers == "h-maxima") s.markers = MarkerMethod::h_maxima;
  else if (o.markers == "peaks") s.markers = MarkerMethod::peaks;
  else throw UsageError("--markers '" + o.markers + "' is not h-maxima or peaks");
  s.h_vox = o.h;
  s.min_distance_vox = o.min_distance_vox;
  if (!o.d50.empty()) s.expected_d50_m = parse_length_m(o.d50, "--d50");
  s.connectivity = connectivity_from_int(o.connectivity);
  s.min_volume_vox = o.min_volume_vox;
  if (o.fragments == "merge") s.fragments = FragmentPolicy::merge;
  else if (o.fragments == "remove") s.fragments = FragmentPolicy::remove;
  else throw UsageError("--fragments '" + o.fragments + "' is not merge or remove");
  s.remove_edge_grains = o.remove_edge_grains;
  if (o.region == "auto") s.region_mode = RegionMode::auto_cylinder;
  else if (o.region == "volume") s.region_mode = RegionMode::whole_volume;
  else if (o.region == "cylinder") s.region_mode = RegionMode::given_cylinder;
  else throw UsageError("--region '" + o.region + "' is not auto, volume or cylinder");
  if (s.region_mode == RegionMode::given_cylinder) {
    const auto parts = split(o.cylinder, ',');
    if (parts.size() != 3) throw UsageError("--region cylinder needs --cylinder X,Y,R (centre and radius, e.g. 1.5mm,1.5mm,1.4mm)");
    // The centre is a position (any sign, the volume's origin is arbitrary); the radius a length.
    s.region.centre_x = cli::parse_length_in(parts[0], "--cylinder centre x", -1.0, 1.0);
    s.region.centre_y = cli::parse_length_in(parts[1], "--cylinder centre y", -1.0, 1.0);
    s.region.radius = cli::parse_length_in(parts[2], "--cylinder radius", 1e-6, 1.0);
  } else if (!o.cylinder.empty()) {
    throw UsageError("--cylinder is only used with --region cylinder; add it or drop --cylinder");
  }
  if (!o.preview.empty() && o.preview.extension() != ".png")
    throw UsageError("--preview " + o.preview.string() + " must be a .png file");
  validate(s);
  return s;
}

json parameters_json(const SegmentOptions& s, const SegmentResult& r) {
  json j;
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
  j["fragments"] = s.fragments == FragmentPolicy::merge ? "merge" : "remove";
  j["fragments_merged"] = r.fragments.merged;
  j["fragments_removed"] = r.fragments.removed;
  j["remove_edge_grains"] = s.remove_edge_grains;
  j["edge_grains_removed"] = r.edge_grains_removed;
  j["region"] = to_string(r.region_mode);
  j["grains"] = r.grains.size();
  j["void_ratio"] = r.void_ratio.e;
  return j;
}

// Mid axial slice (z) and mid vertical section (y, z upwards) of the grey input with the labels.
void write_preview(const fs::path& path, const io::H5File& input, const Volume<std::uint32_t>& labels, double threshold) {
  const Shape3& s = labels.shape();
  const std::size_t zm = s[0] / 2, ym = s[1] / 2;
  std::vector<float> grey_z(s[1] * s[2]), grey_y(s[0] * s[2]);
  input.read_box<float>(schema::path::volume, {zm, 0, 0}, {1, s[1], s[2]}, grey_z.data());
  input.read_box<float>(schema::path::volume, {0, ym, 0}, {s[0], 1, s[2]}, grey_y.data());
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
  io::write_png_rgb(path, pic.width, pic.height, pic.rgb);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("ct2labels",
                 "Segment a CT volume (kind=volume) into labelled grains (kind=labels): denoise (Gaussian of sigma "
                 "0.4 voxel by default, or 3x3x3 median), threshold (Otsu inside the sample cylinder unless "
                 "--threshold), hole filling, optional opening, exact Euclidean distance transform in physical "
                 "units, markers from the h-maxima of the distance map (h chosen from the image: the middle of the widest plateau of the marker count against h, "
                 "printed) or from peaks a minimum distance apart, marker watershed of -EDT inside the solid, "
                 "fragments below a minimum volume merged into their neighbour, labels numbered in raster order. "
                 "Also finds the sample cylinder and the void ratio inside it, and writes the grain table (label, "
                 "voxels, volume, centroid, bounding box, touches_edge).");
  Options o;
  fs::path input, output;
  auto& app = tool.cli();
  tool.add_input("volume", input, "CT volume (.h5, kind=volume; uint8, uint16 or float32)");
  tool.add_output("labels", output, "Labels file to write (.h5, kind=labels)");
  app.add_option("--denoise", o.denoise, "none, median (3x3x3) or gaussian")->capture_default_str();
  using cli::closed, cli::above, cli::number_in;
  app.add_option("--sigma-vox", o.sigma_vox, "Gaussian denoising: sigma in voxels")
      ->check(number_in(above(0, 20, "voxels")))->capture_default_str();
  app.add_option("--threshold", o.threshold, "Grey level; solid is strictly above it (default: Otsu)")
      ->check(cli::finite_number());
  app.add_flag("--fill-holes,!--no-fill-holes", o.fill_holes, "Fill cavities enclosed in the solid")
      ->capture_default_str();
  app.add_option("--open-vox", o.open_vox, "Morphological opening radius in voxels (0 = none)")
      ->check(number_in(closed(0, 50, "voxels")))->capture_default_str();
  app.add_option("--markers", o.markers, "h-maxima or peaks")->capture_default_str();
  app.add_option("--h", o.h, "h-maxima depth in voxels (default: chosen from the image and printed)")
      ->check(number_in(closed(0, 1000, "voxels")));
  app.add_option("--min-distance-vox", o.min_distance_vox,
                 "peaks: minimum distance between markers in voxels (default: the reference grain radius)")
      ->check(number_in(above(0, 1000, "voxels")));
  app.add_option("--d50", o.d50,
                 "Expected median grain diameter (e.g. 0.551mm); bounds the automatic h and the fragment size "
                 "(default: estimated from the distance map)")
      ->check(cli::length_in(1e-6, 0.1));
  app.add_option("--connectivity", o.connectivity, "6, 18 or 26")->check(CLI::IsMember({6, 18, 26}))->capture_default_str();
  app.add_option("--min-volume-vox", o.min_volume_vox,
                 "Labels smaller than this are fragments (default: 5 % of a sphere of the reference radius, at least 2)")
      ->check(number_in(closed(0, 1e9, "voxels")));
  app.add_option("--fragments", o.fragments, "merge (into the neighbour with the largest boundary) or remove")
      ->capture_default_str();
  app.add_flag("--remove-edge-grains", o.remove_edge_grains, "Drop grains cut by a face of the volume");
  app.add_option("--region", o.region,
                 "Where the void ratio is measured: auto (sample cylinder found in the mask), cylinder (--cylinder) "
                 "or volume (the whole volume, for crops from inside a sample)")
      ->capture_default_str();
  app.add_option("--cylinder", o.cylinder,
                 "X,Y,R: centre (x, y; any sign, within 1 m) and radius (1 um to 1 m) of the sample, lengths with units");
  app.add_option("--preview", o.preview, "Also write a PNG: mid axial slice and mid vertical section with the labels");
  tool.set_examples({"ct2labels scan_000.h5 labels_000.h5",
                     "ct2labels scan.h5 labels.h5 --d50 0.551mm --preview labels.png",
                     "ct2labels crop.h5 labels.h5 --region volume --markers peaks --min-distance-vox 3"});

  return tool.run(argc, argv, [&](cli::RunContext& ctx) {
    SegmentOptions options = to_segment_options(o);
    if (!o.preview.empty()) io::check_output_allowed(o.preview, ctx.force());
    const io::H5File in = io::open_kind(input, schema::kind::volume, "pass a scan (ctsynth or volconvert output)");
    ctx.add_input_history(in);
    const io::ImageHeader header = io::read_image_header(in, schema::path::volume);
    const double unit = std::min({header.voxel_size[0], header.voxel_size[1], header.voxel_size[2]});
    if (options.denoise == Denoise::gaussian)
      check_kernel_fits(std::ceil(3.0 * options.gaussian_sigma_vox), header.shape,
                        fmt::format("--sigma-vox {:g} (a Gaussian cut at 3 sigma)", options.gaussian_sigma_vox),
                        "give a smaller --sigma-vox");
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> preview;
    if (!o.preview.empty()) preview.emplace(o.preview, ctx.force());

    AnyVolume grey = io::read_image(in, schema::path::volume);
    const Shape3 shape = header.shape;
    spdlog::info("{}: {} x {} x {} voxels ({})", input.string(), shape[0], shape[1], shape[2],
                 dtype_name(dtype_of_any(grey)));
    const auto progress = ctx.progress("segment", 11);
    auto started = std::chrono::steady_clock::now();
    std::string current;
    options.on_step = [&](const std::string& step) {
      const auto now = std::chrono::steady_clock::now();
      if (!current.empty())
        spdlog::debug("{}: {:.2f} s", current, std::chrono::duration<double>(now - started).count());
      current = step;
      started = now;
      progress->advance(1);
      throw_if_interrupted();
    };
    SegmentResult r;
    try {
      r = std::visit(
          [&](auto& v) -> SegmentResult {
            using T = typename std::decay_t<decltype(v)>::value_type;
            if constexpr (std::is_same_v<T, std::uint32_t>)
              throw UsageError(input.string() + " is uint32; segment uint8, uint16 or float32 scans (volconvert --cast uint16)");
            else
              return segment_grains(std::move(v), options);
          },
          grey);
    } catch (Error& e) {
      e.add_context("while segmenting " + input.string());
      throw;
    }
    progress->done();
    if (r.h_proposal && r.marker_parameter_automatic && r.marker_method == MarkerMethod::h_maxima &&
        !r.h_proposal->plateau_found)
      spdlog::warn("h = {:.3g} voxels (the floor): the marker count has no plateau against h (grains of {:.1f} voxels "
                   "radius may be too small or too fused to separate); check the labels, or give --h or --markers peaks",
                   r.marker_parameter_vox, r.reference_radius_m / unit);
    else if (r.h_proposal && r.marker_parameter_automatic && r.marker_method == MarkerMethod::h_maxima)
      spdlog::info("h = {:.3g} voxels chosen from the image: marker count stable ({} to {}) for h in [{:.3g}, {:.3g}] "
                   "voxels; reference grain radius {:.1f} voxels ({})",
                   r.marker_parameter_vox, r.h_proposal->markers_at_hi, r.h_proposal->markers_at_lo,
                   r.h_proposal->plateau_lo_vox, r.h_proposal->plateau_hi_vox,
                   r.reference_radius_m / unit, r.h_proposal->radius_estimated ? "estimated from the distance map" : "d50 / 2");
    spdlog::info("threshold {:.6g} ({}), solid fraction {:.3f}; {} markers -> {} grains ({} fragments merged, {} removed{})",
                 r.threshold, r.threshold_from_otsu ? "Otsu" : "given", r.solid_fraction, r.markers, r.grains.size(),
                 r.fragments.merged, r.fragments.removed,
                 options.remove_edge_grains ? fmt::format(", {} edge grains removed", r.edge_grains_removed) : "");
    if (r.region_mode == RegionMode::whole_volume)
      spdlog::info("void ratio {:.4f} over the whole volume", r.void_ratio.e);
    else
      spdlog::info("void ratio {:.4f} inside the cylinder centred ({:.4g}, {:.4g}) mm of radius {:.4g} mm",
                   r.void_ratio.e, r.region.centre_x * 1e3, r.region.centre_y * 1e3, r.region.radius * 1e3);

    std::string parameters = parameters_json(options, r).dump();
    LabelsFile content{std::move(r.labels), std::move(r.grains), {r.region, r.void_ratio}, std::move(parameters)};
    write_labels_file(out.temp_path(), content, ctx.history());
    if (preview) write_preview(preview->temp_path(), in, content.labels, r.threshold);
    io::commit_outputs({&out, preview ? &*preview : nullptr});
  });
}
