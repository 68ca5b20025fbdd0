#include "graintwin/fdem/size_grading.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {

void check_size_grading(const SizeGrading& g) {
  if (g.points.empty()) throw UsageError("a graded mesh needs at least one point to refine towards");
  if (!(g.fine > 0) || !(g.coarse >= g.fine))
    throw UsageError(fmt::format("a graded mesh needs 0 < fine size <= coarse size (got {} and {} m)", g.fine, g.coarse));
  if (!(g.growth > 0)) throw UsageError(fmt::format("a graded mesh needs a positive growth rate (got {})", g.growth));
}

double graded_element_size(const SizeGrading& g, const Eigen::Vector3d& x) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : g.points) nearest = std::min(nearest, (x - p).norm());
  return std::min(g.coarse, g.fine + g.growth * nearest);
}

}  // namespace graintwin::fdem
