// fdemrun_bench: solver throughput on a settled packing of 500 grains.
// Grains: gmsh spheres of five sizes (radius 0.40-0.60 mm; element size 0.22 R for tet4, about 350
// surface nodes, 0.44 R for tet10, about 400 with mid-edge nodes, 0.26 R for rigid, about 270: the
// project states its rigid target for about 250 surface nodes per grain).
// The packing: synth::pack_grains places them at random in a cylinder (solid fraction 0.55, every
// pair within 0.5 % of the smallest radius of touching); then, as rigid grains, they are
// consolidated isotropically to sigma_3 = 300 kPa (the reference test's, docs/methods.md) between
// two platens inside the servo wall by fdem::consolidate_in_wall, under gravity with the
// pipeline's damping, until the stresses hold within 1 % and the kinetic energy stays below 5 % of
// the elastic energy for 100 steps. Every kind is then timed on that settled packing: its own
// meshes placed at the consolidated grains' centroids and rotations, between the platens where
// they stopped, inside the wall at its last radius (so each step computes elements, the wall, the
// broad phase and the narrow phase of a loaded packing with about 4-6 contacts per grain).
// Measured per kind (tet4, tet10, rigid) on 1 and 2 threads: wall and process CPU time of the timed
// steps after 10 warm-up steps, on a fresh solver three times for the deformable kinds and nine for
// rigid grains (a second each), the thread counts taking turns so that each sees the same phases of
// the machine (the median run is reported with the range: on this virtual machine one binary's
// rate drifts by up to a factor of two over minutes, other tenants sharing its memory);
// element-steps/s/core (deformable) and grain-steps/s/core (rigid) against the project's targets 1e7
// (4-node) and 1e5 (rigid).
// `fdemrun_bench KIND [STEPS [THREADS]]` runs one kind without publishing, for profiling with perf
// (more steps make the timed loop outweigh building the packing).
#include <fmt/format.h>
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "graintwin/core/error.hpp"
#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/fdem/solver.hpp"
#include "graintwin/fdem/triaxial.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/packing.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr int kGrains = 500;
constexpr double kRigidElementSize = 0.26;  // x the radius
constexpr double kSolidFraction = 0.55;
constexpr double kDamping = 2000;  // 1/s, the pipeline's (pipelines/scenes/triaxial.toml)
constexpr int kRepeats = 3, kRigidRepeats = 9;
const std::vector<double> kRadii{0.40e-3, 0.45e-3, 0.50e-3, 0.55e-3, 0.60e-3};

double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

const char* name_of(GrainKind kind) {
  return kind == GrainKind::tet4 ? "tet4" : kind == GrainKind::tet10 ? "tet10" : "rigid";
}

/// Where the grains are: the centroid and rotation of every grain, the platens and the wall.
struct Packing {
  std::vector<Eigen::Vector3d> centroid;
  std::vector<Eigen::Quaterniond> rotation;
  double z_bottom = 0, z_top = 0, radius = 0;
};

/// Grain g's sphere mesh of `kind`, its centroid at the origin (sizes cycle through kRadii).
class SphereMeshes {
 public:
  explicit SphereMeshes(GrainKind kind) : kind_(kind) {
    mesh::TetOptions o;
    o.order = kind == GrainKind::tet10 ? 2 : 1;
    const double element_size = kind == GrainKind::tet10 ? 0.44 : kind == GrainKind::rigid ? kRigidElementSize : 0.22;
    for (double r : kRadii) {
      o.size = element_size * r;
      mesh::TetMesh m = mesh::mesh_ellipsoid(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(r), Eigen::Quaterniond::Identity(), o);
      Model one;
      mesh::append_grain(one, m, 1, kind);
      const Eigen::Vector3d c = body_properties(one, 0).centroid;
      for (Eigen::Vector3d& p : m.nodes) p -= c;
      meshes_.push_back(std::move(m));
    }
  }
  /// The model of `packing`: every grain's mesh moved to its pose, the platens "bottom" and "top",
  /// the sample cylinder at the wall's radius.
  Model place(const Packing& packing) const {
    Model m;
    for (std::size_t g = 0; g < packing.centroid.size(); ++g) {
      mesh::TetMesh copy = meshes_[g % meshes_.size()];
      const Eigen::Matrix3d rotation = packing.rotation[g].toRotationMatrix();
      for (Eigen::Vector3d& p : copy.nodes) p = packing.centroid[g] + rotation * p;
      mesh::append_grain(m, copy, static_cast<std::uint32_t>(g + 1), kind_);
    }
    m.platens = {Platen{"bottom", Eigen::Vector3d(0, 0, packing.z_bottom), Eigen::Vector3d::UnitZ(), 0.0},
                 Platen{"top", Eigen::Vector3d(0, 0, packing.z_top), -Eigen::Vector3d::UnitZ(), 0.0}};
    SampleCylinder sample;
    sample.radius = packing.radius;
    sample.z_min = packing.z_bottom;
    sample.z_max = packing.z_top;
    m.sample = sample;
    return m;
  }

