#include "graintwin/mesh/equivalent_packing.hpp"

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::mesh {

EquivalentSample pack_equivalent_sample(const std::vector<const shape::GrainShape*>& library, int degree,
                                        const EquivalentPackingOptions& o,
                                        const synth::PackingObserver& observe) {
  if (!(o.solid_fraction > 0.0 && o.solid_fraction <= synth::kDensestPacking))
    throw UsageError(fmt::format("the solid fraction {:.3g} of an equivalent sample must be in (0, {:g}]: {:g} is the densest "
                                 "arrangement of equal spheres",
                                 o.solid_fraction, synth::kDensestPacking, synth::kDensestPacking));
  if (!(o.aspect > 0.0)) throw UsageError(fmt::format("the sample's height / diameter must be positive (got {})", o.aspect));
  EquivalentSample s;
  // The packer's radius tables, one per usable library grain (true surface, then each smooth stage).
  std::vector<int> stages_degree;
  for (int d : o.smooth_degrees)
    if (d >= 1 && d < degree && (stages_degree.empty() || d > stages_degree.back())) stages_degree.push_back(d);
  stages_degree.push_back(degree);
  std::vector<std::size_t> usable;
  std::vector<std::vector<shape::RadialTable>> tables(stages_degree.size());
  for (std::size_t i = 0; i < library.size(); ++i) {
    throw_if_interrupted();  // a library of thousands of grains takes seconds to tabulate
    const shape::GrainShape& g = *library[i];
    if (g.flags & shape::shape_flag::unreliable_fit) {
      ++s.unusable;
      continue;
    }
    std::vector<shape::RadialTable> per_stage;
    try {
      for (int d : stages_degree) {
        const Eigen::VectorXd low = g.coeffs.head(static_cast<Eigen::Index>((d + 1) * (d + 1)));
        per_stage.push_back(shape::radial_table_from_sh(low, d, o.table_nodes));
      }
    } catch (const DataError&) {  // r <= 0 somewhere: not star-shaped about its centroid
      ++s.unusable;
      continue;
    }
    usable.push_back(i);
    for (std::size_t k = 0; k < per_stage.size(); ++k) tables[k].push_back(std::move(per_stage[k]));
  }
  if (usable.empty()) throw DataError("no grain of the shape library has a usable SH surface to pack; check labels2shapes' flags");

  // The draw: indices into `usable`.
  std::vector<std::size_t> drawn;
  if (o.grains == 0) {
    for (std::size_t k = 0; k < usable.size(); ++k) drawn.push_back(k);
  } else {
    std::mt19937_64 rng(o.seed);
    std::uniform_int_distribution<std::size_t> pick(0, usable.size() - 1);
    for (std::size_t n = 0; n < o.grains; ++n) drawn.push_back(pick(rng));
  }
  std::vector<std::vector<const shape::RadialTable*>> stages(tables.size());
  std::vector<double> diameters, volumes;
  double total = 0.0;
  for (std::size_t k : drawn) {
    s.source.push_back(usable[k]);
    for (std::size_t st = 0; st < tables.size(); ++st) stages[st].push_back(&tables[st][k]);
    const double v = tables.back()[k].volume();
    total += v;
    volumes.push_back(v);
    diameters.push_back(equivalent_diameter(v));
  }
  s.psd = shape::size_distribution(diameters, volumes);

  // Cylinder of volume total / solid fraction with height = aspect x diameter.
  s.container.kind = synth::Container::Kind::cylinder;
  s.container.radius = std::cbrt(total / o.solid_fraction / (2.0 * M_PI * o.aspect));
  s.container.height = 2.0 * o.aspect * s.container.radius;
  synth::PackingParams p;
  p.seed = o.seed;
  s.poses = synth::pack_in_stages(stages, s.container, p, &s.report, observe);
  return s;
}

void place_mesh(TetMesh& mesh, const synth::PackedGrain& pose) {
  const Eigen::Matrix3d turn = pose.orientation.normalized().toRotationMatrix();
  for (Eigen::Vector3d& p : mesh.nodes) p = pose.position + turn * p;
}

}  // namespace graintwin::mesh
