// fdem_contact_bench: the contact part of fdemrun, broad and narrow phase.
// Grains with 242 surface nodes (a 6 x 6 x 7-cell structured box mesh mapped onto a ball of radius
// 0.5 mm, randomly rotated) on a cubic lattice 1 % closer than a diameter, so every grain
// touches its six neighbours; from 125 to about 10 000 grains. Per grain count, on one thread
// (thread CPU time, so a loaded machine does not distort it):
//   - broad phase: the cell-grid pair search over the grains' skin-inflated boxes;
//   - a contact step without rebuild (tree refits, node-in-box tests, closest-triangle searches,
//     forces) and its throughput in node checks and node-triangle checks per second;
// and the step on all cores (wall time) at the largest size.
//   build/bin/fdem_contact_bench [--quick]
// --quick: up to 1 000 grains, prints only.
#include <fmt/format.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <ctime>
#include <iostream>
#include <random>

#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/contact_broadphase.hpp"
#include "graintwin/fdem/primitives.hpp"
#include "harness.hpp"

using namespace graintwin;
using namespace graintwin::fdem;

namespace {

constexpr double kRadius = 0.5e-3;

double thread_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Best thread CPU time of `reps` calls.
template <class F>
double best_cpu_seconds(int reps, F&& f) {
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    const double t0 = thread_seconds();
    f();
    best = std::min(best, thread_seconds() - t0);
  }
  return best;
}

/// A ball-shaped grain mesh: the structured box mesh with every node pushed radially from the
/// box's infinity-norm shell onto the ball's Euclidean shell (cells distort; surfaces stay closed).
TetMesh ball_mesh() {
  TetMesh m = box_mesh({6.0, 6.0, 7.0}, 1.0);
  const Eigen::Vector3d half(3.0, 3.0, 3.5);
  for (Eigen::Vector3d& p : m.nodes) {
    const Eigen::Vector3d q = p.cwiseQuotient(half);
    const double inf = q.cwiseAbs().maxCoeff(), two = q.norm();
    p = two > 0 ? Eigen::Vector3d(q * (kRadius * inf / two)) : Eigen::Vector3d::Zero();
  }
  return m;
}

struct Scene {
  Model model;
  std::vector<double> mass;
};

