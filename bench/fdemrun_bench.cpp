// fdemrun_bench (issue 9 item 8): solver throughput on a packing of 500 grains with contact.
// Grains: gmsh spheres of five sizes (radius 0.40-0.60 mm; element size 0.22 R for tet4, about 350
// surface nodes, 0.44 R for tet10, about 400 with mid-edge nodes, 0.26 R for rigid, about 270: the
// issue states its rigid target for about 250 surface nodes per grain), packed at
// random to a solid fraction of 0.55 in a box by synth::pack_grains (overlap relaxation: every pair
// within 0.5 % of the smallest radius of touching), then moved 0.3 % towards the box centre so the
// touching pairs overlap, over a floor platen, under gravity: a dense random packing in contact,
// like a settled one (settling 500 elastic grains dynamically takes ~1e6 steps), so every step
// computes elements, the broad phase and the narrow phase of about 2 300 candidate pairs (only tens
// to a few hundred node contacts: overlaps of a few um are of the order of the facets' sag, and the
// coarser rigid surfaces sag more; the cost is in the pairs' node checks and tree searches, not in
// the contacts found). Measured per kind (tet4,
// tet10, rigid) on 1 and 2 threads: wall and process CPU time of 40 steps after 10 warm-up steps;
// element-steps/s/core (deformable) and grain-steps/s/core (rigid) against the targets
// 1e7 (4-node) and 1e5 (rigid).
// `fdemrun_bench KIND [STEPS [THREADS]]` runs one kind without publishing, for profiling with perf
// (more steps make the timed loop outweigh building the packing).
#include <fmt/format.h>
#include <omp.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/ellipsoid_grain.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/packing.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr int kGrains = 500;
constexpr double kRadius = 0.5e-3;  // the middle of the five sizes
constexpr double kRigidElementSize = 0.26;  // x the radius

double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// The dense random packing of spheres in contact over a floor (see the top of the file).
Model packing(GrainKind kind) {
  mesh::TetOptions o;
  // About 350 surface nodes on a sphere (10-node grains count their mid-edge nodes too); rigid
  // grains about 250, the surface the issue states its rigid target for.
  o.order = kind == GrainKind::tet10 ? 2 : 1;
  const double element_size = kind == GrainKind::tet10 ? 0.44 : kind == GrainKind::rigid ? kRigidElementSize : 0.22;
  const std::vector<double> radii{0.40e-3, 0.45e-3, 0.50e-3, 0.55e-3, 0.60e-3};
  std::vector<mesh::TetMesh> meshes;
  std::vector<shape::RadialTable> tables;
  for (double r : radii) {
    o.size = element_size * r;
    meshes.push_back(mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(r), Eigen::Quaterniond::Identity(), o));
    tables.push_back(shape::RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, 8));
  }
  std::vector<const shape::RadialTable*> shapes;
  double volume = 0;
  for (int g = 0; g < kGrains; ++g) {
    shapes.push_back(&tables[g % radii.size()]);
    volume += 4.0 / 3.0 * 3.141592653589793 * std::pow(radii[g % radii.size()], 3);
  }
  synth::Container box;
  box.kind = synth::Container::Kind::box;
  const double side = std::cbrt(volume / 0.55);
  box.box_size = Eigen::Vector3d(side, side, side);
  synth::PackingParams params;
  params.seed = 9;
  std::vector<synth::PackedGrain> poses;
  try {
    poses = synth::pack_grains(shapes, box, params);
  } catch (const Error& e) {
    std::fprintf(stderr, "fdemrun_bench: packing failed: %s\n", e.message().c_str());
    throw;
  }
  const Eigen::Vector3d centre = 0.5 * box.box_size;
  Model m;
  double floor = std::numeric_limits<double>::infinity();
  for (int g = 0; g < kGrains; ++g) {
    mesh::TetMesh copy = meshes[g % radii.size()];
    const Eigen::Vector3d at = centre + 0.997 * (poses[g].position - centre);
    floor = std::min(floor, at.z() - radii[g % radii.size()]);
    for (Eigen::Vector3d& p : copy.nodes) p += at;
    mesh::append_grain(m, copy, static_cast<std::uint32_t>(g + 1), kind);
  }
  m.platens = {Platen{"floor", Eigen::Vector3d(0, 0, floor + 1e-3 * kRadius), Eigen::Vector3d::UnitZ(), 0.5}};
  return m;
}

