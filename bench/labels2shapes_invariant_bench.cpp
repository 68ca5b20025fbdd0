// labels2shapes_invariant_bench: how well labels2shapes recovers the shape invariants of a grain
// whose exact answer is known, against voxels per diameter, point-spread blur and noise, with and
// without the edge-blur correction; and the share of grains its star-shape test flags on the
// bundled scans.
//   Ellipsoids 1.25 : 1 : 0.8 (I2/I0 = 0.1141) rendered by ctsynth's library (exact partial volumes,
//   Gaussian point spread, Gaussian noise), labels from the mid-grey threshold, in 6 orientations
//   and sub-voxel positions; errors are means over them (and the largest |error|). Time: measurement
//   per grain on one thread, CPU and wall (the machine is shared, CPU time is the steadier figure).
//   Flag shares: ct2labels then labels2shapes with the pipeline's parameters, as child processes.
//   build/bin/labels2shapes_invariant_bench [--quick] [--work DIR]
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>

#include "graintwin/core/statistics.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/synth/render.hpp"
#include "harness.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::shape;
namespace sg = schema::ground_truth;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;
constexpr double kVoxel = 1e-5;
const Eigen::Vector3d kAxes(1.25, 1.0, 0.8);  // times the equivalent radius (product 1)

struct Scene {
  double diameter_vox = 20, blur = 0.8, noise = 0.03;
};

struct Method {
  std::string name;
  bool grey = true, correct = true;
};

struct Result {
  double i2_error = 0.0, i2_worst = 0.0, volume_error = 0.0, cpu_ms = 0.0, wall_ms = 0.0, sigma_vox = 0.0;
};

/// I2 / I0 of the exact ellipsoid, fitted on the measurement's own directions and degree.
double exact_i2_over_i0(const Eigen::Vector3d& abc, const ShFitter& fitter) {
  Eigen::VectorXd r(static_cast<Eigen::Index>(fitter.directions().size()));
  std::transform(fitter.directions().begin(), fitter.directions().end(), r.begin(),
                 [&](const Eigen::Vector3d& d) { return 1.0 / (d.array() / abc.array()).matrix().norm(); });
  const Eigen::VectorXd inv = sh_invariants(fitter.fit(r), fitter.degree());
  return inv[2] / inv[0];
}

std::vector<Result> run_scene(const Scene& scene, const std::vector<Method>& methods, const ShFitter& fitter, int orientations) {
  const Eigen::Vector3d abc = kAxes * (0.5 * scene.diameter_vox * kVoxel);
  const RadialTable table = ellipsoid_table(abc[0], abc[1], abc[2], 96);
  const double exact = exact_i2_over_i0(abc, fitter), exact_volume = 4.0 / 3.0 * std::numbers::pi * abc.prod();
  const auto n = static_cast<std::size_t>(std::ceil(2.0 * abc[0] / kVoxel + 6.0 * scene.blur + 8.0));
  std::vector<Result> out(methods.size());
  for (int rep = 0; rep < orientations; ++rep) {
    synth::PlacedGrain grain;
    grain.shape = &table;
    // Sub-voxel offsets and orientations spread by the golden ratio, the same for every scene.
    const double f = std::fmod(0.618034 * (rep + 1), 1.0);
    grain.position = Eigen::Vector3d(n / 2.0 + f, n / 2.0 + std::fmod(f * 3, 1.0), n / 2.0 + std::fmod(f * 7, 1.0)) * kVoxel;
    grain.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4 + 2.1 * rep, Eigen::Vector3d(1 + f, 2 - rep % 3, 3 * f - 1).normalized()));
    grain.label = 1;
    const auto images = synth::render_grains({grain}, {n, n, n}, {kVoxel, kVoxel, kVoxel}, {0, 0, 0}, synth::RenderParams{});
    synth::ScannerParams sp;
    sp.blur_sigma_vox = scene.blur;
    sp.noise = scene.noise;
    sp.seed = static_cast<std::uint64_t>(rep + 1);
    const Volume<std::uint16_t> scan = synth::simulate_scan(images.fraction, nullptr, sp);
    const double void_level = sp.grey_void * sp.uint16_scale + sp.uint16_offset;
    const double grain_level = sp.grey_grain * sp.uint16_scale + sp.uint16_offset;
    Volume<std::uint32_t> labels(scan.shape(), scan.voxel_size());
    for (std::size_t i = 0; i < labels.size(); ++i) labels.values()[i] = scan.values()[i] > 0.5 * (void_level + grain_level);
    const auto grains = segment::grain_table(labels);
    for (std::size_t m = 0; m < methods.size(); ++m) {
      MeasureOptions o;
      o.correct_blur = methods[m].correct;
      if (methods[m].grey) {
        o.source = SurfaceSource::grey;
        o.smooth_vox = 0.0;
        o.grey_void = void_level;
        o.grey_grain = grain_level;
      }
      const std::clock_t c0 = std::clock();
      const auto t0 = std::chrono::steady_clock::now();
      const GrainShape g = measure_grain(labels, &scan, 1u, grains.at(0).bbox, fitter, o);
      out[m].cpu_ms += 1e3 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC / orientations;
      out[m].wall_ms += 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / orientations;
      const double e = g.invariants[2] / g.invariants[0] / exact - 1.0;
      out[m].i2_error += e / orientations;
      out[m].i2_worst = std::max(out[m].i2_worst, std::abs(e));
      out[m].volume_error += (fitter.moments(g.coeffs).volume / exact_volume - 1.0) / orientations;
      out[m].sigma_vox += g.edge_sigma / kVoxel / orientations;
    }
  }
  return out;
}

