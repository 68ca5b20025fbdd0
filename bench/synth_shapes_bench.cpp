// synth_shapes_bench: shape statistics of ctsynth's grain families over 200 grains each (the
// smooth SH "sand" family and the angular family at their defaults): sphericity, aspect ratio,
// the RMS of the radius in SH degrees 8-15 (of the mean radius; roundness and roughness), the
// degree-15 fit's RMS miss (what lies above degree 15: sharp edges and corners), the smallest normal-to-radial cosine, and the time to make a
// grain.   build/bin/synth_shapes_bench [--quick]
#include <fmt/format.h>

#include <cmath>
#include <ctime>
#include <iostream>
#include <string>

#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/synth/grains.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::synth;

namespace {
const std::string kSource = GRAINTWIN_SOURCE_DIR;

struct MeanSd {
  double sum = 0.0, sum2 = 0.0, lo = HUGE_VAL, hi = -HUGE_VAL;
  int n = 0;
  void add(double x) {
    sum += x;
    sum2 += x * x;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    ++n;
  }
  std::string text(int digits) const {
    const double m = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - m * m));
    return fmt::format("{:.{}f} +- {:.{}f} ({:.{}f}-{:.{}f})", m, digits, sd, digits, lo, digits, hi, digits);
  }
};

// RMS over the sphere of the radius' degree 8..L part, in % of the mean radius:
// sqrt(sum_{n>=8} D_n^2) / D_0 with D_n the rotation invariants (orthonormal basis): bumps
// live there, form (n = 2) does not.
double high_degree_rms(const Eigen::VectorXd& coeffs, int degree) {
  const Eigen::VectorXd d = shape::sh_invariants(coeffs, degree);
  double high = 0.0;
  for (int n = 8; n <= degree; ++n) high += d[n] * d[n];
  return 100.0 * std::sqrt(high) / d[0];
}
}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const int count = quick ? 40 : 200;
  const double voxel = 27.5e-6, diameter = 0.551e-3;  // 20 voxels per grain, as in the bundled sand series
  bench::Report report("synth_shapes", "ctsynth grain families: shape statistics",
                       fmt::format("{} grains per family, each of volume-equivalent diameter {:.3g} mm tabulated at "
                                   "{:.3g} um voxels (20 per diameter), default parameters, SH degree 15. Figures: "
                                   "mean +- standard deviation (min-max). Sphericity and aspect ratio from the radial "
                                   "table (Wadell; inertia-equivalent ellipsoid). High-degree RMS: the RMS of the "
                                   "radius' SH degrees 8-15, in % of the mean radius (a roundness and roughness proxy: "
                                   "bumps live there, form does not). Fit miss: RMS of the exact radius minus its "
                                   "degree-15 fit, of the radius: what lies above degree 15, sharp edges and corners "
                                   "(the sand family is its own fit). Normal cosine: the smallest cosine between the "
                                   "surface normal and the radial direction. Seconds: CPU time (all threads) per grain, "
                                   "on a machine shared with other jobs. The angular family's grains are all "
                                   "star-shaped about their centroid (no non-star grains are generated).",
                                   count, diameter * 1e3, voxel * 1e6));
  // The families at their defaults, and the angular one with fewer facets (sharper corners).
  struct Family {
    std::string name;
    GrainShape shape;
    int min_facets = 8, max_facets = 20;
  };
  for (const Family& family : {Family{"sand", GrainShape::sand}, Family{"angular", GrainShape::angular},
                               Family{"angular, facets 5,10", GrainShape::angular, 5, 10}}) {
    GrainSetParams gp;
    gp.shape = family.shape;
    gp.angular.min_facets = family.min_facets;
    gp.angular.max_facets = family.max_facets;
    gp.voxel_size = voxel;
    gp.seed = 2026;
    const std::vector<double> diameters(static_cast<std::size_t>(count), diameter);
    GrainSet set;
    const std::clock_t c0 = std::clock();
    set = make_grains(gp, diameters);
    const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    MeanSd sphericity, aspect, high, fit, cosine;
    for (std::size_t i = 0; i < set.tables.size(); ++i) {
      sphericity.add(set.stats[i].sphericity);
      aspect.add(set.stats[i].aspect_ratio);
      high.add(high_degree_rms(set.coeffs_body.row(static_cast<Eigen::Index>(i)).transpose(), set.sh_degree));
      fit.add(set.sh_fit_rms.empty() ? 0.0 : 100.0 * set.sh_fit_rms[i]);
      cosine.add(set.tables[i].min_normal_cosine());
    }
    bench::Row row;
    row.case_name = fmt::format("{} grains", count);
    row.implementation = family.name;
    row.seconds = cpu / count;
    row.note = fmt::format("sphericity {}; aspect ratio {}; high-degree RMS {} %; fit miss {} % of r; normal cosine {}",
                           sphericity.text(3), aspect.text(2), high.text(2), fit.text(2), cosine.text(2));
    report.add(row);
  }
  report.publish("sand", kSource + "/docs/benchmarks.md");
}
