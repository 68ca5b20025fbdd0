#pragma once
// Trajectories across a series of scans (docs/shapes2tracks.md): consecutive scans are matched, the
// matches chain into tracks, a grain lost at one step may be found again in a later scan by
// matching the lost grains against the unclaimed grains of that scan (seeded by the tracks present
// in both), and unclaimed grains start new tracks. Then each track's kinematics: displacement
// and rotation.
#include <Eigen/Core>
#include <functional>
#include <vector>

#include "graintwin/shape/shapes_file.hpp"
#include "graintwin/track/match.hpp"
#include "graintwin/track/rotation.hpp"

namespace graintwin::track {

struct ChainOptions {
  MatchOptions match;
  /// Scans a lost grain may stay missing and still be found again (0: lost is final). With 1, a
  /// grain missing from scan k is looked for in scan k+1 among the grains nobody claimed.
  int max_gap = 1;
};

/// Per scan t: how tracks came into it.
struct StepCounts {
  std::size_t grains = 0;   ///< grains in scan t
  std::size_t matched = 0;  ///< tracks continued from scan t-1
  std::size_t lost = 0;     ///< tracks present in scan t-1 and missing from scan t
  std::size_t found = 0;    ///< tracks missing from scan t-1 (lost earlier) found again in scan t
  std::size_t started = 0;  ///< new tracks (grains no track claimed; all grains of scan 0)
  double mean_confidence = 0.0;  ///< over the matched and found
};

struct Tracks {
  std::size_t scans = 0;
  /// Per track, per scan: the grain's index in that scan, or -1 where the track is missing.
  std::vector<std::vector<int>> grain;
  /// Per track, per scan: confidence of the match that brought the track into that scan (NaN in
  /// its first scan and where it is missing).
  std::vector<std::vector<double>> confidence;
  std::vector<StepCounts> steps;                 ///< one per scan
  std::vector<MatchDiagnostics> diagnostics;     ///< one per step t-1 -> t (index t-1)
  std::size_t size() const { return grain.size(); }
};

/// Matches scans[t-1] to scans[t] for every t and chains the matches. `progress` (may be empty)
/// gets the fraction of steps done.
Tracks chain_tracks(const std::vector<ScanGrains>& scans, const ChainOptions& options,
                    const std::function<void(double)>& progress = {});

/// Per track and scan (track-major, then scan; NaN where not defined).
struct Kinematics {
  std::size_t tracks = 0, scans = 0;
  std::vector<double> centroid;       ///< x 3, m
  std::vector<double> displacement;   ///< x 3, m: from the track's first scan
  std::vector<double> increment;      ///< x 3, m: from the track's previous scan (t-1, or the scan it was lost after)
  std::vector<double> rotation;       ///< x 4 (w, x, y, z): from the first scan, while every step is defined
  std::vector<double> rotation_step;  ///< x 4 (w, x, y, z): from the previous scan
  std::vector<double> rotation_misfit;  ///< x 1: surface misfit of the step's rotation / equivalent radius
  std::vector<std::uint8_t> rotation_defined;  ///< x 1: 1 if rotation_step is defined
};

/// Displacements and rotations of every track. `shapes` are the scans' shapes files (grains in
/// the same order as the ScanGrains given to chain_tracks). Parallel over tracks (OpenMP).
Kinematics track_kinematics(const Tracks& tracks, const std::vector<const shape::ShapesFile*>& shapes,
                            const RotationOptions& options, const std::function<void(double)>& progress = {});

}  // namespace graintwin::track
