#pragma once
// The initial state's overlaps (docs/fdemrun.md, "Before the first step"). Penalty contact turns an
// overlap into a force proportional to its depth, so a grain started deep inside another or behind
// a platen is fired off at an absurd speed on the first step, and an overlap deeper than the step's
// contact search (a tenth of the smallest grain) is not seen at all, so two boxes started through
// each other never part. A run therefore starts only when no grain reaches into another grain or
// behind a platen deeper than a tolerance, a fraction of the (smaller) grain's equivalent diameter;
// grains that touch, or overlap slightly as CT-derived grains do, pass. A scene may instead ask for
// the overlaps to be relaxed before the run: the grains are moved apart (rigid translations, before
// any velocity acts) until no overlap exceeds a hundredth of the tolerance.
#include <cstddef>
#include <string>
#include <vector>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/solver.hpp"

namespace graintwin::fdem {

struct OverlapOptions {
  /// Deepest overlap accepted, as a fraction of the smaller grain's equivalent diameter (of the
  /// grain's own for a platen).
  double tolerance = 0.1;
  /// Move overlapping grains apart before the run instead of refusing the state.
  bool relax = false;
  /// The overlaps the run starts with (within the tolerance) carry no force
  /// (ContactModel::keep_initial_overlaps): a scanned twin's contacts start in place and at rest.
  bool keep = false;
};

/// What settle_initial_overlaps found and did.
struct OverlapSettlement {
  double deepest = 0;               ///< m, the deepest overlap at the start (before any relaxation)
  std::size_t beyond = 0;           ///< pairs (grain or platen) beyond the tolerance at the start
  std::size_t passes = 0;           ///< relaxation passes (0: nothing was moved)
  std::size_t moved_grains = 0;
  double largest_move = 0;          ///< m, the longest translation of a grain
  double deepest_after = 0;         ///< m, the deepest overlap left after relaxation
  std::vector<Overlap> remaining;   ///< the overlaps the run starts with (after any relaxation)
};

/// Checks the initial overlaps of `solver`'s grains with each other and with its platens, on the
/// solver's own contact model (ContactModel::overlaps, through the broad phase: under a second for
/// 16 000 grains); nothing without contact, where overlaps do nothing. `model` is the solver's
/// model. Any overlap beyond options.tolerance times the smaller grain's equivalent diameter
/// (6 V / pi)^(1/3) is refused with UsageError naming `where` (the scene file), the grains by label
/// or the platen by name, the depth, the tolerance and the scene keys that set the tolerance and
/// allow relaxation, unless options.relax: then the grains of `model` are moved apart, in passes,
/// until no overlap exceeds a hundredth of its tolerance, and the solver must be built anew on it
/// (the result's passes > 0). Each pass takes every overlap beyond that and parts it by its depth
/// plus a hundredth of its tolerance: both grains along the line of their centroids by half of it,
/// a grain behind a platen along the platen's normal by all of it; each grain moves by the mean of
/// its pushes. UsageError when grains have no room to part (e.g. a grain taller than the gap between
/// two platens) after a few hundred passes.
OverlapSettlement settle_initial_overlaps(Solver& solver, Model& model, const OverlapOptions& options,
                                          const std::string& where);

}  // namespace graintwin::fdem
