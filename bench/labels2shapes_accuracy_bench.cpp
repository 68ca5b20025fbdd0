// labels2shapes_accuracy_bench: SH shapes measured from ctsynth scans against the
// exact SH surfaces of the ground truth, for the fidelity knobs: SH degree (5 to 30) and voxels per
// d50 (8, 12, 16, 24), with the labels from ct2labels (what users get) and from the truth (the fit's
// own error); then the per-grain tolerance at degree 15. Errors per grain, medians over grains:
//   surface error   = RMS over the sphere of r_measured - r_true, over the equivalent radius
//                     (= ||c - c_true|| / sqrt(4 pi) / r_eq with the orthonormal basis);
//   invariant error = ||R_n - R_n,true|| over n >= 2, relative to R_0 (the shape part that tracking uses).
// Grains are matched to the truth by the true label under the measured centroid. Time: the
// measurement (labels2shapes' work) per grain on one thread. Charts: surface error against time.
//   build/bin/labels2shapes_accuracy_bench [--quick] [--work DIR]
// Scenes live in the work folder shared with ct2labels_accuracy_bench (default
// /tmp/graintwin_ct2labels_accuracy, k<K>_noise05); whichever bench runs first makes them.
#include <fmt/format.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>

#include "graintwin/core/geometry.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/io/volume_io.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/segment_grains.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "harness.hpp"

namespace fs = std::filesystem;
using namespace graintwin;
using namespace graintwin::shape;
namespace sg = schema::ground_truth;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;

struct Truth {
  Volume<std::uint32_t> labels;
  int degree = 0;
  std::vector<Eigen::VectorXd> coeffs;  // by true label - 1
  std::vector<double> volume;
};

Truth read_truth(const fs::path& p) {
  const io::H5File f = io::H5File::open(p);
  Truth t;
  t.labels = io::read_image_as<std::uint32_t>(f, schema::path::labels);
  t.degree = static_cast<int>(f.attr_int(sg::sh_coeffs, schema::attr::sh_degree).value());
  std::vector<hsize_t> dims;
  const auto c = f.read<double>(sg::sh_coeffs, &dims);
  for (hsize_t i = 0; i < dims[0]; ++i)
    t.coeffs.push_back(Eigen::Map<const Eigen::VectorXd>(c.data() + i * dims[1], static_cast<Eigen::Index>(dims[1])));
  t.volume = f.read<double>(sg::grain_volume);
  return t;
}

/// Makes (or reuses) a one-scan ctsynth scene; returns false if ctsynth failed.
bool make_scene(const fs::path& dir, double voxel) {
  if (fs::exists(dir / "truth_000.h5")) return true;
  const std::string cmd = fmt::format("{}/ctsynth {}/bench/scenes/ct2labels_accuracy.toml {} --voxel-size {:.6g}um --noise 0.05 --force -q",
                                      bench::bin_dir().string(), kSource, dir.string(), voxel * 1e6);
  std::cout << "generating " << dir << " (kept for later runs)" << std::endl;
  return std::system(cmd.c_str()) == 0;
}

struct Errors {
  double surface = 0.0, invariant = 0.0, ms_per_grain = 0.0, mean_degree = 0.0;
  std::size_t grains = 0;
};

