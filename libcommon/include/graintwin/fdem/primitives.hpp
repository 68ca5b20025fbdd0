#pragma once
// Grains for scenes that do not come from CT: a box meshed directly (structured, exact geometry),
// and the shared step that turns any 4-node tetrahedral mesh into a model grain (10-node promotion
// by mid-edge nodes, outward surface triangles); and the way back, 10-node grains split into
// 4-node ones on the same nodes. Spheres and ellipsoids go through gmsh (mesh/).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
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
/// rigid grains keep the 4-node mesh. Joins through append_grain_elements.
std::uint32_t add_grain(Model& model, const TetMesh& mesh, const Eigen::Vector3d& offset, GrainKind kind,
                        std::uint32_t material, std::uint32_t label);

/// The outward boundary of a 4- or 10-node tetrahedral mesh (`elements` flat, `nodes_per_element`
/// indices each, gmsh order, positively oriented): every face used by one element, counter-
/// clockwise seen from outside, a 10-node face split into 4 through its mid-edge nodes; ordered by
/// element and face (deterministic). Indices as in `elements`.
std::vector<std::array<std::uint32_t, 3>> boundary_triangles(int nodes_per_element, std::span<const std::uint32_t> elements);

/// Appends one grain given as nodes (m) and flat 4- or 10-node elements (gmsh order, indices into
/// `nodes`) to `model` as a contiguous block with its boundary_triangles, and returns its grain
/// index. Throws DataError when an element uses a missing node or its corners are flat or inverted,
/// UsageError for an unknown material or a node count that is not 4 or 10.
std::uint32_t append_grain_elements(Model& model, std::span<const Eigen::Vector3d> nodes, int nodes_per_element,
                                    std::span<const std::uint32_t> elements, GrainKind kind, std::uint32_t material,
                                    std::uint32_t label);

/// Every grain of `model` made a 4-node one on its own nodes: each 10-node element becomes eight
/// 4-node ones (a tetrahedron at each corner and the inner octahedron cut along the diagonal that
/// leaves its four tetrahedra positively oriented, the shortest of those), grains of 4-node elements
/// keep theirs, and the grains become `GrainKind::tet4`. Nodes and surface triangles are untouched
/// (a 10-node grain's surface is already its faces' quarters), so contact sees the same surface;
/// the volume is that of the straight parts (a curved element's bulge is lost). Element order
/// within a grain: the parent's, its eight parts in turn. A grain with a curved element that has no
/// split without an inverted part keeps its 10-node elements and kind; their indices are returned.
std::vector<std::uint32_t> split_into_linear_grains(Model& model);

}  // namespace graintwin::fdem
