// labels2shapes_bench: (1) SH fitting of 16 000 grains at degree 15 through the
// shared pseudo-inverse against a per-grain least-squares solve (design matrix + Householder QR per
// grain, what the CT-FDEM paper did), one core, and the same against the degree; (2) the whole
// per-grain measurement (field, isosurface, rays, fit) of about 16 000 grains on one core and on
// all cores.   build/bin/labels2shapes_bench [--quick]   (--quick: fewer grains, prints only)
#include <fmt/format.h>
#include <omp.h>

#include <Eigen/QR>
#include <cmath>
#include <random>

#include "graintwin/segment/labels.hpp"
#include "graintwin/shape/grain_measure.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/sh_fitter.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::shape;

namespace {

/// Radii of `n` grains along the fitter's directions: a few random sand shapes, scaled and noisy.
std::vector<Eigen::VectorXd> sample_radii(const ShFitter& fitter, std::size_t n, std::mt19937_64& rng) {
  SandShapeParams sp;
  sp.degree = std::min(15, fitter.degree());
  sp.roughness_from_degree = std::min(sp.roughness_from_degree, sp.degree + 1);
  std::vector<Eigen::VectorXd> shapes;
  for (int i = 0; i < 32; ++i) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(sh_count(fitter.degree()));
    c.head(sh_count(sp.degree)) = random_sand_coeffs(sp, rng);
    shapes.push_back(fitter.design() * c);
  }
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> size(0.15e-3, 0.5e-3);
  std::vector<Eigen::VectorXd> radii(n);
  for (std::size_t i = 0; i < n; ++i) {
    radii[i] = shapes[i % shapes.size()] * size(rng);
    for (auto& r : radii[i]) r *= 1.0 + noise(rng);
  }
  return radii;
}

/// The paper's way: a design matrix and a least-squares solve per grain.
Eigen::VectorXd per_grain_solve(int degree, const std::vector<Eigen::Vector3d>& dirs, const Eigen::VectorXd& r) {
  const Eigen::MatrixXd a = sh_design_matrix(degree, dirs);
  return a.householderQr().solve(r);
}

/// A label image of touching-free spheres on a jittered lattice: n^3 grains of radius ~r voxels.
Volume<std::uint32_t> sphere_lattice(int n, double r, double pitch, std::mt19937_64& rng) {
  const std::size_t side = static_cast<std::size_t>(std::ceil(n * pitch));
  Volume<std::uint32_t> l({side, side, side}, {27.5e-6, 27.5e-6, 27.5e-6});
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uint32_t label = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const double cz = (i + 0.5) * pitch + u(rng), cy = (j + 0.5) * pitch + u(rng), cx = (k + 0.5) * pitch + u(rng);
        const double rr = r * (1.0 + 0.1 * u(rng));
        ++label;
        for (long z = long(cz - rr); z <= long(cz + rr) + 1; ++z)
          for (long y = long(cy - rr); y <= long(cy + rr) + 1; ++y)
            for (long x = long(cx - rr); x <= long(cx + rr) + 1; ++x)
              if (z >= 0 && y >= 0 && x >= 0 && z < long(side) && y < long(side) && x < long(side) &&
                  std::hypot(z - cz, y - cy, x - cx) <= rr)
                l(z, y, x) = label;
      }
  return l;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const std::size_t n_grains = quick ? 2000 : 16000;
  const std::size_t n_direct_at_15 = quick ? 50 : 200;  // per-grain solves timed, then scaled to n_grains
  std::mt19937_64 rng(7);
  bench::Report report(
      "labels2shapes_bench", "SH fitting: shared pseudo-inverse vs a least-squares solve per grain",
      fmt::format("Radii of {} grains along 2 (L+1)^2 Fibonacci directions (32 random sand shapes, scaled, 1 % noise); "
                  "graintwin: `ShFitter::fit` (one matrix-vector product per grain after one SVD, whose cost is "
                  "included); reference: the CT-FDEM paper's per-grain least squares (design matrix from GSL + "
                  "Householder QR, Eigen), timed on {} grains at L = 15 (fewer at higher L) and scaled to all. One thread. Then the whole per-grain "
                  "measurement (`measure_grains`: moments, smoothed field, isosurface, 512 rays, fit) of a lattice of "
                  "sphere grains about 15 voxels across.",
                  n_grains, n_direct_at_15));
  omp_set_num_threads(1);
  for (int degree : {5, 10, 15, 20, 30}) {
    if (quick && degree > 15) continue;
    // A QR solve costs ~L^4: fewer grains are timed at high degrees.
    const std::size_t n_direct = std::clamp<std::size_t>(static_cast<std::size_t>(n_direct_at_15 * std::pow(15.0 / degree, 4)),
                                                         10, n_direct_at_15);
    ShFitter fitter(5);
    const double t_setup = bench::best_seconds(1, [&] { fitter = ShFitter(degree); });
    const auto radii = sample_radii(fitter, n_grains, rng);
    std::vector<Eigen::VectorXd> ours(n_grains);
    const double t_fit = bench::best_seconds(3, [&] {
      for (std::size_t i = 0; i < n_grains; ++i) ours[i] = fitter.fit(radii[i]);
    });
    double worst = 0.0;
    const double t_direct = bench::best_seconds(1, [&] {
      for (std::size_t i = 0; i < n_direct; ++i) {
        const Eigen::VectorXd c = per_grain_solve(degree, fitter.directions(), radii[i]);
        worst = std::max(worst, (c - ours[i]).norm() / c.norm());
      }
    });
    const std::string name = fmt::format("{} grains, L = {}", n_grains, degree);
    report.add({name, "graintwin (shared pseudo-inverse)", t_setup + t_fit, 0.0,
                fmt::format("{:.1f} us per grain + {:.3f} s setup", 1e6 * t_fit / n_grains, t_setup)});
    report.add({name, "per-grain QR solve (paper)", t_direct * n_grains / n_direct, 0.0,
                fmt::format("{:.2f} ms per grain; coefficients agree to {:.1e}", 1e3 * t_direct / n_direct, worst)});
    fmt::print("L = {}: {:.3f} s vs {:.1f} s\n", degree, t_setup + t_fit, t_direct * n_grains / n_direct);
  }

  const int per_side = quick ? 12 : 25;  // 25^3 = 15 625 grains
  const auto labels = sphere_lattice(per_side, 7.0, 16.0, rng);
  const auto table = segment::grain_table(labels);
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> grains;
  for (const auto& g : table) grains.push_back({g.label, g.bbox});
  const ShFitter fitter(15);
  const std::string name = fmt::format("measure {} grains, {}^3 labels", grains.size(), labels.shape()[0]);
  for (int threads : {1, omp_get_num_procs()}) {
    omp_set_num_threads(threads);
    const double t = bench::best_seconds(1, [&] { measure_grains<float>(labels, nullptr, grains, fitter, MeasureOptions{}); });
    report.add({name, fmt::format("graintwin, {} thread{}", threads, threads > 1 ? "s" : ""), t, 0.0,
                fmt::format("{:.2f} ms per grain", 1e3 * t / grains.size())});
    fmt::print("{}: {} threads {:.2f} s\n", name, threads, t);
  }
  if (quick)  // a smoke run: print, leave docs/benchmarks.md alone
    fmt::print("{}\n", report.markdown("per-grain QR solve (paper)"));
  else
    report.publish("per-grain QR solve (paper)", std::string(GRAINTWIN_SOURCE_DIR) + "/docs/benchmarks.md");
  return 0;
}
