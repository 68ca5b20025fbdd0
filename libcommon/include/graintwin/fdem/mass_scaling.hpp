#pragma once
// Density scaling of the few grains that set the time step. An explicit step is bounded by the
// stiffest contact on the lightest grain: on the soil crop's twin three grains of a third of the d50
// set it at 7.4e-8 s while the median grain allows 2.6e-7 s. Quasi-static runs commonly scale the
// density of such grains (their inertia matters little when the whole sample moves slowly): here
// the fastest `share` of the grains get a density that lifts their own limit to that of the next
// grain, so the step is the rest's.
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

}  // namespace graintwin::fdem
