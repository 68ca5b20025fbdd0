#pragma once
// A deformable grain stepped implicitly in its corotated frame: the way past the element time step
// (docs/fdemrun.md, implicit grains; [run] deformable_integration = "implicit").
//
// Why: quartz grains of 10-node elements need a step some 340 times shorter than the rigid twin's
// contact step (their element wave speed over their smallest altitude), while under quasi-static
// loading their strains are ~1e-5 and their internal vibrations carry nothing of the test.
//
// How: the grain's best-fit rotation R about its mass centre c (shape matching: the polar factor of
// sum_i m_i (x_i - c)(X_i - C)^T) carries its rigid motion; in that frame its strain is small, so its
// elastic forces are the reference small-strain stiffness K on the displacement u = R^T (x - c) - (X - C).
// One step of h, with R held over it (backward Euler in velocity, stiffness warping), with
// mass-proportional damping alpha inside the step:
//   ((1 + alpha h) M + h^2 K) w' = M w + h (R^T f - K u),   w = R^T v,   v' = R w',   x' = x + h v'
// M the lumped node masses (the same in any frame), f the node forces besides the elastic and
// damping ones (contact, gravity). The matrix is factored once for a step h and a damping alpha.
// Damping inside the step matters: taken from the last step's velocities, it would feed a mode that
// flips sign every step (a grain pressed by many contact nodes at once) instead of damping it. Unconditionally stable for
// the elastic modes, which it damps where omega h >> 1 (the stiff ones a quasi-static test does not
// resolve) and leaves nearly undamped where omega h << 1; a rigid motion (K u = 0) moves as it would
// by x' = x + h v'. At rest under loads f it holds K u = R^T f: the small-strain static state.
#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/node_blocks.hpp"

namespace graintwin::fdem {

class ImplicitGrain {
 public:
  /// Grain `grain` of `model` (4- or 10-node elements, its material's E and nu) with the lumped
  /// `node_mass` (kg, one per model node), for steps of `dt` (s, > 0) under mass-proportional
  /// `damping` (1/s, >= 0). Throws DataError naming the grain when it has no elements or mass, or
  /// the step's matrix is not positive definite.
  ImplicitGrain(const Model& model, std::size_t grain, std::span<const double> node_mass, double dt, double damping = 0);

  /// Node arrays below are the grain's own: its node_count() nodes, in the model's order.
  /// The grain's best-fit frame at node positions `x`: its node with reference position X lies near
  /// centre + rotation (X - reference_centre()), centre the mass centre of its nodes.
  struct Frame {
    Eigen::Matrix3d rotation;
    Eigen::Vector3d centre;
  };
  Frame frame(std::span<const Eigen::Vector3d> x) const;
  /// The mass centre of the grain's nodes at the model's positions, m.
  const Eigen::Vector3d& reference_centre() const { return reference_centre_; }
  /// One step's energies (J), booked as leapfrog books them: kinetic energy and work at the mean of
  /// the step's two velocities.
  struct StepEnergies {
    double strain_start = 0;  ///< 1/2 u^T K u before the step
    /// after it, with the step's R (which differs from the next step's fit by the rotation's second order)
    double strain_end = 0;
    double kinetic_start = 0, kinetic_end = 0;  ///< at the step's first and last velocities
    double kinetic_mean = 0;                    ///< at their mean
    double work = 0;                            ///< of f and gravity, at the mean velocities
    double gravity_work = 0;                    ///< of gravity alone
    /// What entered less what the grain gained: lost to the damping and to backward Euler.
    double lost() const { return work - (kinetic_end - kinetic_start) - (strain_end - strain_start); }
  };
  /// One step of dt: the grain's nodes at `x` moving at `v` (at the half step) move under the forces
  /// `f` on them (N, without the elastic and gravity ones) and the acceleration of `gravity` (m/s^2).
  /// Over a step the rigid motion is leapfrog's, so the work of a force at its mean velocity is
  /// exactly what the end velocities' kinetic energy gains.
  /// `at`: frame(x), when the caller has it already. Keeps its workspace between calls: one grain
  /// steps on one thread at a time.
  StepEnergies step(std::span<Eigen::Vector3d> x, std::span<Eigen::Vector3d> v, std::span<const Eigen::Vector3d> f,
                    const Eigen::Vector3d& gravity = Eigen::Vector3d::Zero(), const Frame* at = nullptr);
  /// The body-frame displacement u = R^T (x - c) - (X - C) of each node of the grain at `x`, m.
  std::vector<Eigen::Vector3d> displacement(std::span<const Eigen::Vector3d> x) const;

  double time_step() const { return dt_; }
  double damping() const { return damping_; }
  std::size_t node_count() const { return node_count_; }

 private:
  std::size_t node_count_ = 0;
  double dt_ = 0, damping_ = 0;
  std::vector<double> mass_;                 ///< per local node, kg
  std::vector<Eigen::Vector3d> reference_;   ///< X - C per local node, m
  Eigen::Vector3d reference_centre_;         ///< C, m
  double total_mass_ = 0;
  SymmetricNodeBlocks stiffness_;  ///< K, local dofs
  NodeBlockLdlt factor_;           ///< of (1 + damping dt) M + dt^2 K
  Eigen::VectorXd u_, Ku_, rhs_, w_;  ///< the step's workspace (local dofs)
};

}  // namespace graintwin::fdem
