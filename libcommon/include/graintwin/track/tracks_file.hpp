#pragma once
// `kind=tracks` files (docs/formats.md): trajectories of grains across a series of scans, with
// displacements, rotations, confidences and per-step counts; and the VTK polydata view of them
// for ParaView. Written by shapes2tracks.
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "graintwin/io/h5file.hpp"
#include "graintwin/track/tracks.hpp"

namespace graintwin::track {

struct TracksFile {
  std::vector<std::string> scans;  ///< the shapes files, in order
  std::vector<double> d50;         ///< m, per scan
  std::vector<std::vector<std::uint32_t>> scan_labels;  ///< per scan: label of each grain (to turn indices into labels)
  Tracks tracks;
  Kinematics kinematics;
  std::string parameters_json;     ///< what the run used (free-form JSON object)
};

void write_tracks_file(const std::filesystem::path& path, const TracksFile& content,
                       const std::vector<std::string>& history);

/// What readers get back: the label table and every per-track array as stored (flat, track-major).
struct TracksTable {
  std::size_t tracks = 0, scans = 0;
  std::vector<std::uint32_t> label;   ///< N x T, 0 = missing
  std::vector<double> centroid, displacement, increment;  ///< N x T x 3
  std::vector<double> rotation, rotation_step;            ///< N x T x 4
  std::vector<std::uint8_t> rotation_defined;             ///< N x T
  std::vector<double> confidence;                         ///< N x T
  std::vector<std::uint64_t> matched, lost, found, started, grains;  ///< T
  std::vector<std::string> scan_files;
  std::vector<double> scan_d50;  ///< T, m: d50 of each scan's grains
  std::string parameters_json;
};
/// UsageError naming the file if it is not a tracks file; DataError if its tables disagree.
TracksTable read_tracks_file(const std::filesystem::path& path);
/// The labels, in the first scan, of the grains whose tracks reach the last scan.
std::set<std::uint32_t> labels_tracked_throughout(const TracksTable& tracks);

/// The checks the report makes on the tables of an open kind=tracks file before it draws from them
/// (io/table_checks): the /tracks, /steps and /scans columns agree in length, and no /tracks
/// column holds infinity (NaN is a track's "not in this scan"). DataError naming the file and column.
void check_tracks_tables(const io::H5File& file);

/// The tracked centroids alone (/tracks/centroid, N x T x 3 flat and track-major, m, NaN where a
/// track misses a scan), for readers that need only the positions (the report's strains).
struct TrackedCentroids {
  std::size_t tracks = 0, scans = 0;
  std::vector<double> centroid;
};
/// UsageError naming the file if it is not a tracks file; DataError if the table is not N x T x 3.
TrackedCentroids read_tracked_centroids(const std::filesystem::path& path);

/// Grain points for ParaView: one point per track at its first position; point arrays `track`,
/// `first_scan`, and per scan t >= 1 `displacement_t` (from the first scan), `increment_t` (from
/// the previous scan), `confidence_t` and `tracked_t` (1 present, 0 missing); vectors are zero
/// where the track is missing (ParaView's glyphs cannot take NaN).
void write_tracks_vtp(const std::filesystem::path& path, const TracksFile& content);

}  // namespace graintwin::track
