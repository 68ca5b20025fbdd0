// fdemrun_bench (issue 9 item 8): solver throughput on a packing of 500 grains with contact.
// Grains: gmsh spheres and ellipsoids of about 300 surface nodes, on a cubic lattice where each
// grain overlaps its six neighbours and the bottom layer the floor platen by 0.2 % of the radius,
// under gravity, so every step computes elements, the broad phase over ~1 500 touching pairs and
// the node contacts at their poles. A lattice in contact, not a gravity-settled random packing
// (settling 500 elastic grains takes ~1e6 steps). Measured per kind (tet4, tet10, rigid) on 1 and
// 2 threads: wall and process CPU time of 40 steps after 10 warm-up steps; element-steps/s/core
// (deformable) and grain-steps/s/core (rigid) against the targets 1e7 and 1e5.
// `fdemrun_bench KIND` runs one kind without publishing (for profiling with perf).
#include <fmt/format.h>
#include <omp.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>

#include "graintwin/fdem/ellipsoid_grain.hpp"
#include "graintwin/fdem/solver.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr int kSide = 8, kGrains = 500;
constexpr double kRadius = 0.5e-3;

double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// The lattice packing: spheres and (every third grain) ellipsoids of the same largest semi-axis.
Model packing(GrainKind kind) {
  mesh::TetOptions o;
  // About 300 surface nodes on a sphere: 10-node grains count their mid-edge nodes too.
  o.order = kind == GrainKind::tet10 ? 2 : 1;
  o.size = (o.order == 2 ? 0.44 : 0.22) * kRadius;
  const mesh::TetMesh sphere = mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(kRadius),
                                                    Eigen::Quaterniond::Identity(), o);
  const mesh::TetMesh ellipsoid = mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d(kRadius, 0.8 * kRadius, 0.7 * kRadius),
                                                       Eigen::Quaterniond::Identity(), o);
  Model m;
  const double spacing = 2 * kRadius * 0.998;
  for (int g = 0; g < kGrains; ++g) {
    mesh::TetMesh copy = g % 3 == 2 ? ellipsoid : sphere;
    const Eigen::Vector3d at(spacing * (g % kSide), spacing * ((g / kSide) % kSide), spacing * (g / (kSide * kSide)) + 0.999 * kRadius);
    for (Eigen::Vector3d& p : copy.nodes) p += at;
    mesh::append_grain(m, copy, static_cast<std::uint32_t>(g + 1), kind);
  }
  m.platens = {Platen{"floor", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0.5}};
  return m;
}

struct Measured {
  double wall = 0, cpu = 0;
  std::size_t contacts = 0;
};

Measured run(const Model& m, int threads, int steps) {
  omp_set_num_threads(threads);
  SolverOptions o;
  o.gravity = Eigen::Vector3d(0, 0, -9.81);
  Solver s(m, o);
  const double dt = s.time_step_limits().stable();
  for (int n = 0; n < 10; ++n) s.step(dt);
  Measured r;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (int n = 0; n < steps; ++n) r.contacts = s.step(dt).contact.node_contacts;
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = process_cpu_seconds() - cpu0;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string only = argc > 1 ? argv[1] : "";
  bench::Report report(
      "fdemrun_bench", "fdemrun: solver throughput, 500 grains in contact",
      fmt::format("{} grains (2/3 spheres R = 0.5 mm, 1/3 ellipsoids 1 : 0.8 : 0.7), gmsh element size 0.22 R (tet4, rigid), 0.44 R (tet10), on an "
                  "8 x 8 x 8 lattice overlapping neighbours and the floor by 0.2 % of R, gravity, contact on (penalty "
                  "SPEC 0 defaults). 40 steps timed after 10. Per core = per thread used. Machine: {}. The machine is "
                  "shared with other jobs: the CPU column is process CPU time.",
                  kGrains, bench::machine_summary()));
  const int steps = 40;
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10, GrainKind::rigid}) {
    const char* name = kind == GrainKind::tet4 ? "tet4" : kind == GrainKind::tet10 ? "tet10" : "rigid";
    if (!only.empty() && only != name) continue;
    const Model m = packing(kind);
    std::size_t surface = 0;
    std::vector<char> on_surface(m.nodes.size(), 0);
    for (const auto& t : m.triangles)
      for (std::uint32_t v : t) surface += !on_surface[v], on_surface[v] = 1;
    for (int threads : {1, 2}) {
      const Measured r = run(m, threads, steps);
      const double work = kind == GrainKind::rigid ? double(m.grains.size()) : double(m.element_count());
      const double per_core_wall = work * steps / r.wall / threads, per_cpu = work * steps / r.cpu;
      const char* unit = kind == GrainKind::rigid ? "grain-steps" : "element-steps";
      const double target = kind == GrainKind::rigid ? 1e5 : 1e7;
      const std::string note = fmt::format(
          "{} elements, {} nodes ({:.0f} surface nodes/grain), {} node contacts; {:.3g} {}/s/core by wall, {:.3g} by CPU "
          "time ({:.2f} s CPU); target {:.0e} ({:.2g} x of it by CPU)",
          m.element_count(), m.nodes.size(), double(surface) / m.grains.size(), r.contacts, per_core_wall, unit, per_cpu,
          r.cpu, target, per_cpu / target);
      std::printf("%s, %d thread(s): %s\n", name, threads, note.c_str());
      std::fflush(stdout);
      report.add({fmt::format("{} x 500", name), fmt::format("graintwin, {} thread(s)", threads), r.wall, 0, note});
    }
  }
  if (only.empty()) report.publish("graintwin, 1 thread(s)", std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "docs" / "benchmarks.md");
}
