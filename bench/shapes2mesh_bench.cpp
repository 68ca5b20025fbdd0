// shapes2mesh_bench: what a grain mesh costs and how close it is to the exact surface, against the
// element size (elements per diameter) and order, for the two 10-node curvings; chart of volume
// error against elements per grain (docs/img/shapes2mesh_accuracy.png); and whole models of
// sand_small's reference scan on 1 and 2 threads (gmsh serialised) when runs/ has its shapes.
//   shapes2mesh_bench [--quick]
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "graintwin/mesh/grain_mesher.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "harness.hpp"

using namespace graintwin;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;

/// A sand-like test grain (the anchors' shape, radius about 0.3 mm): r = R (1 + 0.075 (3 cos^2 t - 1)
/// + 0.08 sin^2 t cos 2p + 0.04 sin^3 t cos 3p + 0.02 cos 5t), fitted exactly at degree 8.
shape::GrainShape test_grain(double radius) {
  const int degree = 8;
  shape::GrainShape g;
  g.label = 1;
  g.coeffs = shape::sh_fit(
      [&](const Eigen::Vector3d& d) {
        const double ct = d.z(), st = std::sqrt(std::max(0.0, 1 - ct * ct)), p = std::atan2(d.y(), d.x()), t = std::acos(ct);
        return radius * (1 + 0.075 * (3 * ct * ct - 1) + 0.08 * st * st * std::cos(2 * p) + 0.04 * st * st * st * std::cos(3 * p) +
                         0.02 * std::cos(5 * t));
      },
      degree, 2000);
  const shape::ShMoments mom = shape::sh_moments(g.coeffs, degree);
  g.volume = mom.volume;
  g.equivalent_diameter = std::cbrt(6 * g.volume / M_PI);
  g.surface_area = 4 * M_PI * radius * radius * 1.05;
  g.semi_axes = Eigen::Vector3d::Constant(radius);
  return g;
}

/// Largest distance of the mesh's boundary triangle centroids from the exact SH surface / radius.
double surface_error(const mesh::TetMesh& m, const shape::GrainShape& g, double radius) {
  const int degree = static_cast<int>(std::lround(std::sqrt(double(g.coeffs.size())))) - 1;
  double worst = 0;
  for (const auto& t : mesh::boundary_triangles(m)) {
    const Eigen::Vector3d c = (m.nodes[t[0]] + m.nodes[t[1]] + m.nodes[t[2]]) / 3.0 - g.centroid;
    worst = std::max(worst, std::abs(c.norm() - shape::sh_radius(g.coeffs, degree, c.normalized())));
  }
  return worst / radius;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const double radius = 0.3e-3;
  const shape::GrainShape grain = test_grain(radius);
  const mesh::ShSurfaceBasis basis(4, 8);
  bench::Report report("shapes2mesh_bench", "shapes2mesh: cost and accuracy of grain meshes",
                       "One sand-like SH grain (radius 0.3 mm, degree 8, exact volume from the SH moments) meshed through "
                       "mesh::mesh_grain at fixed elements per diameter: seconds in gmsh (best of 3), elements, surface nodes, "
                       "volume error against the exact SH volume, largest distance of boundary triangle centroids from the "
                       "exact surface (/ radius), min gamma and min Jacobian ratio. " + bench::machine_summary());
  std::ofstream csv(kSource + "/docs/img/shapes2mesh_accuracy.csv");
  csv << "series,label,x,y\n";
  struct Variant {
    const char* name;
    int order;
    bool snap;
  };
  const std::vector<Variant> variants = {{"tet4", 1, true}, {"tet10 snap", 2, true}, {"tet10 gmsh", 2, false}};
  const std::vector<double> per_diameter = quick ? std::vector<double>{3, 6} : std::vector<double>{3, 4, 6, 8, 12};
  for (const Variant& v : variants)
    for (double n : per_diameter) {
      mesh::GrainMeshOptions o;
      o.order = v.order;
      o.snap_to_sh = v.snap;
      o.size.elements_per_diameter = n;
      mesh::GrainMeshResult r;
      double best = 1e300;
      for (int rep = 0; rep < (quick ? 1 : 3); ++rep) {
        r = mesh::mesh_grain(grain, basis, nullptr, {}, o);
        best = std::min(best, r.gmsh.seconds);
      }
      const double volume_error = r.quality.volume / grain.volume - 1;
      const double surf = surface_error(r.mesh, grain, radius);
      report.add({fmt::format("{} per diameter", n), v.name, best, 0,
                  fmt::format("{} elements, {} surface nodes, volume error {:+.3f} %, surface error {:.4f} R, gamma min {:.2f} "
                              "mean {:.2f}, min det J ratio {:.2f}{}",
                              r.quality.elements, r.quality.surface_nodes, 100 * volume_error, surf, r.quality.min_gamma,
                              r.quality.mean_gamma, r.quality.min_jacobian_ratio, r.gmsh.optimized ? ", optimize(HighOrder) ran" : "")});
      csv << v.name << "," << n << "," << r.quality.elements << "," << std::max(std::abs(volume_error), 1e-6) << "\n";
    }
  // The default (contact-driven) size.
  for (const Variant& v : {variants[0], variants[1]}) {
    mesh::GrainMeshOptions o;
    o.order = v.order;
    const auto r = mesh::mesh_grain(grain, basis, nullptr, {}, o);
    report.add({"automatic (250 surface nodes)", v.name, r.gmsh.seconds, 0,
                fmt::format("{:.1f} per diameter, {} elements, {} surface nodes, volume error {:+.3f} %", grain.equivalent_diameter / r.size.h,
                            r.quality.elements, r.quality.surface_nodes, 100 * (r.quality.volume / grain.volume - 1))});
  }
  csv.close();
  bench::plot_xy(kSource + "/docs/img/shapes2mesh_accuracy.csv", kSource + "/docs/img/shapes2mesh_accuracy.png",
                 "shapes2mesh: volume error against cost", "elements per grain",
                 "|volume error| (labels: elements per diameter)");

  // Whole models: sand_small's reference scan, if the pipeline has produced its shapes.
  const std::filesystem::path shapes = kSource + "/runs/sand_small/scan_000/shapes.h5";
  if (!quick && std::filesystem::exists(shapes)) {
    const std::string tool = (bench::bin_dir() / "shapes2mesh").string();
    for (int threads : {1, 2})
      report.add(bench::run_child("sand_small scan 0 (210 grains), 10-node, snap", fmt::format("shapes2mesh -j {}", threads),
                                  {tool, shapes.string(), "/tmp/shapes2mesh_bench_model.h5", "--force", "-q", "-j",
                                   std::to_string(threads)}));
  }
  report.publish("tet10 snap", kSource + "/docs/benchmarks.md");
}
