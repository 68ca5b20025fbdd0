#pragma once
// Mass scaling for the time step, two kinds for two limits; both only add inertia where it matters
// little when the whole sample moves slowly (quasi-static runs).
// - Density scaling of the few grains that set the contact step. An explicit step is bounded by the
//   stiffest contact on the lightest grain: on the soil crop's twin three grains of a third of the
//   d50 set it at 7.4e-8 s while the median grain allows 2.6e-7 s. The fastest `share` of the grains
//   get a density that lifts their own limit to that of the next grain, so the step is the rest's.
// - Selective mass scaling of the elements that set the element step of deformable grains: each
//   element whose stable step is below a target gets the density that lifts it to the target, so
//   mass goes only where the mesh is finest; the mass added is bounded (a share of the grains' mass).
#include <cstddef>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

struct MassScaling {
  std::size_t grains = 0;         ///< grains whose density was scaled
  double largest_factor = 1;      ///< the largest density factor
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

/// What selective mass scaling did (nothing: elements 0 and steps unchanged).
struct ElementMassScaling {
  double target_step = 0;      ///< s, the element stable step asked for
  double step_before = 0;      ///< s, the element stable limit before
  double step_after = 0;       ///< s, after (the target, or step_before when it was already above)
  std::size_t elements = 0;    ///< elements made denser
  double largest_factor = 1;   ///< their largest density factor
  double added_mass = 0;       ///< kg
  double grains_mass = 0;      ///< kg, before (grains_mass)
  double max_added_share = kDefaultMaxAddedMassShare;  ///< the bound it was held to
  double added_share() const { return grains_mass > 0 ? added_mass / grains_mass : 0.0; }
};

/// Lifts the element stable step of `solver` (not yet stepped or element-scaled) to `target_step`
/// (s): every deformable element whose stable step (critical step, damped by `stiffness_damping`,
/// times the element safety) is below it gets the density factor (needed / own critical step)^2,
/// its added mass (factor - 1) rho V going to its nodes (Solver::scale_element_densities). UsageError
/// naming `where` (the scene file), before any change, when the mass added would exceed
/// `max_added_share` of the grains' mass: with the share, the bound, the elements and the step, and
/// the fix.
ElementMassScaling scale_limiting_elements(Solver& solver, double target_step, double stiffness_damping,
                                           double max_added_share, const std::string& where);

}  // namespace graintwin::fdem
