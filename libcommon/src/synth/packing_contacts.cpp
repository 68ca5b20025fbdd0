// The contacts of grains at given poses (packing.hpp): one pair, every pair of a packing (its
// candidates from core/point_grid), and a grain against the container's walls; measured as
// precisely as the packer's final check, through the kernels of packing_geometry.hpp.
#include <algorithm>
#include <cmath>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/synth/packing.hpp"
#include "packing_geometry.hpp"

namespace graintwin::synth {

namespace {

detail::Frame frame_of(const PackedGrain& g) {
  detail::Frame f;
  f.x = g.position;
  f.R = g.orientation.normalized().toRotationMatrix();
  return f;
}

PairContact contact_of(const detail::PairEval& e) { return PairContact{e.side.depth, e.side.point, e.side.normal}; }

}  // namespace

std::optional<PairContact> pair_contact(const shape::RadialTable& a, const PackedGrain& ga,
                                        const shape::RadialTable& b, const PackedGrain& gb,
                                        double search_gap) {
  const detail::ShapeSampling sa = detail::sample_shape(a), sb = detail::sample_shape(b);
  const detail::PairEval e = detail::evaluate_pair(detail::view_of(a, sa), frame_of(ga), detail::view_of(b, sb),
                                                   frame_of(gb), std::max(search_gap, 0.0), detail::kExactRefineStep);
  if (!e.found) return std::nullopt;
  return contact_of(e);
}

std::vector<GrainContact> find_contacts(const std::vector<const shape::RadialTable*>& shapes,
                                        const std::vector<PackedGrain>& grains, double search_gap) {
  if (shapes.size() != grains.size()) {
    throw UsageError("find_contacts: " + std::to_string(shapes.size()) + " shapes but " +
                     std::to_string(grains.size()) + " grains; pass one shape per grain");
  }
  const std::size_t n = grains.size();
  if (n == 0) return {};
  double rmax = 0.0;
  std::vector<Eigen::Vector3d> positions(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (shapes[i] == nullptr || shapes[i]->empty()) {
      throw UsageError("find_contacts: shape " + std::to_string(i) + " is null or empty");
    }
    rmax = std::max(rmax, shapes[i]->max_radius());
    positions[i] = grains[i].position;
  }
  const double gap = std::max(search_gap, 0.0);
  // Cells as wide as the farthest reach: a grain's partners lie in the cells next to its own.
  const PointGrid grid(positions, 2.0 * rmax + gap);
  std::vector<detail::ShapeData> data;
  std::vector<int> grain_shape;
  detail::index_shapes(shapes, data, grain_shape);
  std::vector<detail::Frame> frames(n);
  for (std::size_t i = 0; i < n; ++i) frames[i] = frame_of(grains[i]);
  std::vector<std::vector<GrainContact>> found(n);
#pragma omp parallel for schedule(dynamic, 16)
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<int> near;
    grid.for_each_within(grains[i].position, shapes[i]->max_radius() + rmax + gap, [&](std::size_t j, double) {
      if (j <= i) return;
      const double reach = shapes[i]->max_radius() + shapes[j]->max_radius() + gap;
      if ((grains[j].position - grains[i].position).squaredNorm() <= reach * reach) near.push_back(static_cast<int>(j));
    });
    std::sort(near.begin(), near.end());
    const detail::SurfaceView vi = data[grain_shape[i]].view();
    for (int j : near) {
      const detail::PairEval e = detail::evaluate_pair(vi, frames[i], data[grain_shape[j]].view(), frames[j], gap,
                                                       detail::kExactRefineStep);
      if (e.found) found[i].push_back(GrainContact{i, static_cast<std::size_t>(j), contact_of(e)});
    }
  }
  std::vector<GrainContact> out;
  for (auto& f : found) out.insert(out.end(), f.begin(), f.end());
  return out;
}

double wall_penetration(const shape::RadialTable& a, const PackedGrain& ga, const Container& c) {
  const detail::ShapeSampling sa = detail::sample_shape(a);
  detail::WallHit hits[detail::kMaxWallHits];
  // A search gap beyond the container size makes every wall report its depth or clearance.
  const double everywhere = 4.0 * a.max_radius() + 2.0 * (c.radius + c.height) + c.box_size.sum() +
                            ga.position.norm();
  const int n = detail::evaluate_walls(detail::view_of(a, sa), frame_of(ga), c, everywhere, detail::kExactRefineStep, hits);
  double worst = -HUGE_VAL;
  for (int k = 0; k < n; ++k) worst = std::max(worst, hits[k].depth);
  return worst;
}

}  // namespace graintwin::synth
