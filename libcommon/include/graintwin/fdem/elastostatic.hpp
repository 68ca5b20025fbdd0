#pragma once
// Intra-grain stress of a grain that moves as a rigid body: the small-strain linear-elastic static
// state of its reference mesh under the nodal loads of one moment of a run, relieved of their net
// force and moment by the rigid acceleration those give the body (inertia relief).
//
// Why (docs/fdemrun.md, intra-grain stress of rigid grains): quartz grains at E ~ 1e11 Pa under
// contact stresses of MPa strain by ~1e-5, so their deformation changes no contact, and an
// explicit deformable twin spends its cost resolving elastic vibrations at steps some 200 times
// shorter than the rigid twin's, which carry nothing of a quasi-static test. The static solution
// of each grain under its contact forces is what those vibrations settle to.
#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

/// One grain's static state under a load: what ElastostaticGrain::solve returns. Reference axes.
struct ElastostaticState {
  std::vector<Eigen::Vector3d> displacement;  ///< per node of the grain, m (zero at the three support nodes' held components)
  std::vector<Eigen::Matrix3d> stress;        ///< per element of the grain, volume average, tension positive, Pa
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();          ///< of the mass centre, m/s^2 (net force / mass)
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();  ///< rad/s^2 (inertia^-1 net moment about the mass centre)
};

class ElastostaticGrain {
 public:
  /// Assembles and factorizes grain `grain`'s small-strain stiffness (its material's E and nu; its
  /// mesh's 4- or 10-node elements with the element forces' quadrature, whatever the grain's kind),
  /// with six components at three far-apart nodes held against rigid motion (3-2-1: a
  /// self-equilibrated load leaves them without reaction, so the stress does not depend on them).
  /// node_mass: lumped masses, kg, one per model node (lumped_masses). Throws DataError naming the
  /// grain when it has no elements, an element is inverted or degenerate in the reference, or the
  /// stiffness is singular (a mesh in several pieces).
  ElastostaticGrain(const Model& model, std::size_t grain, std::span<const double> node_mass);

  /// The static state under `loads`, one per node of the grain (node_begin .. node_end), N, in the
  /// reference axes (a rigid grain's body frame: the world loads turned by R^T). The loads' net
  /// force F and moment M about the mass centre are first balanced by the rigid acceleration field
  /// a + alpha x r (a = F / m, alpha = I^-1 M, with the lumped masses): the body is loaded by
  /// f_i - m_i (a + alpha x r_i). Throws UsageError when `loads` has the wrong length.
  ElastostaticState solve(std::span<const Eigen::Vector3d> loads) const;

  std::size_t node_count() const { return node_count_; }
  std::size_t element_count() const { return elements_.size(); }

 private:
  /// One quadrature point of an element: its weight w |det J| (m^3) and dN_a/dX of its nodes.
  struct Point {
    double weight = 0;
    std::array<Eigen::Vector3d, 10> gradient;
  };
  struct Element {
    std::array<std::uint32_t, 10> nodes{};  ///< local node indices (node - node_begin)
    int node_count = 4;
    std::vector<Point> points;
  };

  std::size_t node_begin_ = 0, node_count_ = 0;
  Lame lame_;  ///< of the grain's material, Pa
  std::vector<Element> elements_;
  std::vector<double> mass_;               ///< per local node, kg
  std::vector<Eigen::Vector3d> arm_;       ///< per local node, from the mass centre, m
  double total_mass_ = 0;
  Eigen::Matrix3d inverse_inertia_ = Eigen::Matrix3d::Zero();  ///< of the lumped masses about the mass centre
  std::array<std::size_t, 6> held_{};      ///< the held degrees of freedom, 3 node + axis
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> factor_;
};

}  // namespace graintwin::fdem
