#pragma once
// The FDEM model in memory: what shapes2mesh builds from CT grains, what fdemrun builds from
// scene primitives, and what fdemrun simulates. Grain-owned contiguous ranges (nodes, elements,
// surface triangles of one grain are consecutive) so a grain can move between threads or MPI
// ranks as one block. On disk it is `kind=fdem_model` (docs/formats.md).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/core/enum_names.hpp"

namespace graintwin::fdem {

/// How a grain is modelled. Every grain has a tetrahedral mesh (it gives a rigid grain its mass
/// and inertia) and a closed outward surface (contact works on surfaces for all three).
enum class GrainKind : std::uint8_t { rigid = 0, tet4 = 1, tet10 = 2 };
/// Their names in scenes and messages.
inline constexpr std::array<EnumName<GrainKind>, 3> kGrainKindNames{
    {{GrainKind::rigid, "rigid"}, {GrainKind::tet4, "tet4"}, {GrainKind::tet10, "tet10"}}};

/// The reference experiment's defaults (docs/methods.md): Ottawa sand in the CT-FDEM paper.
struct Material {
  std::string name = "ottawa_sand";
  double density = 2650.0;               ///< kg/m^3
  double young = 92.1e9;                 ///< Pa
  double poisson = 0.118;
  double friction = 0.5;                 ///< Coulomb coefficient against grains and platens
  double normal_penalty = 92.1e11;       ///< p_n, N/m^3 (k_n = p_n A_node)
  double tangential_penalty = 92.1e11;   ///< p_t, N/m^3
  double damping_ratio = 0.03;           ///< critical damping fraction beta_n = beta_t
};

/// One grain: half-open index ranges into the model's arrays.
struct Grain {
  std::uint32_t label = 0;  ///< label in the reference scan (or primitive number)
  GrainKind kind = GrainKind::tet4;
  std::uint32_t material = 0;  ///< index into Model::materials
  std::uint32_t node_begin = 0, node_end = 0;
  std::uint32_t element_begin = 0, element_end = 0;
  std::uint32_t triangle_begin = 0, triangle_end = 0;
};

/// The names of a sample's end platens, by which the triaxial test finds them.
inline constexpr const char* kBottomPlaten = "bottom";
inline constexpr const char* kTopPlaten = "top";

/// A rigid plane (platen): the half-space behind it is solid. Moved by the loading protocol.
struct Platen {
  std::string name;             ///< kBottomPlaten, kTopPlaten, or a scene's own
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< m, a point on the plane
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); ///< unit, pointing into the sample
  double friction = 0.0;        ///< smooth platens by default (docs/methods.md, FDEM)
};

/// The sample region of the reference scan: a vertical cylinder (z axial).
struct SampleCylinder {
  Eigen::Vector2d axis_xy = Eigen::Vector2d::Zero();  ///< m
  double radius = 0.0;                                ///< m
  double z_min = 0.0, z_max = 0.0;                    ///< m
  double membrane_thickness = 0.3e-3;                 ///< m (latex, docs/methods.md)
};

struct Model {
  /// Reference (undeformed) node positions, m, (x, y, z); nodes of grain g are
  /// [grains[g].node_begin, grains[g].node_end).
  std::vector<Eigen::Vector3d> nodes;
  /// Element connectivity, flat: element e uses element_nodes[element_offset[e] ..
  /// element_offset[e+1]), 4 or 10 node indices in gmsh order (10-node: corners 0-3, then the
  /// mid-edge nodes of edges 01, 12, 20, 30, 32, 31). Positive orientation:
  /// (x1-x0) x (x2-x0) . (x3-x0) > 0.
  std::vector<std::uint32_t> element_nodes;
  std::vector<std::uint32_t> element_offset;  ///< elements + 1 entries, starts at 0
  std::vector<std::uint32_t> element_grain;   ///< grain index of every element
  /// Closed outward surface of every grain as linear triangles over its surface nodes (a 10-node
  /// grain's curved faces are each split into 4 triangles through the mid-edge nodes), counter-
  /// clockwise seen from outside.
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> triangle_grain;  ///< grain index of every triangle
  std::vector<Grain> grains;
  std::vector<Material> materials{Material{}};
  std::vector<Platen> platens;
  std::optional<SampleCylinder> sample;

  std::size_t element_count() const { return element_grain.size(); }
  std::size_t nodes_of(std::size_t element) const {
    return element_offset[element + 1] - element_offset[element];
  }
};

}  // namespace graintwin::fdem
