#pragma once
// Elastic tetrahedra for FDEM grains (docs/methods.md, FDEM): total-Lagrangian St Venant-Kirchhoff
// 4-node (one quadrature point) and 10-node (4-point degree-2 rule) tetrahedra. Reference shape-
// function gradients dN/dX are precomputed per quadrature point, so a step needs only the current
// node positions: F = sum_a x_a (dN_a/dX)^T, E = (F^T F - I) / 2, S = lambda tr(E) I + 2 mu E,
// internal force f_a = sum_q w_q F S dN_a/dX. A 4-node element is one record (nodes, volume, the
// gradients of corners 1..3) and its forces come from F = [x1 - x0, x2 - x0, x3 - x0] G in one
// pass; a 10-node element gathers its nodes once for its 4 points. A rigid motion gives F = R, E = 0: no stress at
// any rotation angle. Node order is gmsh's (model.hpp). Units: m, Pa, N, J.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

/// Lame constants of a material, Pa.
struct Lame {
  double lambda = 0, mu = 0;
};
Lame lame_constants(const Material& material);
/// P-wave (dilatational) speed sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu))), m/s.
double dilatational_wave_speed(const Material& material);

/// The two mid-edge node rules of the gmsh 10-node tetrahedron: node 4 + k sits on edge kTet10Edges[k].
inline constexpr std::array<std::array<int, 2>, 6> kTet10Edges{{{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}}};

/// Shape functions N (4 or 10 values) at natural coordinates xi (corner k at xi = e_k, corner 0 at 0).
void tet_shape_functions(int nodes, const Eigen::Vector3d& xi, double* N);
/// dN/dxi, one row per node (4 or 10 rows written into `dN`, 3 columns).
void tet_shape_derivatives(int nodes, const Eigen::Vector3d& xi, Eigen::Matrix<double, 10, 3>& dN);

/// A quadrature rule on the reference tetrahedron (volume 1/6): points in natural coordinates.
struct TetRule {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> weights;
};
/// The rule the element forces use: 1 point for 4 nodes, the 4-point degree-2 rule for 10.
const TetRule& stiffness_rule(int nodes);
/// Collapsed (Duffy) Gauss-Legendre rule with 5 points per direction, exact to polynomial degree
/// 7: consistent-mass diagonals and inertia tensors of curved 10-node tetrahedra.
const TetRule& exact_rule();

/// Element e's reference map at natural point xi: J = dX/dxi, its inverse and determinant, and the
/// reference gradients dN_a/dX of its n nodes (rows 0..n-1). Throws DataError naming the element
/// when det J <= 0 (inverted or flat in the reference mesh).
struct ReferenceGradients {
  Eigen::Matrix3d inverse_jacobian;
  double det = 0;
  Eigen::Matrix<double, 10, 3> gradient;
};
ReferenceGradients reference_gradients(const Model& model, std::size_t element, const Eigen::Vector3d& xi);

/// The isotropic elasticity tensor applied to a strain (or strain rate): lambda tr(E) I + 2 mu E, Pa.
Eigen::Matrix3d isotropic_stress(const Eigen::Matrix3d& strain, const Lame& lame);

/// An element's small-strain stiffness, N/m: its top-left 3n x 3n corner (n = 4 or 10 nodes), row
/// and column 3 a + i for node a's component i.
using ElementStiffness = Eigen::Matrix<double, 30, 30>;
/// Element e's stiffness at `lame`, the tangent of the element forces in the reference state:
/// K_ab,ij = sum_q w_q [lambda g_a,i g_b,j + mu g_a,j g_b,i + mu (g_a . g_b) delta_ij] over
/// stiffness_rule's points, g the reference gradients. Writes the top-left corner of `K`; returns n.
int element_stiffness(const Model& model, std::size_t element, const Lame& lame, ElementStiffness& K);

/// Grain `grain`'s small-strain stiffness (element_stiffness of its elements at `lame`), its lower
/// triangle (row >= col) as triplets over the grain's local degrees of freedom 3 (node -
/// node_begin) + axis; those where `held` is set (empty: none) are left out.
std::vector<Eigen::Triplet<double>> grain_stiffness_lower(const Model& model, std::size_t grain, const Lame& lame,
                                                          std::span<const char> held = {});

/// Physical points and weights (w |det J|) of `rule` mapped through element e's reference shape.
void map_rule(const Model& model, std::size_t element, const TetRule& rule, std::vector<Eigen::Vector3d>& points,
              std::vector<double>& weights);

/// Signed reference volume of element e, m^3 (exact for curved 10-node elements).
double element_volume(const Model& model, std::size_t element);
/// Smallest altitude of element e's corner tetrahedron (3 V / largest face area), m.
double element_min_altitude(const Model& model, std::size_t element);

/// Precomputed reference gradients of the elements of the model's deformable grains (tet4/tet10);
/// elements of rigid grains are skipped (they carry no stress).
class ElasticElements {
 public:
  /// Throws DataError naming the element when one is inverted or degenerate in the reference.
  explicit ElasticElements(const Model& model);