Errors measure(const Volume<std::uint32_t>& labels, const Volume<std::uint16_t>* grey, const Truth& truth, int degree,
               double tol, bool use_grey) {
  const auto table = segment::grain_table(labels);
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> grains;
  for (const auto& g : table) grains.push_back({g.label, g.bbox});
  const ShFitter fitter(degree);
  MeasureOptions o;
  o.tol = tol;
  if (use_grey) {
    const GreyLevels levels = grey_levels(labels, *grey);
    o.source = SurfaceSource::grey;
    o.smooth_vox = 0.0;
    o.grey_void = levels.void_level;
    o.grey_grain = levels.grain_level;
  }
  omp_set_num_threads(1);
  std::vector<GrainShape> shapes;
  const double secs = bench::best_seconds(1, [&] { shapes = measure_grains(labels, grey, grains, fitter, o); });
  const int kmax = std::max(degree, truth.degree);
  std::vector<double> surface, invariant;
  Errors e;
  for (const GrainShape& g : shapes) {
    // The true grain under the measured centroid.
    const Vec3& vs = labels.voxel_size();
    const Vec3& org = labels.origin();
    const auto idx = [&](int axis_zyx, int xyz) {
      return static_cast<std::size_t>(std::lround((g.centroid[xyz] - org[axis_zyx]) / vs[axis_zyx]));
    };
    const std::uint32_t t = truth.labels(idx(0, 2), idx(1, 1), idx(2, 0));
    if (t == 0 || g.flags & shape_flag::touches_edge) continue;
    Eigen::VectorXd ours = Eigen::VectorXd::Zero(sh_count(kmax)), exact = Eigen::VectorXd::Zero(sh_count(kmax));
    ours.head(g.coeffs.size()) = g.coeffs;
    exact.head(truth.coeffs[t - 1].size()) = truth.coeffs[t - 1];
    const double r_eq = equivalent_radius(truth.volume[t - 1]);
    surface.push_back((ours - exact).norm() / std::sqrt(4.0 * std::numbers::pi) / r_eq);
    const Eigen::VectorXd ri = sh_invariants(ours, kmax), rt = sh_invariants(exact, kmax);
    invariant.push_back((ri.tail(kmax - 1) / ri[0] - rt.tail(kmax - 1) / rt[0]).norm());
    e.mean_degree += g.sh_degree;
  }
  e.grains = surface.size();
  e.surface = median(surface);
  e.invariant = median(invariant);
  e.ms_per_grain = 1e3 * secs / static_cast<double>(std::max<std::size_t>(1, shapes.size()));
  e.mean_degree /= static_cast<double>(std::max<std::size_t>(1, e.grains));
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  // The same scenes as ct2labels_accuracy_bench (same scene file and options): made once, used by both.
  fs::path work = "/tmp/graintwin_ct2labels_accuracy";
  if (!bench::parse_quick_work(argc, argv, quick, work)) {
    std::cerr << "usage: labels2shapes_accuracy_bench [--quick] [--work DIR]\n";
    return 2;
  }
  fs::create_directories(work);
  const double d50 = 0.551e-3;
  const std::vector<int> ks = quick ? std::vector<int>{16} : std::vector<int>{8, 12, 16, 24};
  const std::vector<int> degrees = quick ? std::vector<int>{5, 15} : std::vector<int>{5, 8, 10, 12, 15, 20, 25, 30};
  bench::Report report(
      "labels2shapes_accuracy_bench", "labels2shapes accuracy against ctsynth truth: SH degree and voxels per d50",
      "ctsynth scene bench/scenes/ct2labels_accuracy.toml (about 210 Ottawa-like sand grains, true SH degree 15, 5 % "
      "noise, blur 0.8 voxel) rendered at 8, 12, 16 and 24 voxels per d50. Labels from ct2labels with default settings "
      "(`ct2labels`) or the exact labels (`truth labels`); surfaces from the grey levels (`grey`, the pipeline's "
      "choice) or the smoothed labels (`labels`). Surface error: median over grains of the RMS radial difference "
      "from the true surface over the equivalent radius; invariant error: median of || R_n/R_0 - true || over "
      "n >= 2. Time: measurement per grain, one thread. Grains cut by the volume edge are left out.");
  std::ofstream csv(work / "labels2shapes_surface_vs_time.csv");
  csv << "series,label,x,y\n";
  for (int k : ks) {
    const fs::path dir = work / fmt::format("k{}_noise05", k);
    if (!make_scene(dir, d50 / k)) {
      std::cerr << "ctsynth failed for " << dir << "\n";
      return 1;
    }
    const Truth truth = read_truth(dir / "truth_000.h5");
    const io::H5File scan = io::H5File::open(dir / "scan_000.h5");
    const auto grey = io::read_image_as<std::uint16_t>(scan, schema::path::volume);
    omp_set_num_threads(omp_get_num_procs());
    const segment::SegmentResult seg = segment::segment_grains(grey, segment::SegmentOptions{});
    for (const auto& [source, labels, use_grey] :
         std::vector<std::tuple<std::string, const Volume<std::uint32_t>*, bool>>{
             {"ct2labels + grey", &seg.labels, true}, {"ct2labels + labels", &seg.labels, false},
             {"truth labels + labels", &truth.labels, false}}) {
      for (int degree : degrees) {
        const Errors e = measure(*labels, &grey, truth, degree, 0.0, use_grey);
        const std::string case_name = fmt::format("{} vox/d50, L = {}", k, degree);
        report.add({case_name, source, e.ms_per_grain * 1e-3 * e.grains, 0.0,
                    fmt::format("surface {:.2f} %, invariants {:.4f}, {:.2f} ms/grain, {} grains", 100 * e.surface,
                                e.invariant, e.ms_per_grain, e.grains)});
        // Cases without matched grains have no error to chart.
        if (e.grains > 0) csv << fmt::format("{} vox/d50 ({}),L={},{},{}\n", k, source, degree, e.ms_per_grain, e.surface);
        std::cout << case_name << " " << source << ": surface " << 100 * e.surface << " %, invariants " << e.invariant
                  << ", " << e.ms_per_grain << " ms/grain" << std::endl;
      }
    }
    for (double tol : {0.005, 0.01, 0.02, 0.05}) {
      const Errors e = measure(seg.labels, &grey, truth, 15, tol, true);
      report.add({fmt::format("{} vox/d50, L = 15, tol {}", k, tol), "ct2labels + grey", e.ms_per_grain * 1e-3 * e.grains, 0.0,
                  fmt::format("surface {:.2f} %, invariants {:.4f}, mean degree kept {:.1f}", 100 * e.surface, e.invariant,
                              e.mean_degree)});
    }
  }
  csv.close();
  if (quick) {
    std::cout << report.markdown("ct2labels + grey") << std::endl;
    return 0;
  }
  const std::string png = kSource + "/docs/img/labels2shapes_accuracy.png";
  bench::plot_xy(work / "labels2shapes_surface_vs_time.csv", png,
                 "labels2shapes: surface error against cost (points: SH degree L)",
                 "measurement time per grain (ms, one thread)", "median surface error / r_eq");
  report.publish("ct2labels + grey", kSource + "/docs/benchmarks.md");
  return 0;
}
