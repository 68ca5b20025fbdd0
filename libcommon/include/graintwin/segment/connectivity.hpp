#pragma once
// Voxel neighbourhoods shared by the segmentation steps (markers, watershed, label clean-up):
// 6-, 18- or 26-connectivity and a bounds-aware neighbour loop over a (z, y, x) volume.
#include <cstddef>
#include <vector>

#include "graintwin/core/volume.hpp"

namespace graintwin::segment {

/// Voxels are neighbours if they share a face (6), a face or an edge (18), or any corner (26).
enum class Connectivity { faces = 6, edges = 18, corners = 26 };

/// 6, 18 or 26 -> Connectivity; any other number throws UsageError naming the choices.
Connectivity connectivity_from_int(int n);

/// One step to a neighbour: index offsets per axis and the linear offset in the volume's layout.
struct NeighbourStep {
  int dz, dy, dx;
  std::ptrdiff_t offset;
};

/// The steps of connectivity `c` in a volume of `shape`, in raster order of the neighbour: the
/// first half precede the voxel in raster order (z, y, x), the second half follow it.
std::vector<NeighbourStep> neighbour_steps(Connectivity c, const Shape3& shape);

/// True if all neighbours of (z, y, x) lie inside a volume of `shape` (no bounds checks needed).
inline bool is_interior(const Shape3& shape, std::size_t z, std::size_t y, std::size_t x) {
  return z > 0 && y > 0 && x > 0 && z + 1 < shape[0] && y + 1 < shape[1] && x + 1 < shape[2];
}

/// Calls fn(q) for every neighbour q (linear index) of voxel p = (z, y, x) that lies inside the
/// volume. Interior voxels take the unchecked path, which is what keeps the hot loops fast.
template <class Fn>
inline void for_each_neighbour(const std::vector<NeighbourStep>& steps, const Shape3& shape, std::size_t z,
                               std::size_t y, std::size_t x, std::size_t p, Fn&& fn) {
  if (is_interior(shape, z, y, x)) {
    for (const NeighbourStep& s : steps) fn(p + s.offset);
    return;
  }
  const auto inside = [](std::size_t i, int d, std::size_t n) {
    return d == 0 || (d < 0 ? i > 0 : i + 1 < n);
  };
  for (const NeighbourStep& s : steps)
    if (inside(z, s.dz, shape[0]) && inside(y, s.dy, shape[1]) && inside(x, s.dx, shape[2])) fn(p + s.offset);
}

/// Splits a linear index into (z, y, x) with two multiplications by reciprocals instead of two
/// integer divisions (which cost tens of cycles in the queue-driven loops). Exact for indices below
/// 2^52: the floating quotient is off by at most one and is corrected.
class IndexSplitter {
 public:
  explicit IndexSplitter(const Shape3& shape)
      : nx_(shape[2]), ny_(shape[1]), inv_nx_(1.0 / static_cast<double>(shape[2])),
        inv_ny_(1.0 / static_cast<double>(shape[1])) {}
  void split(std::size_t p, std::size_t& z, std::size_t& y, std::size_t& x) const {
    const std::size_t row = divide(p, nx_, inv_nx_);
    x = p - row * nx_;
    z = divide(row, ny_, inv_ny_);
    y = row - z * ny_;
  }

 private:
  static std::size_t divide(std::size_t a, std::size_t d, double inv) {
    std::size_t q = static_cast<std::size_t>(static_cast<double>(a) * inv);
    if (q * d > a) --q;
    else if ((q + 1) * d <= a) ++q;
    return q;
  }
  std::size_t nx_, ny_;
  double inv_nx_, inv_ny_;
};

/// for_each_neighbour for a voxel known only by its linear index.
template <class Fn>
inline void for_each_neighbour(const std::vector<NeighbourStep>& steps, const Shape3& shape,
                               const IndexSplitter& split, std::size_t p, Fn&& fn) {
  std::size_t z, y, x;
  split.split(p, z, y, x);
  for_each_neighbour(steps, shape, z, y, x, p, fn);
}

}  // namespace graintwin::segment
