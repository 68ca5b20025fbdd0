#pragma once
// tracks2micro's stage (docs/tracks2micro.md): the states of a tracked series (the tracks with the
// scans' shapes files, and contacts files when given) or of a simulation's frames, then the
// micro-mechanics of their increments (analyse_series), as the content of a kind=micro file.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/io/h5file.hpp"
#include "graintwin/micro/analysis.hpp"
#include "graintwin/micro/micro_file.hpp"

namespace graintwin::micro {

/// The tables of a kind=tracks file that micro-mechanics uses (N tracks, T scans), as
/// track::read_tracks_file reads them: micro builds on no tracking code, its tool hands them over.
struct TrackedGrains {
  std::size_t tracks = 0, scans = 0;
  std::vector<std::uint32_t> label;    ///< N x T, the grain's label in each scan, 0 = missing
  std::vector<double> centroid;        ///< N x T x 3, m
  std::vector<std::string> scan_files; ///< T: the shapes file of each scan, as the tracks file names it
  std::vector<double> scan_d50;        ///< T, m
};

/// The states of the tracked series `tracks` (read from `tracks_name`): the tracks' centroids, each
/// scan's grain volumes, d50 and PSD from its shapes file (those the tracks file names, or
/// `shapes_override`, one per scan), and coordination numbers from `contacts` (one kind=contacts
/// file per scan) when given. `input_opened` (may be empty) is called with every file opened, once
/// its kind is checked, in reading order. UsageError for a single scan, lists of the wrong length
/// and missing files; DataError when a shapes file lacks grains the tracks name.
MicroFile tracked_states(const TrackedGrains& tracks, const std::string& tracks_name,
                         const std::vector<std::filesystem::path>& shapes_override,
                         const std::vector<std::filesystem::path>& contacts,
                         const std::function<void(const io::H5File&)>& input_opened = {});

/// The states of a simulation: every frame of the kind=fdem_results file `results`, every grain in
/// each, volumes from its grain table and coordination numbers from each frame's grain-grain
/// contacts. UsageError for a single frame.
MicroFile simulated_states(const std::filesystem::path& results);

/// Analyses the states of `content` (from tracked_states or simulated_states, read from `input` of
/// kind `source_kind`: tracks or fdem_results): the increment `from` -> `to`, or with both negative
/// every pair of consecutive states, with `options`; fills content.result and its parameters
/// JSON. UsageError when `from` or `to` names no state. `progress` (may be empty) makes the
/// progress callback of the named step "micro-mechanics" when the analysis starts.
void analyse_states(MicroFile& content, const std::string& input, const std::string& source_kind, long long from, long long to,
                    const MicroOptions& options,
                    const std::function<std::function<void(double)>(const std::string&)>& progress = {});

/// What a state is called in messages: "frame" for a simulation (source kind fdem_results), else "scan".
const char* state_noun(const std::string& source_kind);

}  // namespace graintwin::micro
