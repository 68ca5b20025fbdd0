#include "graintwin/segment/connectivity.hpp"

#include <cstdlib>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::segment {

Connectivity connectivity_from_int(int n) {
  switch (n) {
    case 6: return Connectivity::faces;
    case 18: return Connectivity::edges;
    case 26: return Connectivity::corners;
    default:
      throw UsageError("connectivity " + std::to_string(n) + " is not supported; use 6 (faces), 18 (edges) or 26 (corners)");
  }
}

std::vector<NeighbourStep> neighbour_steps(Connectivity c, const Shape3& shape) {
  // The number of non-zero components of a step is 1 for a face, 2 for an edge, 3 for a corner.
  const int max_nonzero = c == Connectivity::faces ? 1 : c == Connectivity::edges ? 2 : 3;
  const auto sy = static_cast<std::ptrdiff_t>(shape[2]);
  const auto sz = static_cast<std::ptrdiff_t>(shape[1] * shape[2]);
  std::vector<NeighbourStep> steps;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nonzero = std::abs(dz) + std::abs(dy) + std::abs(dx);
        if (nonzero == 0 || nonzero > max_nonzero) continue;
        steps.push_back({dz, dy, dx, dz * sz + dy * sy + dx});
      }
  return steps;
}

}  // namespace graintwin::segment
