// The contact model's measure of a configuration's overlaps (ContactModel::overlaps), for
// packings placed before a run.
#include <fmt/format.h>

#include "contact_state.hpp"
#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

std::vector<Overlap> ContactModel::overlaps(std::span<const Eigen::Vector3d> x, std::span<const PlatenState> platens,
                                           std::span<const std::uint8_t> moved) {
  State& s = *state_;
  if (x.size() != s.node_count)
    throw DataError(fmt::format("fdem contact: {} positions for {} nodes; pass one per model node.", x.size(), s.node_count));
  const auto grain_count = static_cast<std::uint32_t>(s.grains.size());
  if (!moved.empty() && moved.size() != grain_count)
    throw DataError(fmt::format("fdem contact: {} moved flags for {} grains; pass one per grain.", moved.size(), grain_count));
  // Only a configuration left by an earlier overlaps() call (same poses, same trees) can be updated
  // in part; after a step (or the first time) every grain is placed again.
  const bool all = moved.empty() || !s.overlap_configuration;
  const auto changed = [&](std::uint32_t g) { return all || moved[g] != 0; };
  s.sphere_centre.resize(grain_count);
  s.sphere_radius.resize(grain_count);
  if (all) s.pose.assign(grain_count, RigidPose{});
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g)
    if (changed(static_cast<std::uint32_t>(g))) s.update_grain(static_cast<std::uint32_t>(g), x, nullptr, false);
  s.need_rebuild = true;  // the trees and poses are this configuration's, not the run's
  s.overlap_configuration = true;

  std::vector<Aabb> boxes(grain_count);
  for (std::uint32_t g = 0; g < grain_count; ++g) boxes[g] = s.trees.bounds(g);
  std::vector<BoxPair> pairs = overlapping_box_pairs(boxes);
  if (!all) std::erase_if(pairs, [&](const BoxPair& p) { return !changed(p.first) && !changed(p.second); });
  const double unbounded = std::numeric_limits<double>::infinity();
  // The deepest point of grain `from` inside grain `to`: its surface nodes and triangle centroids
  // within `to`'s box and bounding sphere, each searched without a bound.
  const auto deepest = [&](std::uint32_t from, std::uint32_t to) {
    const Aabb& box = boxes[to];
    const double reach2 = s.sphere_radius[to] * s.sphere_radius[to];
    double depth = 0;
    SurfaceTrees::Nearest near;
    const auto test = [&](const Eigen::Vector3d& p) {
      if (!box.contains(p) || (p - s.sphere_centre[to]).squaredNorm() > reach2) return;
      if (!s.nearest(to, p, unbounded, x, near)) return;
      const bool inside = (near.closest.point - p).dot(s.pseudonormal(near.triangle, near.closest.feature, x)) > 0;
      if (inside) depth = std::max(depth, std::sqrt(near.distance2));
    };
    for (std::uint32_t node : s.surface(from)) test(x[node]);
    const Grain& g = s.grains[from];
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t) {
      const auto& c = s.triangles[t];
      test((x[c[0]] + x[c[1]] + x[c[2]]) / 3.0);
    }
    return depth;
  };
  std::vector<double> pair_depth(pairs.size(), 0.0);
#pragma omp parallel for schedule(dynamic, 4) if (pairs.size() >= kParallelCandidates)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(pairs.size()); ++k) {
    const auto [a, b] = pairs[static_cast<std::size_t>(k)];
    pair_depth[static_cast<std::size_t>(k)] = std::max(deepest(a, b), deepest(b, a));
  }
  // Behind a platen: the deepest surface node (a flat cut's deepest point is a vertex).
  std::vector<std::vector<Overlap>> behind(grain_count);
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g) {
    const auto grain = static_cast<std::uint32_t>(g);
    if (!changed(grain)) continue;
    for (std::uint32_t p = 0; p < platens.size(); ++p) {
      double depth = 0;
      for (std::uint32_t node : s.surface(grain)) depth = std::max(depth, (platens[p].point - x[node]).dot(platens[p].normal));
      if (depth > 0) behind[grain].push_back({grain, grain_count + p, depth});
    }
  }
  std::vector<Overlap> out;
  for (std::uint32_t g = 0, k = 0; g < grain_count; ++g) {
    for (; k < pairs.size() && pairs[k].first == g; ++k)
      if (pair_depth[k] > 0) out.push_back({pairs[k].first, pairs[k].second, pair_depth[k]});
    out.insert(out.end(), behind[g].begin(), behind[g].end());
  }
  return out;
}

}  // namespace graintwin::fdem