/// n^3 balls on a lattice of spacing 2 R (1 - 0.01), each turned by a random rotation.
Scene lattice(int n, const TetMesh& ball) {
  Scene s;
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss;
  const double spacing = 2 * kRadius * (1 - 0.01);
  TetMesh turned = ball;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Quaterniond q = Eigen::Quaterniond(gauss(rng), gauss(rng), gauss(rng), gauss(rng)).normalized();
        for (std::size_t v = 0; v < ball.nodes.size(); ++v) turned.nodes[v] = q * ball.nodes[v];
        add_grain(s.model, turned, spacing * Eigen::Vector3d(i, j, k), GrainKind::rigid, 0,
                  static_cast<std::uint32_t>(s.model.grains.size() + 1));
      }
  // Node masses as a lumped ball would have them: the ball's mass spread evenly.
  const double grain_mass = s.model.materials[0].density * 4.0 / 3.0 * 3.14159265358979 * std::pow(kRadius, 3);
  s.mass.assign(s.model.nodes.size(), grain_mass / static_cast<double>(ball.nodes.size()));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const TetMesh ball = ball_mesh();
  std::vector<int> sides = {5, 10, 16, 22};
  if (quick) sides = {5, 10};

  bench::Report report(
      "fdem_contact_bench", "FDEM contact: broad-phase scaling and narrow-phase throughput",
      "Grains with 242 surface nodes (480 triangles; a structured 6 x 6 x 7-cell box mesh mapped onto a "
      "0.5 mm ball, random rotations) on a cubic lattice 1 % closer than a diameter, so each grain touches "
      "its six neighbours (default material). One thread, thread CPU time, best of 3-5. "
      "*broad phase*: the cell-grid pair search over the skin-inflated grain boxes; *step*: one "
      "ContactModel::add_forces without rebuild (tree refits, node-in-box tests, closest-triangle searches, "
      "forces). Time per grain should stay flat if the cost is linear in the number of grains. "
      "The reference row is the largest lattice on all cores (wall time).");
  omp_set_num_threads(1);
  std::cout << fmt::format("{:>7} {:>11} {:>14} {:>14} {:>12} {:>14} {:>16} {:>10}\n", "grains", "cand.pairs",
                           "broad us/grain", "step us/grain", "node contacts", "node checks/s", "node-tri checks/s",
                           "rebuild ms");
  Scene last;
  for (int side : sides) {
    Scene s = lattice(side, ball);
    const std::size_t grains = s.model.grains.size();
    ContactModel contact(s.model, s.mass, {});
    std::vector<Eigen::Vector3d> v(s.model.nodes.size(), Eigen::Vector3d::Zero()), f(s.model.nodes.size());
    ContactStepStats stats;
    const double rebuild = best_cpu_seconds(1, [&] { stats = contact.add_forces(s.model.nodes, v, {}, 1e-8, f); });
    const int reps = grains > 5000 ? 3 : 5;
    const double step = best_cpu_seconds(reps, [&] { stats = contact.add_forces(s.model.nodes, v, {}, 1e-8, f); });
    std::vector<Aabb> boxes(grains);
    for (std::size_t g = 0; g < grains; ++g) {
      for (std::uint32_t n = s.model.grains[g].node_begin; n < s.model.grains[g].node_end; ++n)
        boxes[g].grow(s.model.nodes[n]);
      boxes[g] = boxes[g].inflated(0.5 * contact.skin());
    }
    std::size_t pairs = 0;
    const double broad = best_cpu_seconds(reps, [&] { pairs = overlapping_box_pairs(boxes).size(); });
    const double node_rate = static_cast<double>(stats.node_checks) / step;
    const double tri_rate = static_cast<double>(stats.triangle_checks) / step;
    std::cout << fmt::format("{:>7} {:>11} {:>14.2f} {:>14.2f} {:>12} {:>14.3g} {:>16.3g} {:>10.1f}\n", grains, pairs,
                             1e6 * broad / grains, 1e6 * step / grains, stats.node_contacts, node_rate, tri_rate,
                             1e3 * rebuild)
              << std::flush;
    const std::string note = fmt::format(
        "step {:.2f} us/grain; broad phase {:.2f} us/grain; {} candidate pairs, {} node contacts; {:.3g} node checks/s, "
        "{:.3g} node-triangle checks/s; first step with rebuild {:.1f} ms",
        1e6 * step / grains, 1e6 * broad / grains, pairs, stats.node_contacts, node_rate, tri_rate, 1e3 * rebuild);
    report.add({fmt::format("{} grains", grains), "graintwin, 1 thread", step, 0, note});
    if (side == sides.back()) last = std::move(s);
  }
  // All cores, largest lattice, wall time.
  omp_set_num_threads(omp_get_num_procs());
  {
    ContactModel contact(last.model, last.mass, {});
    std::vector<Eigen::Vector3d> v(last.model.nodes.size(), Eigen::Vector3d::Zero()), f(last.model.nodes.size());
    contact.add_forces(last.model.nodes, v, {}, 1e-8, f);
    const double wall = bench::best_seconds(3, [&] { contact.add_forces(last.model.nodes, v, {}, 1e-8, f); });
    const std::size_t grains = last.model.grains.size();
    std::cout << fmt::format("{} grains on {} threads: {:.2f} us/grain (wall)\n", grains, omp_get_max_threads(),
                             1e6 * wall / grains);
    report.add({fmt::format("{} grains", grains), fmt::format("graintwin, {} threads (wall)", omp_get_max_threads()),
                wall, 0, ""});
  }
  if (!quick)
    report.publish(fmt::format("graintwin, {} threads (wall)", omp_get_num_procs()),
                   std::filesystem::path(GRAINTWIN_SOURCE_DIR) / "docs" / "benchmarks.md");
  return 0;
}
