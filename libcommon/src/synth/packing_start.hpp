#pragma once
// Internal to the packer (packing.cpp): its random start.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "graintwin/synth/packing.hpp"

namespace graintwin::synth::detail {

struct RandomStart {
  bool placed = false;
  /// The common scale the grains start from; when they could not be placed, the smallest tried.
  double scale = 0.0;
};

/// Random sequential addition of the grains' bounding spheres (radius scale x rmax[i]) inside the
/// container, largest grains first, each at a random position and orientation drawn from `seed`
/// (a generator of our own, so the start is the same on every platform). The scale starts at
/// initial_scale, or (0) at 0.55 lowered until the bounding spheres fill at most a quarter of
/// the container, and shrinks by 10 % whenever some grain finds no room; below 0.15 the start
/// gives up (placed = false). x and q receive the positions and orientations.
RandomStart random_start(const Container& c, const std::vector<double>& rmax, double initial_scale,
                         std::uint64_t seed, std::vector<Eigen::Vector3d>& x,
                         std::vector<Eigen::Quaterniond>& q);

}  // namespace graintwin::synth::detail
