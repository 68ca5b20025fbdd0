#pragma once
// Grains for scenes that do not come from CT: a box meshed directly (structured, exact geometry),
// and the shared step that turns any 4-node tetrahedral mesh into a model grain (10-node promotion
// by mid-edge nodes, outward surface triangles). Spheres and ellipsoids go through gmsh (mesh/).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

/// A linear tetrahedral mesh of one body: positions in m, positively oriented tets.
struct TetMesh {
  std::vector<Eigen::Vector3d> nodes;
  std::vector<std::array<std::uint32_t, 4>> tets;
};

/// A box of `size` (m, x y z) centred at the origin: ceil(size / element_size) cells per axis, each
/// cube split into 6 tetrahedra around its main diagonal (Kuhn), so faces match across cells.
TetMesh box_mesh(const Eigen::Vector3d& size, double element_size);

/// Appends `mesh` (moved by `offset`, m) to `model` as one grain of `kind` with `material` and
/// `label`, and returns its grain index. tet10 adds one mid-edge node per edge (straight edges);
/// rigid grains keep the 4-node mesh. The surface is every tetrahedron face used once, outward and
/// counter-clockwise seen from outside, each 10-node face split into 4 triangles. Throws DataError
/// when a tetrahedron is flat or inverted.
std::uint32_t add_grain(Model& model, const TetMesh& mesh, const Eigen::Vector3d& offset, GrainKind kind,
                        std::uint32_t material, std::uint32_t label);

}  // namespace graintwin::fdem