struct Measured {
  double wall = 0, cpu = 0;
  ContactStepStats contact;  ///< of the last step
  std::size_t rebuilds = 0;  ///< broad-phase builds during the timed steps
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
  for (int n = 0; n < steps; ++n) {
    r.contact = s.step(dt).contact;
    r.rebuilds += r.contact.rebuilt;
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = process_cpu_seconds() - cpu0;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string only = argc > 1 ? argv[1] : "";
  const int steps = argc > 2 ? std::max(1, std::atoi(argv[2])) : 40;
  const std::vector<int> thread_counts = argc > 3 ? std::vector<int>{std::max(1, std::atoi(argv[3]))} : std::vector<int>{1, 2};
  bench::Report report(
      "fdemrun_bench", "fdemrun: solver throughput, 500 grains in contact",
      fmt::format("{} gmsh spheres of radius 0.40-0.60 mm, element size 0.22 R (tet4), 0.44 R (tet10), {} R (rigid), packed at "
                  "random to a solid fraction of 0.55 by synth::pack_grains and moved 0.3 % towards the centre so touching "
                  "pairs overlap, over a floor platen, gravity, contact on (penalty SPEC 0 defaults). {} steps timed "
                  "after 10. Per core = per thread used. Machine: {}. The CPU column is process CPU time.",
                  kGrains, kRigidElementSize, steps, bench::machine_summary()));
  for (GrainKind kind : {GrainKind::tet4, GrainKind::tet10, GrainKind::rigid}) {
    const char* name = kind == GrainKind::tet4 ? "tet4" : kind == GrainKind::tet10 ? "tet10" : "rigid";
    if (!only.empty() && only != name) continue;
    const Model m = packing(kind);
    std::size_t surface = 0;
    std::vector<char> on_surface(m.nodes.size(), 0);
    for (const auto& t : m.triangles)
      for (std::uint32_t v : t) surface += !on_surface[v], on_surface[v] = 1;
    for (int threads : thread_counts) {
      const Measured r = run(m, threads, steps);
      const double work = kind == GrainKind::rigid ? double(m.grains.size()) : double(m.element_count());
      const double per_core_wall = work * steps / r.wall / threads, per_cpu = work * steps / r.cpu;
      const char* unit = kind == GrainKind::rigid ? "grain-steps" : "element-steps";
      const double target = kind == GrainKind::rigid ? 1e5 : 1e7;
      const std::string note = fmt::format(
          "{} elements, {} nodes ({:.0f} surface nodes/grain), {} node contacts, {} candidate pairs, {} node checks and "
          "{} node-triangle checks a step, {} broad-phase builds; {:.3g} {}/s/core by wall, {:.3g} by CPU time ({:.2f} s "
          "CPU); target {:.0e} ({:.2g} x of it by CPU)",
          m.element_count(), m.nodes.size(), double(surface) / m.grains.size(), r.contact.node_contacts,
          r.contact.pairs, r.contact.node_checks, r.contact.triangle_checks, r.rebuilds, per_core_wall, unit, per_cpu,
          r.cpu, target, per_cpu / target);
      std::printf("%s, %d thread(s): %s\n", name, threads, note.c_str());
      std::fflush(stdout);
      report.add({fmt::format("{} x 500", name), fmt::format("graintwin, {} thread(s)", threads), r.wall, 0, note});
    }
  }
  if (only.empty()) report.publish("graintwin, 1 thread(s)", std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "docs" / "benchmarks.md");
}
