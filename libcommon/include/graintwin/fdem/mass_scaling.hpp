#pragma once
// Mass scaling for the time step, two kinds for two limits; both only add inertia where it matters
// little when the whole sample moves slowly (quasi-static runs).
// - Density scaling of the few grains that set the contact step. An explicit step is bounded by the
//   stiffest contact on the lightest grain: on the soil crop's twin three grains of a third of the
//   d50 set it at 7.4e-8 s while the median grain allows 2.6e-7 s. The fastest `share` of the grains
//   get a density that lifts their own limit to that of the next grain, so the step is the rest's.
// - Selective mass scaling of the nodes that set the element step of deformable grains: each node
//   whose mass does not guarantee a target step against Gershgorin's bound on its stiffness rows
//   gets the mass that does, so mass goes only where the mesh is finest or flattest and the target is
//   stable by proof rather than by a per-element estimate; the mass added is bounded (a share of the
//   grains' mass).
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

struct MassScaling {
  std::size_t grains = 0;         ///< grains whose density was scaled
  double largest_factor = 1;      ///< the largest density factor of a grain
  double mass_share = 0;          ///< their share of the grains' mass, before scaling
  double step_before = 0;         ///< s, the contact step limit before
  double step_after = 0;          ///< s, the limit the scaled grains were lifted to
  std::vector<std::uint32_t> scaled;  ///< indices of the scaled grains, and their factors
  std::vector<double> factors;
};

/// Scales the density of the `share` (0 to 0.2) of `model`'s grains with the smallest contact time
/// steps (ContactModel::grain_time_steps on `solver`, built on `model`) so that each reaches the
/// step of the fastest grain left unscaled: factor (target / own)^2, through a copy of the grain's
/// material per scaled grain (named "<material> x<factor>"). The solver must be built anew on the
/// model afterwards. Nothing without contact or for share 0. UsageError for a share outside [0, 0.2].
MassScaling scale_fastest_grains(Model& model, const Solver& solver, double share);

/// The grains' mass, kg: the sum of their bodies' masses at the model's densities (the reference of
/// both kinds' shares).
double grains_mass(const Solver& solver);

/// The default bound of selective mass scaling: the mass it may add, a share of the grains' mass.
inline constexpr double kDefaultMaxAddedMassShare = 0.01;

/// Per model node, Gershgorin's bound on its rows of the deformable grains' assembled small-strain
/// stiffness, N/m: the largest over its three rows of sum_e sum_j |K_e,ij| (element_stiffness); 0 for
/// the nodes of rigid grains. With lumped masses m every natural frequency obeys
/// omega^2 <= max_i bound_i / m_i, so a central-difference step of 2 sqrt(m_i / bound_i) at every
/// node is stable, however small or flat the elements among larger ones.
std::vector<double> node_stiffness_bounds(const Model& model);
/// The undamped critical step, s, that the node masses guarantee against `bounds`: the least over
/// nodes with a bound of 2 sqrt(m_i / bound_i); infinity when no node has one.
double guaranteed_critical_step(std::span<const double> bounds, std::span<const double> node_mass);

/// What selective mass scaling did (nothing: nodes 0 and steps unchanged).
struct SelectiveMassScaling {
  double target_step = 0;      ///< s, the element stable step asked for
  double step_before = 0;      ///< s, the element stable limit before (the elements' estimate)
  double step_after = 0;       ///< s, after: the step the node masses now guarantee (at least the target)
  double guaranteed_before = 0;  ///< s, the stable step the unscaled masses guarantee, for comparison
  std::size_t nodes = 0;       ///< nodes made heavier
  double largest_factor = 1;   ///< their largest mass factor
  double added_mass = 0;       ///< kg
  double grains_mass = 0;      ///< kg, before (grains_mass)
  double max_added_share = kDefaultMaxAddedMassShare;  ///< the bound it was held to
  double added_share() const { return grains_mass > 0 ? added_mass / grains_mass : 0.0; }
};

/// Lifts the element stable step of `solver` (not yet stepped or scaled) to `target_step` (s) with a
/// guarantee: every node of a deformable grain whose mass does not certify the undamped critical step
/// behind the target (the target over the element safety, undone of `stiffness_damping`) against its
/// node_stiffness_bounds row gets the mass that does, bound_i dt^2 / 4 (Solver::add_node_masses), so
/// mass goes only to the nodes of the smallest and flattest elements. UsageError naming `where` (the
/// scene file), before any change, when the mass added would exceed `max_added_share` of the grains'
/// mass: with the share, the bound, the nodes and the step, and the fix. Nothing when the target is
/// not above the elements' estimate.
SelectiveMassScaling scale_limiting_nodes(Solver& solver, double target_step, double stiffness_damping,
                                          double max_added_share, const std::string& where);

}  // namespace graintwin::fdem
