#pragma once
// Triangle meshes of SH surfaces (reconstructed grains for ParaView / STL viewers, and later the
// FDEM meshes): an icosphere's directions displaced to r(direction).
#include <array>
#include <vector>

#include <Eigen/Core>

namespace graintwin::shape {

/// Unit sphere triangulated by subdividing an icosahedron `subdivisions` times (0: 12 vertices and
/// 20 triangles; each level quadruples the triangles). Triangles are oriented outwards.
struct SphereMesh {
  std::vector<Eigen::Vector3d> directions;  ///< unit vectors
  std::vector<std::array<int, 3>> triangles;
};
SphereMesh icosphere(int subdivisions);

/// Vertices centre + r_i d_i of a body whose radii along mesh.directions are `radii`.
std::vector<Eigen::Vector3d> displaced_vertices(const SphereMesh& mesh, const Eigen::VectorXd& radii,
                                                const Eigen::Vector3d& centre);

}  // namespace graintwin::shape
