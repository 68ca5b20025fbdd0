#pragma once
// What one file of a checkpoint holds (docs/formats.md, fdem_checkpoint): everything (one rank), or
// on R ranks each rank's file the rows of the grains it advanced, written at once by every rank.
#include <cstdint>
#include <vector>

namespace graintwin::fdem {

struct CheckpointPart {
  /// The grains whose rows the file holds (bodies, loads, nodes, their contacts' friction history
  /// and records), sorted; nullptr: every grain, in a file that names none.
  const std::vector<std::uint32_t>* grains = nullptr;
  /// Whether it also holds what every rank holds alike: the step, time and energy books, the
  /// platens and their forces, the sample boundary, the membrane balls' friction and the deep pairs.
  bool shared = true;
};

}  // namespace graintwin::fdem
