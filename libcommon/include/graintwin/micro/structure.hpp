#pragma once
// Structure of one state (docs/methods.md, micro-mechanics): pair correlation g(r) with an edge correction for a
// box or cylinder sample, coordination numbers and their distribution, and distributions of the
// incremental displacements.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "graintwin/micro/distributions.hpp"

namespace graintwin::micro {

/// The region the grain centres fill: an axis-aligned box, or a cylinder about an axis parallel to
/// z (the triaxial sample). Lengths in m.
struct Region {
  enum class Kind { box, cylinder } kind = Kind::box;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  ///< box; cylinder: z range in lo.z(), hi.z()
  Eigen::Vector2d axis = Eigen::Vector2d::Zero();  ///< cylinder: (x, y) of its axis
  double radius = 0.0;                             ///< cylinder

  bool contains(const Eigen::Vector3d& p) const;
  double volume() const;
  /// Distance from an inside point to the nearest boundary (0 outside).
  double depth(const Eigen::Vector3d& p) const;
};
/// "box" or "cylinder"; UsageError otherwise.
Region::Kind parse_region_kind(const std::string& name);
/// "box" or "cylinder", as parse_region_kind reads it.
const char* region_kind_name(Region::Kind kind);
/// The smallest region of that kind holding every finite point: the box of their extents; the
/// cylinder about their mean (x, y) reaching the farthest, between their lowest and highest z.
Region enclosing_region(const std::vector<Eigen::Vector3d>& points, Region::Kind kind);

/// Share of the sphere of radius r about p that lies inside the region, from `directions`
/// (unit vectors spread evenly, e.g. fibonacci_directions).
double sphere_fraction_inside(const Region& region, const Eigen::Vector3d& p, double r,
                              const std::vector<Eigen::Vector3d>& directions);
/// n unit vectors on a Fibonacci spiral (evenly spread over the sphere).
std::vector<Eigen::Vector3d> fibonacci_directions(std::size_t n);

struct PairCorrelation {
  std::vector<double> r;      ///< bin centres, m
  std::vector<double> edges;  ///< bins + 1, m
  std::vector<double> g;      ///< g(r), 1 for an ideal gas
  std::size_t points = 0;
  double density = 0.0;       ///< points per m^3 in the region
};

/// g(r) = V / (N (N - 1)) sum_i sum_{j != i} w_i(r) [r_ij in bin] / shell volume, over the finite
/// points inside `region`, bins of equal width on (0, r_max]. Edge correction (Ripley's isotropic
/// weight): w_i(r) = 1 / share of the sphere of radius r about i inside the region, from
/// `directions` sample directions; 1 for points deeper than r. Parallel over points (OpenMP).
PairCorrelation pair_correlation(const std::vector<Eigen::Vector3d>& points, const Region& region, double r_max,
                                 std::size_t bins, std::size_t directions = 512);

/// Z_i = neighbours j with |r_i - r_j| <= factor (r_i + r_j) (r: volume-equivalent radii, m); the
/// distance criterion used when no contacts file is given. Non-finite positions get 0 and count
/// for nobody.
std::vector<std::uint32_t> coordination_by_distance(const std::vector<Eigen::Vector3d>& positions,
                                                    const std::vector<double>& radii, double factor);
/// Z_i from a contact list of index pairs (each pair counts once for each of its two grains).
std::vector<std::uint32_t> coordination_from_pairs(std::size_t n, const std::vector<std::pair<std::size_t, std::size_t>>& pairs);

/// How many grains have each Z = 0 .. max Z.
struct CoordinationDistribution {
  std::vector<std::uint64_t> count;  ///< index Z
  double mean = 0.0;
  std::size_t grains = 0;
};
CoordinationDistribution coordination_distribution(const std::vector<std::uint32_t>& z);

/// Distributions of incremental displacements over d50: components x, y, z (signed, bins over
/// [-range, range]) and magnitude (bins over [0, range]); NaN rows are skipped.
struct DisplacementDistributions {
  Histogram component[3];
  Histogram magnitude;
};
DisplacementDistributions displacement_distributions(const std::vector<Eigen::Vector3d>& increments, double d50,
                                                     double range_d50, std::size_t bins);

}  // namespace graintwin::micro
