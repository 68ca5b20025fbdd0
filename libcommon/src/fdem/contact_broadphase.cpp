#include "graintwin/fdem/contact_broadphase.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace graintwin::fdem {

std::vector<BoxPair> overlapping_box_pairs(std::span<const Aabb> boxes) {
  std::vector<std::uint32_t> live;
  Aabb world;
  double cell = 0;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Aabb& b = boxes[i];
    if (!(b.lo.array() <= b.hi.array()).all()) continue;
    live.push_back(static_cast<std::uint32_t>(i));
    world.grow(b);
    cell = std::max(cell, (b.hi - b.lo).maxCoeff());
  }
  std::vector<BoxPair> pairs;
  if (live.size() < 2) return pairs;
  const Eigen::Vector3d span = world.hi - world.lo;
  if (!(cell > 0)) cell = std::max(span.maxCoeff(), 1.0);  // points: any cell works
  // Coarsen until the grid has at most 4 cells per box (plus a small floor), so memory stays
  // linear however far apart the boxes are.
  std::array<std::int64_t, 3> dims{};
  const auto max_cells = static_cast<double>(4 * live.size() + 64);
  for (;;) {
    for (int k = 0; k < 3; ++k) dims[k] = static_cast<std::int64_t>(std::floor(span[k] / cell)) + 1;
    if (static_cast<double>(dims[0]) * dims[1] * dims[2] <= max_cells) break;
    cell *= 1.5;
  }
  auto cell_of = [&](const Eigen::Vector3d& p) {
    std::array<std::int64_t, 3> c{};
    for (int k = 0; k < 3; ++k)
      c[k] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((p[k] - world.lo[k]) / cell)), 0,
                                      dims[k] - 1);
    return c;
  };
  auto flat = [&](const std::array<std::int64_t, 3>& c) { return static_cast<std::size_t>((c[2] * dims[1] + c[1]) * dims[0] + c[0]); };
  // Counting sort of (cell, box) entries: CSR over cells, boxes in increasing order in each cell.
  const std::size_t cells = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  std::vector<std::uint32_t> start(cells + 1, 0);
  auto for_each_cell = [&](const Aabb& b, auto&& f) {
    const auto lo = cell_of(b.lo), hi = cell_of(b.hi);
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) f(flat({x, y, z}));
  };
  for (std::uint32_t i : live) for_each_cell(boxes[i], [&](std::size_t c) { ++start[c + 1]; });
  for (std::size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
  std::vector<std::uint32_t> entries(start[cells]);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::uint32_t i : live) for_each_cell(boxes[i], [&](std::size_t c) { entries[fill[c]++] = i; });
  }
  // A pair sharing several cells is reported only from the cell holding the low corner of the
  // boxes' intersection, so each pair appears once without a hash set.
  for (std::size_t c = 0; c < cells; ++c)
    for (std::uint32_t s = start[c]; s < start[c + 1]; ++s)
      for (std::uint32_t t = s + 1; t < start[c + 1]; ++t) {
        const Aabb& a = boxes[entries[s]];
        const Aabb& b = boxes[entries[t]];
        if (!a.overlaps(b) || flat(cell_of(a.lo.cwiseMax(b.lo))) != c) continue;
        pairs.emplace_back(entries[s], entries[t]);
      }
  // Counting sort by the first index, then each (short) bucket by the second: linear overall.
  std::vector<std::uint32_t> first_start(boxes.size() + 1, 0);
  for (const BoxPair& p : pairs) ++first_start[p.first + 1];
  for (std::size_t i = 0; i < boxes.size(); ++i) first_start[i + 1] += first_start[i];
  std::vector<BoxPair> sorted(pairs.size());
  for (const BoxPair& p : pairs) sorted[first_start[p.first]++] = p;
  for (std::size_t i = boxes.size(); i-- > 0;) first_start[i + 1] = first_start[i];
  first_start[0] = 0;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    std::sort(sorted.begin() + first_start[i], sorted.begin() + first_start[i + 1]);
  return sorted;
}

}  // namespace graintwin::fdem
