#pragma once
// FDEM broad phase: every overlapping pair of a set of boxes through a uniform cell grid, in time
// linear in the number of boxes for boxes of similar size (the grid cell is the largest box
// extent, so a box touches at most 8 cells; the grid is coarsened when the boxes are sparse so it
// never has more than about 4 cells per box).
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "graintwin/fdem/contact_geometry.hpp"

namespace graintwin::fdem {

using BoxPair = std::pair<std::uint32_t, std::uint32_t>;

/// All pairs (i, j), i < j, of boxes that overlap (touching counts), sorted by (i, j). Empty boxes
/// (lo > hi) take part in no pair.
std::vector<BoxPair> overlapping_box_pairs(std::span<const Aabb> boxes);

}  // namespace graintwin::fdem