 private:
  GrainKind kind_;
  std::vector<mesh::TetMesh> meshes_;
};

SolverOptions solver_options() {
  SolverOptions o;
  o.gravity = Eigen::Vector3d(0, 0, -9.81);
  o.damping = kDamping;
  return o;
}

/// The random loose packing in a cylinder of height = diameter (see the top of the file).
Packing random_packing() {
  std::vector<shape::RadialTable> tables;
  for (double r : kRadii) tables.push_back(shape::RadialTable::from_function([r](const Eigen::Vector3d&) { return r; }, 8));
  std::vector<const shape::RadialTable*> shapes;
  double volume = 0;
  for (int g = 0; g < kGrains; ++g) {
    shapes.push_back(&tables[g % kRadii.size()]);
    volume += 4.0 / 3.0 * 3.141592653589793 * std::pow(kRadii[g % kRadii.size()], 3);
  }
  synth::Container cylinder;
  cylinder.kind = synth::Container::Kind::cylinder;
  cylinder.radius = std::cbrt(volume / kSolidFraction / (2 * 3.141592653589793));
  cylinder.height = 2 * cylinder.radius;
  synth::PackingParams params;
  params.seed = 9;
  Packing p;
  for (const synth::PackedGrain& g : synth::pack_grains(shapes, cylinder, params)) {
    p.centroid.push_back(g.position);
    p.rotation.push_back(g.orientation);
  }
  p.z_top = cylinder.height;
  p.radius = cylinder.radius;
  return p;
}

/// Consolidates the random packing as rigid grains to 300 kPa in the servo wall and returns where
/// the grains, platens and wall stopped.
Packing settled_packing(std::size_t& steps, double& seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  const Packing random = random_packing();
  const Model loose = SphereMeshes(GrainKind::rigid).place(random);
  Solver solver(loose, solver_options());
  TriaxialOptions options;
  options.servo_inertial_number = 1e-2;  // the pipeline's: only the end state matters
  TriaxialBoundary wall(loose, options, grains_d50(solver));
  solver.set_boundary(&wall);
  std::fprintf(stderr, "fdemrun_bench: consolidating %d rigid grains to %.0f kPa ...\n", kGrains, 1e-3 * options.confining_pressure);
  steps = consolidate_in_wall(solver, wall, options, solver.time_step_limits().stable(), 200000);
  solver.set_boundary(nullptr);
  Packing p;
  for (std::size_t g = 0; g < loose.grains.size(); ++g) {
    p.centroid.push_back(solver.grain_centroid(g));
    // The solver's rotation is from the loose packing's placement, which had its own rotation.
    p.rotation.push_back(solver.grain_rotation(g) * random.rotation[g]);
  }
  const PlatenPair platens = find_platens(loose);
  p.z_bottom = solver.platens()[platens.bottom].point.z();
  p.z_top = solver.platens()[platens.top].point.z();
  p.radius = wall.wall().radius;
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return p;
}

struct Measured {
  double wall = 0, cpu = 0;
  ContactStepStats contact;  ///< of the last step
  std::size_t rebuilds = 0;  ///< broad-phase builds during the timed steps
  std::size_t pair_lists_built = 0;  ///< rigid pairs' near-node lists built again between them
  double coordination = 0;   ///< grain-grain contacts per grain after the last step
};

Measured run(const Model& m, int threads, int steps) {
  omp_set_num_threads(threads);
  Solver s(m, solver_options());
  TriaxialOptions options;
  TriaxialBoundary wall(m, options, grains_d50(s));
  s.set_boundary(&wall);
  const double dt = s.time_step_limits().stable();
  for (int n = 0; n < 10; ++n) s.step(dt);
  Measured r;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (int n = 0; n < steps; ++n) {
    r.contact = s.step(dt).contact;
    r.rebuilds += r.contact.rebuilt;
    r.pair_lists_built += r.contact.pair_lists_built;
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = process_cpu_seconds() - cpu0;
  std::size_t pairs = 0;
  for (const ContactRecord& c : s.contacts()) pairs += c.b < m.grains.size();
  r.coordination = 2.0 * double(pairs) / double(m.grains.size());
  s.set_boundary(nullptr);
  return r;
}

}  // namespace

