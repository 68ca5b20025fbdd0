#pragma once
// A shape library read from a segmented scan: the grains of a kind=shapes file, each as the
// smoothed indicator of its label's voxels in the scan's kind=labels file (solid_grains.hpp:
// VoxelGrain), so that ctsynth can pack and render the grains users scan, cavities, overhangs and
// all, with exact ground truth (docs/ctsynth.md, "Grains from a scan").
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/synth/grains.hpp"

namespace graintwin::synth {

/// Gaussian sigma (voxels) with which a library grain's indicator is smoothed: the value
/// labels2shapes uses to read a sub-voxel surface from labels.
inline constexpr double kLibrarySmoothingVox = 0.7;

struct ShapeLibrary {
  Volume<std::uint32_t> labels;  ///< the scan's label image
  struct Entry {
    std::uint32_t label = 0;
    std::array<std::size_t, 6> bbox{};   ///< (z0, y0, x0, z1, y1, x1), half-open, in `labels`
    Eigen::Vector3d centroid{0, 0, 0};   ///< m (x, y, z), mean of the voxel centres
    double volume = 0.0;                 ///< m^3, voxel count x voxel volume
  };
  std::vector<Entry> grains;      ///< the usable grains, in the shapes file's order
  std::size_t left_out = 0;       ///< grains cut by the field of view, too small, or with the centroid outside
};

/// Reads the grains of `shapes` (kind=shapes) with their voxels from `labels` (kind=labels, the
/// file the shapes were measured from). Grains flagged touches_edge, small or centroid_outside are
/// left out (counted in left_out). UsageError naming the file if either is not of its kind, if the
/// shapes name labels the label image lacks, or if no grain is usable.
ShapeLibrary read_shape_library(const std::filesystem::path& shapes, const std::filesystem::path& labels);

/// The solid of library grain `index`: its indicator, padded by 3 voxels plus the smoothing's
/// reach, smoothed by kLibrarySmoothingVox, cut at the level that keeps its voxel volume
/// (volume_preserving_level), in a body frame at its centroid with the scan's axes.
VoxelGrain library_grain(const ShapeLibrary& library, std::size_t index);

/// Library grains, drawn uniformly with replacement, until their volume reaches `volume` (m^3): the
/// sample's grains. UsageError if the library is empty.
std::vector<std::size_t> draw_library_grains(const ShapeLibrary& library, double volume, std::mt19937_64& rng);

/// The grain set of the drawn grains (draws index library.grains): every grain's solid (shared
/// between draws of one library grain), its star hull as its table (tabulated for `voxel_size`, the
/// scans' voxel), the SH fit of degree `degree` to its last exits, its statistics and its
/// NonStarMeasures. Parallel over the distinct grains; `progress` receives the fraction done.
GrainSet make_library_grains(const ShapeLibrary& library, const std::vector<std::size_t>& draws, int degree,
                             double voxel_size, const std::function<void(double)>& progress = {});

}  // namespace graintwin::synth
