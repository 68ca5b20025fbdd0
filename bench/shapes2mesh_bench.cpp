// shapes2mesh_bench: what a grain mesh costs and how close it is to the exact surface, against the
// element size (elements per diameter) and order, for the two 10-node curvings; the automatic size
// on a sand-like and a rough grain against the 2 % volume target of 4-node meshes; chart of volume
// error against elements per grain (docs/img/shapes2mesh_accuracy.png); and whole models of
// sand_small's reference scan with 1 and 2 gmsh worker processes and of the real soil crop, with
// the time per grain and the share of grains on each meshing path, when runs/ has their shapes.
//   shapes2mesh_bench [--quick]
#include <sys/resource.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "graintwin/core/geometry.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/io/schema.hpp"
#include "graintwin/mesh/grain_mesher.hpp"
#include "graintwin/mesh/grain_surface.hpp"
#include "graintwin/shape/sh_basis.hpp"
#include "graintwin/shape/shapes_file.hpp"
#include "harness.hpp"

using namespace graintwin;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;

/// A sand-like test grain (the anchors' shape, radius about 0.3 mm): r = R (1 + 0.075 (3 cos^2 t - 1)
/// + 0.08 sin^2 t cos 2p + 0.04 sin^3 t cos 3p + 0.02 cos 5t), fitted exactly at degree 8; `rough`
/// adds bumps of degree 6 to 9 (0.05 sin^6 t cos 6p + 0.03 cos 9t), fitted at degree 12.
shape::GrainShape test_grain(double radius, bool rough) {
  const int degree = rough ? 12 : 8;
  shape::GrainShape g;
  g.label = 1;
  g.coeffs = shape::sh_fit(
      [&](const Eigen::Vector3d& d) {
        const double ct = d.z(), st = std::sqrt(std::max(0.0, 1 - ct * ct)), p = std::atan2(d.y(), d.x()), t = std::acos(ct);
        const double bumps = rough ? 0.05 * std::pow(st, 6) * std::cos(6 * p) + 0.03 * std::cos(9 * t) : 0.0;
        return radius * (1 + 0.075 * (3 * ct * ct - 1) + 0.08 * st * st * std::cos(2 * p) + 0.04 * st * st * st * std::cos(3 * p) +
                         0.02 * std::cos(5 * t) + bumps);
      },
      degree, 4000);
  const shape::ShMoments mom = shape::sh_moments(g.coeffs, degree);
  g.volume = mom.volume;
  g.equivalent_diameter = equivalent_diameter(g.volume);
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

/// CPU seconds (user + system) of the finished child processes this process waited for, and of
/// theirs (the tool's reaped gmsh workers).
double children_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_CHILDREN, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

/// The 1-minute load average (the machine is shared: other jobs slow timed runs down).
double load_average() {
  std::ifstream in("/proc/loadavg");
  double load = 0;
  in >> load;
  return load;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const double radius = 0.3e-3;
  const shape::GrainShape grain = test_grain(radius, false), rough = test_grain(radius, true);
  const mesh::ShSurfaceBasis basis(4, 8), rough_basis(4, 12);
  bench::Report report("shapes2mesh_bench", "shapes2mesh: cost and accuracy of grain meshes",
                       "One sand-like SH grain (radius 0.3 mm, degree 8, exact volume from the SH moments) meshed through "
                       "mesh::mesh_grain at fixed elements per diameter: seconds in gmsh (best of 3), elements, surface nodes, "
                       "volume error against the exact SH volume, largest distance of boundary triangle centroids from the "
                       "exact surface (/ radius), min gamma and min Jacobian ratio; gmsh remeshes the SH surface, boundary nodes "
                       "snapped onto the exact SH surface except for 'tet10 gmsh'; 'kept': the surface remeshed by CGAL and "
                       "kept as the boundary (the default), gmsh seconds are then only its volume filling. Then the automatic size (250 surface nodes; 4-node: the 2 % volume "
                       "target from the measured total mean curvature) on it and on a rougher grain (degree 12). Then whole "
                       "models (shapes and labels of the pipeline's runs/) of sand_small scan 0 with -j 1 and -j 2 (threads = "
                       "gmsh worker processes) and of the real soil crop with -j 2: wall time of the tool (one run), CPU "
                       "time, and per meshing path the share of grains and their mean time in mesh_grain. " + bench::machine_summary());
  std::ofstream csv(kSource + "/docs/img/shapes2mesh_accuracy.csv");
  csv << "series,label,x,y\n";
  struct Variant {
    const char* name;
    int order;
    bool snap;
    mesh::MeshPath path;
  };
  // gmsh's remeshing of the SH surface (snapped, or curved by gmsh), and the kept-surface path.
  const std::vector<Variant> variants = {{"tet4", 1, true, mesh::MeshPath::gmsh_surface},
                                         {"tet10 snap", 2, true, mesh::MeshPath::gmsh_surface},
                                         {"tet10 gmsh", 2, false, mesh::MeshPath::gmsh_surface},
                                         {"tet4 kept", 1, true, mesh::MeshPath::kept_surface},
                                         {"tet10 kept", 2, true, mesh::MeshPath::kept_surface}};
  const std::vector<double> per_diameter = quick ? std::vector<double>{3, 6} : std::vector<double>{3, 4, 6, 8, 12};
  double fewest = 1e300, most = 0;  // elements, for the target line
  for (const Variant& v : variants)
    for (double n : per_diameter) {
      mesh::GrainMeshOptions o;
      o.order = v.order;
      o.snap_to_sh = v.snap;
      o.sh_path = v.path;
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
      fewest = std::min(fewest, double(r.quality.elements)), most = std::max(most, double(r.quality.elements));
    }
  // The automatic size (contact: 250 surface nodes; 4-node: also the volume target).
  for (const Variant& v : {variants[0], variants[1], variants[3], variants[4]})
    for (const auto& [name, g, b] : {std::tuple{"sand-like", &grain, &basis}, std::tuple{"rough", &rough, &rough_basis}}) {
      mesh::GrainMeshOptions o;
      o.order = v.order;
      o.sh_path = v.path;
      const auto r = mesh::mesh_grain(*g, *b, nullptr, {}, o);
      const double volume_error = r.quality.volume / g->volume - 1;
      // Total mean curvature over volume against the sphere of the same volume's 3 / R^2.
      const auto surface = mesh::sh_surface(b->sphere, b->basis, g->coeffs, g->centroid);
      const double curvature = mesh::total_mean_curvature(surface) / mesh::enclosed_volume(surface) /
                               (12.0 / (g->equivalent_diameter * g->equivalent_diameter));
      report.add({fmt::format("automatic, {} grain", name), v.name, r.gmsh.seconds, 0,
                  fmt::format("{:.1f} per diameter ({} rule), {} elements, {} surface nodes, volume error {:+.3f} %, "
                              "curvature {:.3f} x the sphere's",
                              g->equivalent_diameter / r.size.h, mesh::size_rule_name(r.size.rule), r.quality.elements,
                              r.quality.surface_nodes, 100 * volume_error, curvature)});
      csv << v.name << " automatic," << name << "," << r.quality.elements << "," << std::max(std::abs(volume_error), 1e-6) << "\n";
    }
  for (double x : {fewest, most}) csv << "tet4 volume target (2 %),," << x << ",0.02\n";
  csv.close();
  bench::plot_xy(kSource + "/docs/img/shapes2mesh_accuracy.csv", kSource + "/docs/img/shapes2mesh_accuracy.png",
                 "shapes2mesh: volume error against cost", "elements per grain",
                 "|volume error| (labels: elements per diameter or grain)");

  // Whole models of the pipeline's reference scans, where runs/ has their shapes and labels:
  // sand_small (ctsynth grains) with 1 and 2 gmsh worker processes (the same model either way),
  // and the real soil crop with 2. Per grain: wall time in mesh_grain (/mesh/seconds) and the
  // share of grains on each meshing path.
  const std::string tool = (bench::bin_dir() / "shapes2mesh").string();
  struct Series {
    const char* name;
    std::vector<int> processes;
  };
  for (const Series& series : {Series{"sand_small", {1, 2}}, Series{"soil_crop", {2}}}) {
    const std::filesystem::path scan = kSource + "/runs/" + series.name + "/scan_000";
    if (quick || !std::filesystem::exists(scan / "shapes.h5") || !std::filesystem::exists(scan / "labels.h5")) continue;
    const std::size_t grains = shape::read_shapes_file(scan / "shapes.h5").grains.size();
    std::vector<fdem::Model> models;
    for (int processes : series.processes) {
      const std::string model = fmt::format("/tmp/shapes2mesh_bench_model_{}.h5", processes);
      const double load = load_average(), cpu_before = children_cpu_seconds();
      bench::Row row = bench::run_child(fmt::format("{} scan 0 ({} grains), 10-node, snap", series.name, grains),
                                        fmt::format("shapes2mesh -j {} ({} gmsh process{})", processes, processes, processes > 1 ? "es" : ""),
                                        {tool, (scan / "shapes.h5").string(), (scan / "labels.h5").string(), model, "--force", "-q", "-j",
                                         std::to_string(processes)});
      const double cpu = children_cpu_seconds() - cpu_before;
      models.push_back(fdem::read_model_file(model));
      const io::H5File f = io::H5File::open(model);
      const auto path = f.read<std::uint8_t>(schema::fdem_model::mesh::path);
      const auto seconds = f.read<double>(schema::fdem_model::mesh::seconds);
      const auto overran = f.read<std::uint8_t>(schema::fdem_model::mesh::overran_budget);
      std::size_t on[3] = {0, 0, 0}, overruns = 0;
      double path_seconds[3] = {0, 0, 0}, slowest = 0;
      for (std::size_t g = 0; g < path.size(); ++g) {
        ++on[path[g]], path_seconds[path[g]] += seconds[g], overruns += overran[g];
        slowest = std::max(slowest, seconds[g]);
      }
      const auto share = [&](int k) {
        return on[k] ? fmt::format("{:.1f} % ({:.3f} s per grain)", 100.0 * double(on[k]) / double(path.size()), path_seconds[k] / double(on[k]))
                     : std::string("0 %");
      };
      row.note = fmt::format("CPU {:.1f} s (tool and workers), {:.3f} CPU s per grain; paths: gmsh surface {}, kept surface {}, "
                             "ellipsoid {}; slowest grain {:.2f} s; {} over the time budget; load average {:.2f} before the run{}",
                             cpu, cpu / double(grains), share(0), share(1), share(2), slowest, overruns, load,
                             load > 1.0 ? " (shared machine)" : "");
      if (models.size() == 2)
        row.note += models[1].nodes == models[0].nodes && models[1].element_nodes == models[0].element_nodes
                        ? "; model identical to -j 1"
                        : "; MODEL DIFFERS FROM -j 1";
      report.add(row);
      std::filesystem::remove(model);
    }
  }
  report.publish("tet10 snap", kSource + "/docs/benchmarks.md");
}
