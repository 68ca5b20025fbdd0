#pragma once
// Sphere phantoms with exact answers, shared by the segmentation tests: painted masks, jittered
// lattices and noisy synthetic scans (the spam / kalisphera protocol); shapes files of spheres.
#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "graintwin/core/volume.hpp"

namespace graintwin::test {

/// A sphere in voxel coordinates (centre z, y, x and radius, all in voxels).
struct Ball {
  double z, y, x, r;
};

/// Mask of the union of the balls: 1 where the voxel centre lies inside one.
Volume<std::uint8_t> paint_balls(Shape3 shape, const std::vector<Ball>& balls, Vec3 voxel = {1e-5, 1e-5, 1e-5},
                                 Vec3 origin = {0.0, 0.0, 0.0});

/// Labels of the balls: voxel centre inside ball i gets i + 1 (the later ball wins an overlap).
Volume<std::uint32_t> label_balls(Shape3 shape, const std::vector<Ball>& balls, Vec3 voxel = {1e-5, 1e-5, 1e-5});

/// Simple-cubic lattice of n^3 balls of radius r (+- radius_jitter * r), spacing `step`, the first
/// centre at `first`, each centre moved by up to +- jitter voxels along each axis.
std::vector<Ball> jittered_lattice(int n, double r, double step, double first, double jitter, double radius_jitter,
                                   std::uint32_t seed);

/// A synthetic scan of the balls: 2x2x2 supersampled occupancy, grey 0.25 + 0.5 occupancy,
/// Gaussian blur 0.8 voxel, Gaussian noise of the given standard deviation.
Volume<float> scan_balls(Shape3 shape, const std::vector<Ball>& balls, std::uint32_t seed, double noise = 0.03,
                         Vec3 voxel = {1e-5, 1e-5, 1e-5});

/// Writes a shapes file (kind=shapes) of equal spheres of `diameter` (m), degree-0 SH surfaces,
/// with these labels and centroids (m).
void write_sphere_shapes(const std::filesystem::path& path, const std::vector<std::uint32_t>& labels,
                         const std::vector<Eigen::Vector3d>& centroids, double diameter, const std::string& history);

/// The scan as a uint16 file stores it: round(4000 x grey), with f's geometry.
Volume<std::uint16_t> uint16_scan(const Volume<float>& f);

/// A grain that is not star-shaped beside one that is, 40 x 40 x `nx` voxels (nx >= 72): label 1 a
/// ball of radius 15 at (19.9, 20.2, 19.7) (z, y, x) with an enclosed spherical cavity of radius
/// 5.5 whose centre is 7.5 voxels along +x (its share of the grain: 5.5^3 / (15^3 - 5.5^3)), and
/// label 2 a ball of radius 12 at (20.1, 19.8, 52.3).
Volume<std::uint32_t> label_hollow_grain_and_ball(std::size_t nx, Vec3 voxel = {1e-5, 1e-5, 1e-5});

/// Number of distinct non-zero labels.
std::size_t count_labels(const Volume<std::uint32_t>& labels);

}  // namespace graintwin::test
