#pragma once
// Where a run's time goes, step phase by phase (as LAMMPS prints at the end of a run): the solver
// adds to it every step, fdemrun and the benches report it.
#include <cstdint>
#include <string>

namespace graintwin::fdem {

/// Wall-clock seconds the solver's steps spent in each phase (each phase runs on the run's threads).
struct StepTimes {
  double elements = 0;  ///< internal forces of the deformable grains
  double contact = 0;   ///< grain-grain and grain-platen contact: broad and narrow phase
  double boundary = 0;  ///< the sample boundary: servo wall, or membrane bonds, pressure and ball contacts
  double motion = 0;    ///< integration of grains and platens, energy books
  std::uint64_t steps = 0;
  /// Steps with a boundary that has its own bodies (membrane balls): their count summed over those
  /// steps, and the boundary's seconds in them.
  std::uint64_t body_steps = 0;
  double body_seconds = 0;
  /// Contact work summed over the steps (ContactStepStats): node contacts, surface nodes tested against another
  /// grain or a platen, closest-point evaluations, and rigid pairs whose near-node lists were built
  /// again between broad-phase builds.
  std::uint64_t node_contacts = 0;
  std::uint64_t node_checks = 0;
  std::uint64_t triangle_checks = 0;
  std::uint64_t pair_lists_built = 0;

  double total() const { return elements + contact + boundary + motion; }
};

/// One line for a run's log: steps, time per step, grain-steps per second (and per thread), each
/// phase's share, the contact work per step and, with a membrane, its cost per ball and step.
std::string describe_step_times(const StepTimes& times, std::size_t grains, int threads);

}  // namespace graintwin::fdem
