#pragma once
// shapes2tracks' stage: a series of scans' shapes files in, the content of a kind=tracks file out
// (grains matched scan to scan, chained into tracks, their displacements and rotations).
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/track/tracks.hpp"
#include "graintwin/track/tracks_file.hpp"

namespace graintwin::track {

/// The tracks of the scans whose kind=shapes files are `paths` (in scan order): each file read
/// (errors name it; DataError when it holds no grain), consecutive scans matched and chained
/// (chain_tracks with `chain`), then every track's displacements (m) and rotations
/// (track_kinematics with `rotation`). `parameters_json` records the options. `progress` (may be
/// empty) makes the progress callback of each step ("reading", "matching", "rotations") as the step
/// starts, and releases it when the step ends (a display held only by it then finishes).
TracksFile track_series(const std::vector<std::filesystem::path>& paths, const ChainOptions& chain,
                        const RotationOptions& rotation,
                        const std::function<std::function<void(double)>(const std::string&)>& progress = {});

/// The options of a run as the JSON object stored in /tracks/parameters: method, window, volume
/// filter, gap, backward check and rotation settings, and the improved matcher's own settings.
std::string tracks_parameters_json(const ChainOptions& chain, const RotationOptions& rotation);

}  // namespace graintwin::track