/// sand_small's first scan against ctsynth's exact SH surfaces: medians over grains of the SH volume
/// and I0 over the true ones, I2/I0 error and the invariant distance (n >= 2), full degree 15.
struct PackedErrors {
  double volume = 0.0, i0 = 0.0, i2 = 0.0, distance = 0.0, cpu_ms = 0.0;
};

PackedErrors packed_errors(const Volume<std::uint32_t>& labels, const Volume<std::uint16_t>& scan, const io::H5File& truth,
                           const ShFitter& fitter, const MeasureOptions& o) {
  std::vector<hsize_t> dims;
  const auto coeffs = truth.read<double>(sg::sh_coeffs, &dims);
  const auto volume = truth.read<double>(sg::grain_volume);
  const auto centroid = truth.read<double>(sg::grain_centroid);
  const auto table = segment::grain_table(labels);
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> boxes;
  for (const auto& g : table) boxes.push_back({g.label, g.bbox});
  const std::clock_t c0 = std::clock();
  const auto shapes = measure_grains(labels, &scan, boxes, fitter, o);
  PackedErrors e;
  e.cpu_ms = 1e3 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC / static_cast<double>(shapes.size());
  std::vector<double> vol, i0, i2, dist;
  for (const GrainShape& g : shapes) {
    // The true grain: the nearest true centroid (labels may be ct2labels', numbered otherwise).
    std::size_t k = 0;
    double best = INFINITY;
    for (std::size_t t = 0; t < volume.size(); ++t) {
      const double d = (g.centroid - Eigen::Vector3d(centroid[3 * t], centroid[3 * t + 1], centroid[3 * t + 2])).norm();
      if (d < best) best = d, k = t;
    }
    const Eigen::VectorXd tc = Eigen::Map<const Eigen::VectorXd>(coeffs.data() + k * dims[1], static_cast<Eigen::Index>(dims[1]));
    const Eigen::VectorXd ti = sh_invariants(tc, fitter.degree());
    vol.push_back(fitter.moments(g.coeffs).volume / volume[k]);
    i0.push_back(g.invariants[0] / ti[0]);
    i2.push_back(g.invariants[2] / g.invariants[0] / (ti[2] / ti[0]) - 1.0);
    dist.push_back((g.invariants.tail(fitter.degree() - 1) / g.invariants[0] - ti.tail(fitter.degree() - 1) / ti[0]).norm());
  }
  e.volume = median(vol);
  e.i0 = median(i0);
  e.i2 = median(i2);
  e.distance = median(dist);
  return e;
}

/// ct2labels and labels2shapes on a bundled scan with the pipeline's parameters; the shares of
/// grains with each star-shape flag and the measurement's time per grain.
struct FlagShares {
  std::size_t grains = 0, not_star = 0, unreliable = 0, by_void = 0;
  double seconds = 0.0;
};

