#pragma once
// Element sizes graded towards contact points, for primitive grains that must resolve a contact
// (the Hertz and Chung & Ooi checks): fine where the grain will touch, growing linearly with the
// distance up to a coarse size elsewhere. gmsh applies it through mesh::TetOptions::size_at
// (mesh/ellipsoid_grain.hpp); this part has no gmsh so it can be tested on its own.
#include <Eigen/Core>
#include <vector>

namespace graintwin::fdem {

struct SizeGrading {
  std::vector<Eigen::Vector3d> points;  ///< m, where the mesh is finest (e.g. the pole that will touch)
  double fine = 0;      ///< m, element size at the points (> 0)
  /// Size increase per unit distance (dimensionless, > 0). The elements around a point number
  /// about growth^-3 log(coarse / fine): a 50 x finer contact costs 10^4 elements, not 10^6. 0.15
  /// resolves a Hertz contact better than 0.3 at the same cost: fewer badly shaped elements, so a
  /// larger stable step (bench/fdemrun_verify_bench.cpp).
  double growth = 0.15;
  double coarse = 0;    ///< m, the size far away (>= fine)
};

/// UsageError (one sentence naming the bad value) when the grading has no points, its sizes are not
/// 0 < fine <= coarse or its growth is not positive. Call once before meshing.
void check_size_grading(const SizeGrading& grading);

/// h(x) = min(coarse, fine + growth min_k |x - p_k|), m, for a grading that passed the check
/// (gmsh asks for it at every vertex it places, so it does not check again).
double graded_element_size(const SizeGrading& grading, const Eigen::Vector3d& x);

}  // namespace graintwin::fdem
