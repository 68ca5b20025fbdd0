#pragma once
// One grain's tetrahedral mesh (4- or 10-node, gmsh node order as in fdem/model.hpp), what we
// measure on it ourselves (gmsh 4.8 has no element-quality call): volume, gamma quality, Jacobian
// validity of curved elements, its boundary surface; and how it joins an fdem::Model.
#include <array>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

#include "graintwin/core/volume.hpp"
#include "graintwin/fdem/model.hpp"
#include "graintwin/mesh/surface.hpp"

namespace graintwin::mesh {

struct TetMesh {
  std::vector<Eigen::Vector3d> nodes;   ///< m
  int nodes_per_element = 4;            ///< 4 or 10
  std::vector<std::uint32_t> elements;  ///< flat, nodes_per_element per element, positive orientation
  std::size_t element_count() const { return elements.size() / static_cast<std::size_t>(nodes_per_element); }
  const std::uint32_t* element(std::size_t e) const { return elements.data() + e * static_cast<std::size_t>(nodes_per_element); }
};

/// gmsh's gamma of a linear tetrahedron: 3 x inradius / circumradius (1 equilateral, 0 flat),
/// negative when the corners are inverted. For 10-node elements, of the corner tetrahedron.
double tet_gamma(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Smallest altitude of a tetrahedron: 3 x volume / largest face area (fdem::element_min_altitude's
/// measure, which sets fdemrun's element step), m; negative when the corners are inverted.
double tet_min_altitude(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Smallest of a tetrahedron's six dihedral angles, degrees (0 when flat or degenerate).
double tet_min_dihedral_degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                const Eigen::Vector3d& d);

/// What an element must reach to be no sliver (remove_slivers); 0 leaves a measure unchecked.
struct SliverThresholds {
  double min_dihedral_degrees = 0.0;  ///< smallest dihedral angle of the corner tetrahedron
  double min_altitude_ratio = 0.0;    ///< smallest altitude over the grain's median element altitude
  bool any() const { return min_dihedral_degrees > 0.0 || min_altitude_ratio > 0.0; }
};

/// Whether an element with these measures (altitude against the grain's `median_altitude`) meets `thresholds`.
bool meets(const SliverThresholds& thresholds, double min_dihedral_degrees, double min_altitude, double median_altitude);

/// det J of a 10-node tetrahedron (gmsh order) at natural coordinates (xi, eta, zeta) of the unit
/// tetrahedron; equals 6 x volume for straight-sided elements.
double tet10_det_jacobian(const std::array<Eigen::Vector3d, 10>& x, double xi, double eta, double zeta);

/// min det J / max det J of an element over its 10 nodes and 4 Gauss points (1 for a straight
/// 10-node element or any positive 4-node one; <= 0: inverted somewhere).
double jacobian_ratio(const TetMesh& mesh, std::size_t element);

struct MeshQuality {
  std::size_t elements = 0, nodes = 0, surface_nodes = 0;
  /// What sets the explicit step (of the corner tetrahedra): smallest dihedral angle (degrees),
  /// smallest and median altitude (m), and the element with the smallest altitude.
  double min_dihedral = 0.0, min_altitude = 0.0, median_altitude = 0.0;
  std::size_t worst_element = 0;
  std::size_t below_thresholds = 0;  ///< elements below the SliverThresholds passed to mesh_quality
  double min_gamma = 0.0, mean_gamma = 0.0;
  double min_jacobian_ratio = 0.0;   ///< over all elements
  std::size_t inverted = 0;          ///< elements with jacobian_ratio <= 0
  std::size_t below_floor = 0;       ///< elements with gamma below the floor passed to mesh_quality
  double volume = 0.0;               ///< m^3, exact for the (curved) elements
  double surface_area = 0.0;         ///< m^2, of the linear boundary triangles
};
MeshQuality mesh_quality(const TetMesh& mesh, double gamma_floor, const SliverThresholds& slivers = {});

/// Median over the elements of their corner tetrahedra's smallest altitude, m (0 without elements).
double median_altitude(const TetMesh& mesh);

/// Restores curved 10-node elements: the mid-edge nodes of every element whose jacobian_ratio is
/// below `min_ratio` move towards the straight-edge midpoint by `fraction` (1: onto it; a straight
/// element with valid corners has ratio 1); repeated up to `passes` times since a moved node is
/// shared. Returns the mid-edge nodes moved.
std::size_t straighten_distorted(TetMesh& mesh, double min_ratio, double fraction, int passes);

/// Curved elements must keep min det J / max det J at least this (barely valid curved elements
/// would set a tiny stable time step in the solver).
inline constexpr double kMinCurvedJacobianRatio = 0.2;
/// The rule for 10-node meshes whose boundary nodes were moved (snapped onto the exact surface):
/// elements below kMinCurvedJacobianRatio have their mid-edge nodes pulled back halfway, up to 4
/// times, then fully; returns the mid-edge nodes moved. Always ends valid when the corners are.
std::size_t pull_back_curved(TetMesh& mesh);

/// Volume of the mesh (curved 10-node elements integrated exactly, 5-point cubic rule).
double mesh_volume(const TetMesh& mesh);

/// The boundary (faces used by one element) as outward linear triangles over the mesh's node
/// indices; a 10-node face is split into 4 through its mid-edge nodes.
std::vector<std::array<std::uint32_t, 3>> boundary_triangles(const TetMesh& mesh);
/// The same as a stand-alone surface (only the boundary nodes, in order of first use).
TriangleSurface boundary_surface(const TetMesh& mesh);

/// Appends one grain to `model`: its nodes, elements and boundary triangles as a new grain-owned
/// block. kind must agree with the mesh's nodes per element unless it is rigid.
void append_grain(fdem::Model& model, const TetMesh& mesh, std::uint32_t label, fdem::GrainKind kind,
                  std::uint32_t material = 0);

/// The vertical cylinder around all nodes of `model`: axis through the mean node position (x, y),
/// radius the largest node distance from it, z range of the nodes.
fdem::SampleCylinder enclosing_cylinder(const fdem::Model& model, double membrane_thickness);

/// The largest vertical cylinder inside a scan's box: a crop from inside a sample (the soil crop)
/// has no sample cylinder in view, and the cylinder around its grains leaves the box's corners
/// empty, which the wall must close before it confines anything. Axis through the middle of the
/// volume's x-y extent, radius half its narrower side, z range the volume's (voxel faces).
fdem::SampleCylinder inscribed_cylinder(const Volume<std::uint32_t>& labels, double membrane_thickness);

/// The labels of `labels` whose voxels (as cubes) all lie within `radius` of the vertical axis
/// through `axis_xy`, widened by `margin` (m): the grains a cylinder holds whole.
std::unordered_set<std::uint32_t> labels_within(const Volume<std::uint32_t>& labels, const Eigen::Vector2d& axis_xy, double radius,
                                                double margin);

/// Rigid platens at the cylinder's ends: "bottom" at z_min facing +z, "top" at z_max facing -z.
std::vector<fdem::Platen> end_platens(const fdem::SampleCylinder& sample, double friction);

}  // namespace graintwin::mesh