FlagShares flag_shares(const std::string& series, const fs::path& work) {
  const fs::path scan = fs::path(kSource) / "sample_volumes" / series / "scan_000.h5";
  const fs::path own = fs::path(kSource) / "pipelines/params" / series / "ct2labels.toml";
  const fs::path ct_params = fs::exists(own) ? own : fs::path(kSource) / "pipelines/params/ct2labels.toml";
  const fs::path labels = work / (series + "_labels.h5"), shapes = work / (series + "_shapes.h5");
  const std::string bin = bench::bin_dir().string();
  bench::run_child(series, "ct2labels", {bin + "/ct2labels", scan.string(), labels.string(), "--config", ct_params.string(), "--force", "-q"});
  const bench::Row row = bench::run_child(series, "labels2shapes",
                                          {bin + "/labels2shapes", labels.string(), scan.string(), shapes.string(), "--config",
                                           kSource + "/pipelines/params/labels2shapes.toml", "--force", "-q"});
  const ShapesFile f = read_shapes_file(shapes);
  FlagShares s;
  s.grains = f.grains.size();
  s.seconds = row.seconds;
  for (const GrainShape& g : f.grains) {
    s.not_star += (g.flags & shape_flag::not_star_shaped) != 0;
    s.unreliable += (g.flags & shape_flag::unreliable_fit) != 0;
    s.by_void += g.hidden_void_fraction > 0.01;
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  fs::path work = "/tmp/graintwin_labels2shapes_invariants";
  if (!bench::parse_quick_work(argc, argv, quick, work)) {
    std::cerr << "usage: labels2shapes_invariant_bench [--quick] [--work DIR]\n";
    return 2;
  }
  fs::create_directories(work);
  omp_set_num_threads(1);
  const ShFitter fitter(15);
  const int orientations = quick ? 2 : 6;
  const std::vector<Method> methods{{"grey, corrected", true, true}, {"grey, raw iso-surface", true, false},
                                    {"labels, corrected", false, true}, {"labels, raw iso-surface", false, false}};
  bench::Report report(
      "labels2shapes_invariant_bench", "labels2shapes: invariants of blurred ellipsoids, and star-shape flags on the bundled scans",
      fmt::format("Ellipsoids with axes 1.25 : 1 : 0.8 (exact I2/I0 = {:.4f}) rendered with ctsynth's library (exact partial "
                  "volumes, Gaussian point spread `blur` voxels, Gaussian noise as a share of the contrast), labels from the "
                  "mid-grey threshold, {} orientations and sub-voxel positions per case; SH degree 15, 512 rays. `grey`: "
                  "surfaces from the grey levels (the pipeline's default), `labels`: smoothed labels (sigma 0.7); "
                  "`corrected`: the edge-blur correction (default), `raw`: --no-blur-correction. I2/I0 error: mean (and "
                  "largest |error|) of I2/I0 over the exact value; volume error: SH volume over the exact volume. Time: "
                  "measurement per grain, one thread, CPU (user+sys) and wall; the machine was shared. Then ct2labels and "
                  "labels2shapes (pipeline parameters) on the bundled scans: grains flagged by the star-shape test.",
                  exact_i2_over_i0(kAxes, fitter), orientations));
  std::ofstream csv(work / "invariant_error.csv");
  csv << "series,label,x,y\n";
  std::vector<std::pair<std::string, Scene>> scenes;
  for (double d : quick ? std::vector<double>{8, 20} : std::vector<double>{8, 12, 16, 20, 30})
    scenes.push_back({fmt::format("{:.0f} vox/diameter, blur 0.8, noise 3 %", d), Scene{d, 0.8, 0.03}});
  if (!quick) {
    for (double b : {0.0, 0.5, 1.2, 1.6}) scenes.push_back({fmt::format("20 vox/diameter, blur {}, noise 3 %", b), Scene{20, b, 0.03}});
    for (double n : {0.0, 0.06, 0.10}) scenes.push_back({fmt::format("20 vox/diameter, blur 0.8, noise {:.0f} %", 100 * n), Scene{20, 0.8, n}});
  }
  for (const auto& [name, scene] : scenes) {
    const std::vector<Result> r = run_scene(scene, methods, fitter, orientations);
    for (std::size_t m = 0; m < methods.size(); ++m) {
      report.add({name, methods[m].name, r[m].wall_ms * 1e-3, 0.0,
                  fmt::format("I2/I0 {:+.2f} % (worst {:.2f} %), volume {:+.2f} %, edge sigma {:.2f} vox, {:.2f} ms CPU / {:.2f} ms "
                              "wall per grain",
                              100 * r[m].i2_error, 100 * r[m].i2_worst, 100 * r[m].volume_error, r[m].sigma_vox, r[m].cpu_ms,
                              r[m].wall_ms)});
      if (scene.blur == 0.8 && scene.noise == 0.03) {
        // One line per method (no comma in a CSV field); log axes, so |error| is floored at 0.01 %.
        std::string series = methods[m].name;
        series.erase(series.find(','), 1);
        csv << fmt::format("{},,{},{}\n", series, scene.diameter_vox, std::max(0.01, 100 * std::abs(r[m].i2_error)));
      }
      std::cout << name << " | " << methods[m].name << ": I2/I0 " << 100 * r[m].i2_error << " %, volume " << 100 * r[m].volume_error
                << " %, " << r[m].cpu_ms << " ms CPU" << std::endl;
    }
  }
  csv.close();
  for (const std::string series : {"sand_small", "soil_crop"}) {
    const FlagShares s = flag_shares(series, work);
    const auto pct = [&](std::size_t k) { return 100.0 * static_cast<double>(k) / static_cast<double>(std::max<std::size_t>(1, s.grains)); };
    report.add({series + " (ct2labels + labels2shapes)", "star-shape flags", s.seconds, 0.0,
                fmt::format("{} grains: {} ({:.1f} %) not star-shaped, {} ({:.1f} %) unreliable fit, {} enclose > 1 % void; "
                            "labels2shapes {:.2f} ms wall per grain (2 threads)",
                            s.grains, s.not_star, pct(s.not_star), s.unreliable, pct(s.unreliable), s.by_void,
                            1e3 * s.seconds / static_cast<double>(std::max<std::size_t>(1, s.grains)))});
    std::cout << series << ": " << s.not_star << " not star, " << s.unreliable << " unreliable of " << s.grains << std::endl;
  }
  // Packed grains: sand_small's first scan with the exact labels and with ct2labels' (from the
  // flag run above), against the true SH surfaces.
  {
    const fs::path dir = fs::path(kSource) / "sample_volumes/sand_small";
    const io::H5File truth = io::H5File::open(dir / "truth_000.h5");
    const auto exact_labels = io::read_image_as<std::uint32_t>(truth, schema::path::labels);
    const auto scan = io::read_image_as<std::uint16_t>(io::H5File::open(dir / "scan_000.h5"), schema::path::volume);
    const segment::LabelsFile ct = segment::read_labels_file(work / "sand_small_labels.h5");
    for (const auto& [labels_name, labels] :
         std::vector<std::pair<std::string, const Volume<std::uint32_t>*>>{{"exact labels", &exact_labels}, {"ct2labels", &ct.labels}}) {
      const auto table = segment::grain_table(*labels);
      std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> boxes;
      for (const auto& g : table) boxes.push_back({g.label, g.bbox});
      MeasureOptions grey;
      grey.source = SurfaceSource::grey;
      grey.smooth_vox = 0.0;
      const GreyLevels levels = grey_levels(*labels, scan);
      grey.grey_void = levels.void_level;
      grey.grey_grain = levels.grain_level;
      const double psf = estimate_point_spread(*labels, scan, boxes, fitter, grey);
      struct Variant {
        std::string name;
        MeasureOptions o;
      };
      std::vector<Variant> variants;
      for (const bool neighbours : {false, true})
        for (const bool correct : {false, true}) {
          MeasureOptions o = grey;
          o.point_spread_vox = neighbours ? psf : 0.0;
          o.correct_blur = correct;
          variants.push_back({fmt::format("grey, {}, {}", neighbours ? "neighbours taken off" : "neighbours' light kept",
                                          correct ? "corrected" : "raw iso-surface"),
                              o});
        }
      for (const bool correct : {false, true}) {
        MeasureOptions o;
        o.correct_blur = correct;
        variants.push_back({fmt::format("labels, {}", correct ? "corrected" : "raw iso-surface"), o});
      }
      for (const Variant& v : variants) {
        const PackedErrors e = packed_errors(*labels, scan, truth, fitter, v.o);
        report.add({fmt::format("sand_small scan 0, {} ({} grains; point spread {:.2f} vox)", labels_name, boxes.size(), psf), v.name,
                    0.0, 0.0,
                    fmt::format("median SH volume / true {:.4f}, I0 / true {:.4f}, I2/I0 {:+.2f} %, invariant distance {:.4f}, "
                                "{:.2f} ms CPU per grain",
                                e.volume, e.i0, 100 * e.i2, e.distance, e.cpu_ms)});
        std::cout << labels_name << " | " << v.name << ": volume " << e.volume << ", distance " << e.distance << std::endl;
      }
    }
  }
  if (quick) {
    std::cout << report.markdown("grey, corrected") << std::endl;
    return 0;
  }
  bench::plot_xy(work / "invariant_error.csv", kSource + "/docs/img/labels2shapes_invariants.png",
                 "labels2shapes: |I2/I0 error| of blurred ellipsoids (blur 0.8, noise 3 %)", "voxels per equivalent diameter",
                 "|I2/I0 error| (%), mean over orientations");
  report.publish("grey, corrected", kSource + "/docs/benchmarks.md");
  return 0;
}