  /// Subtracts the internal forces of elements [begin, end) at node positions x from f and returns
  /// their strain energy, J. Elements of rigid grains contribute nothing.
  double add_internal_forces(std::span<const Eigen::Vector3d> x, std::size_t begin, std::size_t end,
                             std::span<Eigen::Vector3d> f) const;
  /// Subtracts the stiffness-proportional (Rayleigh) damping forces of elements [begin, end) from f:
  /// the viscous stress S_v = beta (lambda tr(dE) I + 2 mu dE) of the strain rate dE = sym(F^T dF)
  /// (dF from the node velocities v) through the same f_a = sum_q w_q F S_v dN_a/dX as the elastic
  /// stress, i.e. beta times the material stiffness applied to v. A rigid motion has dE = 0: spin
  /// and flight are not damped. beta in s.
  void add_viscous_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v, double beta,
                          std::size_t begin, std::size_t end, std::span<Eigen::Vector3d> f) const;
  /// Strain energy of elements [begin, end), J.
  double strain_energy(std::span<const Eigen::Vector3d> x, std::size_t begin, std::size_t end) const;
  /// Cauchy stress (tension positive, Pa) at each quadrature point of element e: sigma = F S F^T / J.
  std::vector<Eigen::Matrix3d> cauchy_stress(std::span<const Eigen::Vector3d> x, std::size_t element) const;
  /// Deformation gradient at each quadrature point of element e.
  std::vector<Eigen::Matrix3d> deformation_gradient(std::span<const Eigen::Vector3d> x, std::size_t element) const;
  /// Volume-averaged Cauchy stress over the current volume of elements [begin, end) (tension
  /// positive, Pa): sum_q w_q F S F^T / sum_q w_q det F. Zero for rigid grains.
  Eigen::Matrix3d average_cauchy_stress(std::span<const Eigen::Vector3d> x, std::size_t begin, std::size_t end) const;

  bool is_elastic(std::size_t element) const { return slot_[element] != kNoSlot; }

 private:
  static constexpr std::uint32_t kNoSlot = 0xffffffffu;
  /// A 4-node element in one record, so the hot loop reads one stream: F = D G with
  /// D = [x1 - x0, x2 - x0, x3 - x0] (differences keep the grain's distance from the origin out of F).
  struct LinearTet {
    std::array<std::uint32_t, 4> nodes;
    std::uint32_t material;
    double volume;              ///< reference volume, m^3 (the one quadrature weight)
    Eigen::Matrix3d gradients;  ///< row a - 1 = dN_a/dX of node a = 1..3; node 0's is minus their sum, 1/m
  };

  /// F = [x1 - x0, x2 - x0, x3 - x0] G of a 4-node element.
  static Eigen::Matrix3d linear_deformation_gradient(std::span<const Eigen::Vector3d> x, const LinearTet& tet);
  /// Quadrature points of a 10-node element.
  static std::size_t quadratic_points();
  /// visit(w, F, S, psi) at every quadrature point of the element (none for a rigid grain's).
  template <class Visit>
  void for_each_point(std::span<const Eigen::Vector3d> x, std::size_t element, Visit&& visit) const;
  void add_linear_tet_forces(std::span<const Eigen::Vector3d> x, const LinearTet& tet, std::span<Eigen::Vector3d> f,
                             double& energy) const;
  void add_quadratic_tet_forces(std::span<const Eigen::Vector3d> x, std::size_t element, std::span<Eigen::Vector3d> f,
                                double& energy) const;
  /// Subtracts the forces of a 4-node element's first Piola-Kirchhoff stress times its volume, V F S.
  static void subtract_linear_tet_forces(const LinearTet& tet, const Eigen::Matrix3d& stress_volume, std::span<Eigen::Vector3d> f);

  const Model* model_;
  std::vector<Lame> lame_;                   ///< per material
  std::vector<std::uint32_t> slot_;          ///< per element: its LinearTet (4 nodes), its first quadrature point (10 nodes) or kNoSlot (rigid)
  std::vector<LinearTet> linear_;            ///< 4-node elements
  std::vector<double> weight_;               ///< 10-node elements, per quadrature point: w |det J| (reference volume share), m^3
  std::vector<double> gradient_;             ///< 10-node elements, per quadrature point: dN_a/dX, 3 per node, 1/m
};

/// Lumped node masses, kg, one per model node: row sums (rho V / 4) for 4-node elements; HRZ
/// diagonal scaling for 10-node elements (consistent diagonal scaled to the element's mass, so
/// every node gets a positive mass and the total is exact: straight-edged, corners m/36 and
/// mid-edge nodes 4m/27). Rigid grains' nodes get the lumping of their mesh kind.
std::vector<double> lumped_masses(const Model& model);
/// Adds the lumped masses of elements [element_begin, element_end) to `mass` (one per model node).
void add_lumped_masses(const Model& model, std::size_t element_begin, std::size_t element_end, std::span<double> mass);

/// Mass properties of one grain's mesh, exact for straight and curved elements.
struct BodyProperties {
  double mass = 0;                                           ///< kg
  double volume = 0;                                         ///< m^3
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();        ///< m
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();         ///< kg m^2, about the centroid, world axes
};
BodyProperties body_properties(const Model& model, std::size_t grain);

}  // namespace graintwin::fdem
