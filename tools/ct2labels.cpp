// ct2labels: segment a CT volume into labelled grains (docs/methods.md, segmentation): denoise, threshold,
// EDT, markers, watershed of -EDT, fragments, grain table, sample cylinder and void ratio.
//   ct2labels scan_000.h5 labels_000.h5
//   ct2labels scan.h5 labels.h5 --d50 0.551mm --preview labels.png
#include <optional>

#include "graintwin/cli/option_checks.hpp"
#include "graintwin/cli/tool.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/io/atomic_output.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/segment_scan.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::segment;

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

/// The command line as the segmentation's options: the names parsed, the cylinder's lengths read.
SegmentOptions to_segment_options(const Options& o) {
  SegmentOptions s;
  s.denoise = parse_denoise(o.denoise);
  s.gaussian_sigma_vox = o.sigma_vox;
  s.threshold = o.threshold;
  s.fill_holes = o.fill_holes;
  s.open_radius_vox = o.open_vox;
  s.markers = parse_marker_method(o.markers);
  s.h_vox = o.h;
  s.min_distance_vox = o.min_distance_vox;
  if (!o.d50.empty()) s.expected_d50_m = parse_length_m(o.d50, "--d50");
  s.connectivity = connectivity_from_int(o.connectivity);
  s.min_volume_vox = o.min_volume_vox;
  s.fragments = parse_fragment_policy(o.fragments);
  s.remove_edge_grains = o.remove_edge_grains;
  s.region_mode = parse_region_mode(o.region);
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
    const SegmentOptions options = to_segment_options(o);
    if (!o.preview.empty()) io::check_output_allowed(o.preview, ctx.force());
    const io::H5File in = io::open_kind(input, schema::kind::volume, "pass a scan (ctsynth or volconvert output)");
    ctx.add_input_history(in);
    io::AtomicOutput out(output, ctx.force());
    std::optional<io::AtomicOutput> preview;
    if (!o.preview.empty()) preview.emplace(o.preview, ctx.force());

    const ScanSegmentation s = segment_scan(in, options, [&](const std::string& step) { return ctx.progress_callback(step); });
    write_labels_file(out.temp_path(), s.labels, ctx.history());
    if (preview) write_segmentation_preview(preview->temp_path(), in, s.labels.labels, s.threshold);
    io::commit_outputs({&out, preview ? &*preview : nullptr});
  });
}