int run_bench(int argc, char** argv) {
  const std::string only = argc > 1 ? argv[1] : "";
  const int steps = argc > 2 ? std::max(1, std::atoi(argv[2])) : 200;
  const std::vector<int> thread_counts = argc > 3 ? std::vector<int>{std::max(1, std::atoi(argv[3]))} : std::vector<int>{1, 2};
  std::size_t consolidation_steps = 0;
  double consolidation_seconds = 0;
  const Packing settled = settled_packing(consolidation_steps, consolidation_seconds);
  double grain_volume = 0;
  for (int g = 0; g < kGrains; ++g) grain_volume += 4.0 / 3.0 * 3.141592653589793 * std::pow(kRadii[g % kRadii.size()], 3);
  const double solid_fraction =
      grain_volume / (3.141592653589793 * settled.radius * settled.radius * (settled.z_top - settled.z_bottom));
  std::printf("settled packing: %zu consolidation steps in %.0f s, solid fraction %.3f\n", consolidation_steps,
              consolidation_seconds, solid_fraction);
  bench::Report report(
      "fdemrun_bench", "fdemrun: solver throughput, a settled packing of 500 grains",
      fmt::format("{} gmsh spheres of radius 0.40-0.60 mm, element size 0.22 R (tet4), 0.44 R (tet10), {} R (rigid), packed at "
                  "random in a cylinder (solid fraction {}) by synth::pack_grains, then consolidated as rigid grains to "
                  "300 kPa inside the servo wall between two platens by fdem::consolidate_in_wall ({} steps, {:.0f} s; "
                  "solid fraction {:.3f}); each kind timed on that packing inside the wall held at its radius, gravity, "
                  "damping {} /s, contact on (the default penalty). {} steps timed after 10, {} times (rigid: {}) on a "
                  "fresh solver, the thread counts taking turns: the median run is shown, with the range of the rates. "
                  "Per core = per thread used. Machine: {}. The CPU column is process CPU time.",
                  kGrains, kRigidElementSize, kSolidFraction, consolidation_steps, consolidation_seconds, solid_fraction,
                  kDamping, steps, kRepeats, kRigidRepeats, bench::machine_summary()));
  // Rigid grains first: timed after the deformable kinds (gigabytes allocated and freed) they ran at
  // about half their rate in a process of their own, the heap scattered.
  for (GrainKind kind : {GrainKind::rigid, GrainKind::tet4, GrainKind::tet10}) {
    const char* name = name_of(kind);
    if (!only.empty() && only != name) continue;
    const Model m = SphereMeshes(kind).place(settled);
    std::size_t surface = 0;
    std::vector<char> on_surface(m.nodes.size(), 0);
    for (const auto& t : m.triangles)
      for (std::uint32_t v : t) surface += !on_surface[v], on_surface[v] = 1;
    const int repeats = kind == GrainKind::rigid ? kRigidRepeats : kRepeats;
    std::vector<std::vector<Measured>> runs_of(thread_counts.size());
    for (int k = 0; k < repeats; ++k)
      for (std::size_t t = 0; t < thread_counts.size(); ++t) runs_of[t].push_back(run(m, thread_counts[t], steps));
    for (std::size_t t = 0; t < thread_counts.size(); ++t) {
      const int threads = thread_counts[t];
      std::vector<Measured>& runs = runs_of[t];
      std::sort(runs.begin(), runs.end(), [](const Measured& a, const Measured& b) { return a.cpu < b.cpu; });
      const Measured& r = runs[runs.size() / 2];
      const double work = kind == GrainKind::rigid ? double(m.grains.size()) : double(m.element_count());
      const double per_core_wall = work * steps / r.wall / threads, per_cpu = work * steps / r.cpu;
      const double fastest = work * steps / runs.front().cpu, slowest = work * steps / runs.back().cpu;
      const char* unit = kind == GrainKind::rigid ? "grain-steps" : "element-steps";
      // The project sets targets for 4-node elements and rigid grains only.
      const double target = kind == GrainKind::rigid ? 1e5 : kind == GrainKind::tet4 ? 1e7 : 0;
      const std::string against =
          target > 0 ? fmt::format("target {:.0e} ({:.2g} x of it by CPU)", target, per_cpu / target) : "no target";
      const std::string note = fmt::format(
          "{} elements, {} nodes ({:.0f} surface nodes/grain), coordination number {:.2f}, {} node contacts, {} "
          "candidate pairs, {} node checks and {} node-triangle checks a step, {} broad-phase builds and {} rigid pairs' "
          "lists built again between them; {:.3g} {}/s/core "
          "by wall, {:.3g} by CPU time ({:.2f} s CPU; the {} runs {:.3g}-{:.3g}); {}",
          m.element_count(), m.nodes.size(), double(surface) / m.grains.size(), r.coordination, r.contact.node_contacts,
          r.contact.pairs, r.contact.node_checks, r.contact.triangle_checks, r.rebuilds, r.pair_lists_built, per_core_wall, unit, per_cpu,
          r.cpu, repeats, slowest, fastest, against);
      std::printf("%s, %d thread(s): %s\n", name, threads, note.c_str());
      std::fflush(stdout);
      report.add({fmt::format("{} x 500", name), fmt::format("graintwin, {} thread(s)", threads), r.wall, 0, note});
    }
  }
  if (only.empty()) report.publish("graintwin, 1 thread(s)", std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "docs" / "benchmarks.md");
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run_bench(argc, argv);
  } catch (const Error& e) {
    std::fprintf(stderr, "fdemrun_bench: %s\n", e.message().c_str());
    return 1;
  }
}
