// fdem_implicit_grain_bench: what stepping deformable grains implicitly in their corotated frame
// (fdem::ImplicitGrain, [run] deformable_integration = "implicit") costs against explicit elements, on the
// pipeline's 10-node twins of sand_small (ctsynth grains) and the real soil crop. Per grain: the
// factorisation of M + h^2 K once, one implicit step (rotation, K u, the solve) and one explicit
// element-force pass (ElasticElements::add_internal_forces). The explicit twin steps at fdemrun's
// element limit, the implicit one at the step the rigid twin's contact allows (the same model with
// its grains rigid); the cost per simulated microsecond is each one's time a grain-step over its
// step. The grains' contact is left out of both (the same per step, and the implicit twin takes
// far fewer steps). Whether explicit penalty contact stays stable on implicit grains at that step is
// fdem_implicit_grain_test's question (a box on a platen: stable at 70 element steps). The step's
// LDL^T solve in 3 x 3 node blocks (fdem::NodeBlockLdlt) is also timed against Eigen's
// SimplicialLDLT on the same matrix and right-hand side, and their answers compared.
//   fdem_implicit_grain_bench [--quick]   (--quick: 20 grains of sand_small)
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <numeric>

#include <Eigen/SparseCholesky>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/implicit_grain.hpp"
#include "graintwin/fdem/node_blocks.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/solver.hpp"
#include "harness.hpp"

using namespace graintwin;

namespace {

const std::string kSource = GRAINTWIN_SOURCE_DIR;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) try {
  bool quick = false;
  std::filesystem::path work;
  if (!bench::parse_quick_work(argc, argv, quick, work)) {
    std::cerr << "usage: fdem_implicit_grain_bench [--quick]\n";
    return 2;
  }
  bench::Report report("fdem_implicit_grain", "Deformable grains stepped implicitly in their corotated frame: the cost against explicit elements",
                       fmt::format("`build/bin/fdem_implicit_grain_bench` ({}). The pipeline's 10-node twins (runs/<series>/model.h5, made by "
                                   "`make -f Makefile.pipeline SERIES=<series> mesh`), one thread. Per grain: the factorisation of M + h^2 K "
                                   "(once), one implicit step (best-fit rotation, K u, the LDL^T solve, each the best of 5) and one explicit "
                                   "element-force pass (the best of 5). Explicit twin: fdemrun's element step; implicit: the contact step of "
                                   "the same model with its grains rigid (the rigid twin's). Cost per simulated us: a grain-step's time over "
                                   "its step, the median grain. Contact is left out of both (its stability on implicit grains at that step: a "
                                   "10-node box resting on a platen at 70 element steps is stable, fdem_implicit_grain_test).",
                                   bench::machine_summary()));
  const std::vector<std::string> series = quick ? std::vector<std::string>{"sand_small"} : std::vector<std::string>{"sand_small", "soil_crop"};
  for (const std::string& name : series) {
    const std::filesystem::path path = kSource + "/runs/" + name + "/model.h5";
    if (!std::filesystem::exists(path)) {
      std::cerr << fmt::format("{} is missing: make -f Makefile.pipeline SERIES={} mesh\n", path.string(), name);
      return 1;
    }
    const fdem::Model model = fdem::read_model_file(path);
    fdem::Model rigid = model;
    for (fdem::Grain& g : rigid.grains) g.kind = fdem::GrainKind::rigid;
    fdem::Model deformable = model;  // each grain of its mesh's order (a real twin may hold a 4-node grain)
    for (fdem::Grain& g : deformable.grains)
      g.kind = g.element_end > g.element_begin && model.nodes_of(g.element_begin) == 10 ? fdem::GrainKind::tet10 : fdem::GrainKind::tet4;
    const double element_step = fdem::Solver(deformable, fdem::SolverOptions{}).time_step_limits().element_stable;
    const double contact_step = fdem::Solver(rigid, fdem::SolverOptions{}).time_step_limits().contact_stable;
    const std::vector<double> mass = fdem::lumped_masses(deformable);
    const fdem::ElasticElements elements(deformable);
    std::vector<double> factor, implicit, explicit_forces, sizes, eigen_solve, block_solve;
    const std::size_t grains = quick ? std::min<std::size_t>(20, model.grains.size()) : model.grains.size();
    std::vector<Eigen::Vector3d> x = deformable.nodes, v(deformable.nodes.size(), Eigen::Vector3d::Zero()),
                                 f(deformable.nodes.size(), Eigen::Vector3d::Zero());
    for (std::size_t g = 0; g < grains; ++g) {
      const fdem::Grain& grain = deformable.grains[g];
      if (grain.kind != fdem::GrainKind::tet10) continue;  // the 10-node grains are the case
      sizes.push_back(static_cast<double>(grain.element_end - grain.element_begin));
      std::unique_ptr<fdem::ImplicitGrain> stepper;
      factor.push_back(bench::best_seconds(1, [&] { stepper = std::make_unique<fdem::ImplicitGrain>(deformable, g, mass, contact_step); }));
      const std::size_t n = grain.node_end - grain.node_begin;
      implicit.push_back(bench::best_seconds(5, [&] {
        stepper->step(std::span(x).subspan(grain.node_begin, n), std::span(v).subspan(grain.node_begin, n),
                      std::span<const Eigen::Vector3d>(f).subspan(grain.node_begin, n));
      }));
      explicit_forces.push_back(bench::best_seconds(5, [&] { elements.add_internal_forces(x, grain.element_begin, grain.element_end, f); }));
      // The step's solve against Eigen's SimplicialLDLT (AMD, scalar) on the same matrix and right-hand side.
      std::vector<Eigen::Triplet<double>> system = fdem::grain_stiffness_lower(deformable, g, fdem::lame_constants(deformable.materials[grain.material]));
      for (auto& t : system) t = Eigen::Triplet<double>(t.row(), t.col(), contact_step * contact_step * t.value());
      for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) system.emplace_back(static_cast<int>(3 * i + k), static_cast<int>(3 * i + k), mass[grain.node_begin + i]);
      const auto dofs = static_cast<Eigen::Index>(3 * n);
      Eigen::SparseMatrix<double> lower(dofs, dofs);
      lower.setFromTriplets(system.begin(), system.end());
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> eigen(lower);
      const fdem::NodeBlockLdlt blocks(n, system);
      const Eigen::VectorXd rhs = Eigen::VectorXd::Random(dofs);
      Eigen::VectorXd by_eigen(dofs), by_blocks(dofs);
      eigen_solve.push_back(bench::best_seconds(5, [&] { by_eigen = eigen.solve(rhs); }));
      block_solve.push_back(bench::best_seconds(5, [&] {
        blocks.solve({rhs.data(), static_cast<std::size_t>(dofs)}, {by_blocks.data(), static_cast<std::size_t>(dofs)});
      }));
      if (!((by_blocks - by_eigen).norm() <= 1e-9 * by_eigen.norm())) {
        std::cerr << fmt::format("{}: grain {}: the block solve differs from Eigen's by {:.3g} (relative)\n", name, g,
                                 (by_blocks - by_eigen).norm() / by_eigen.norm());
        return 1;
      }
      std::fill(f.begin() + grain.node_begin, f.begin() + grain.node_end, Eigen::Vector3d::Zero());
      if ((g + 1) % 50 == 0) std::cerr << fmt::format("{}: {} of {} grains\n", name, g + 1, grains);
    }
    const double per_us_explicit = median(explicit_forces) / element_step * 1e-6, per_us_implicit = median(implicit) / contact_step * 1e-6;
    const std::string note = fmt::format(
        "{} grains of median {:.0f} 10-node elements (of {}); steps: explicit {:.3g} s, implicit {:.3g} s ({:.0f} x); per grain: "
        "factorisation {:.3g} ms once, implicit step {:.3g} us, explicit element forces {:.3g} us; per simulated us: explicit "
        "{:.3g} ms, implicit {:.3g} ms: {:.1f} x cheaper; the step's LDL^T solve {:.3g} us in 3 x 3 node blocks against {:.3g} us "
        "by Eigen's SimplicialLDLT ({:.2f} x faster, the same answer to 1e-9)",
        sizes.size(), median(sizes), grains, element_step, contact_step, contact_step / element_step, 1e3 * median(factor), 1e6 * median(implicit),
        1e6 * median(explicit_forces), 1e3 * per_us_explicit, 1e3 * per_us_implicit, per_us_explicit / per_us_implicit, 1e6 * median(block_solve),
        1e6 * median(eigen_solve), median(eigen_solve) / median(block_solve));
    std::cout << name << ": " << note << "\n";
    const auto measured = static_cast<double>(sizes.size());
    report.add({name, "explicit elements (fdemrun now)", per_us_explicit * measured, 0, note});
    report.add({name, "implicit corotated grains", per_us_implicit * measured, 0,
                fmt::format("seconds of one thread per simulated us for the {} grains (factorisations aside: {:.3g} s once)", sizes.size(),
                            std::accumulate(factor.begin(), factor.end(), 0.0))});
  }
  if (!quick) report.publish("explicit elements (fdemrun now)", kSource + "/docs/benchmarks.md");
  else std::cout << report.markdown("explicit elements (fdemrun now)");
  return 0;
} catch (const Error& e) {
  std::cerr << "fdem_implicit_grain_bench: " << e.message() << "\n";
  return 1;
}
