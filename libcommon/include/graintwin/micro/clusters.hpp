#pragma once
// Clusters of the most non-affine grains (docs/methods.md, micro-mechanics): the grains with the highest D2min,
// joined where two of them are nearest neighbours, their sizes s, volume-weighted radii of gyration
// (the corrected formula), the power-law fit of P(s) and the fractal dimension from R_g ~ s^(1/d_f).
//
// "Nearest neighbours" is the contact-distance criterion: grains i and j are linked when their
// centroids are within link_factor x (r_i + r_j), r the volume-equivalent radii. It links grains
// that touch (or nearly: the factor absorbs non-spherical shapes), so a cluster is a set of grains
// that can push on each other; a Delaunay graph would also link grains across voids and along the
// sample's convex hull, joining clusters that share no contact.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "graintwin/micro/distributions.hpp"

namespace graintwin::micro {

/// Indices of the `fraction` (0..1] of the grains with the largest finite `score`, at least one
/// when any is finite; ties at the threshold are all taken. Sorted by index.
std::vector<std::size_t> top_fraction(const std::vector<double>& score, double fraction);

/// Linked pairs (i < j) among `members` (indices into positions/radii) by the contact-distance
/// criterion above; uses a uniform grid (core/point_grid).
std::vector<std::pair<std::size_t, std::size_t>> contact_links(const std::vector<Eigen::Vector3d>& positions,
                                                               const std::vector<double>& radii,
                                                               const std::vector<std::size_t>& members,
                                                               double link_factor);

/// Connected components of the graph on `n` nodes with `links`: a component id per node, numbered
/// 0.. in order of each component's smallest node.
std::vector<std::uint32_t> connected_components(std::size_t n, const std::vector<std::pair<std::size_t, std::size_t>>& links);

/// R_g^2 = sum V_i |r_i - R|^2 / sum V_i, R = sum V_i r_i / sum V_i (m).
double radius_of_gyration(const std::vector<Eigen::Vector3d>& positions, const std::vector<double>& volumes);

struct ClusterStatistics {
  /// Per grain of the input: cluster id, or -1 when not among the top fraction.
  std::vector<std::int32_t> cluster;
  std::vector<std::uint32_t> size;        ///< per cluster: s (grains)
  std::vector<double> radius_of_gyration; ///< per cluster: R_g (m; 0 for s = 1)
  std::size_t selected = 0;               ///< grains in the top fraction
  double threshold = 0.0;                 ///< smallest selected score
  PowerLawFit size_fit;                   ///< discrete power law of P(s), s_min by KS (Clauset et al.)
  LineFit rg_fit;                         ///< log10 R_g = a + (1/d_f) log10 s over clusters with s >= 2
  double fractal_dimension = 0.0;         ///< d_f = 1 / slope (NaN without a fit)
  double fractal_dimension_error = 0.0;   ///< slope_error / slope^2
};

struct ClusterOptions {
  double top_fraction = 0.10;  ///< share of the grains with the highest score
  double link_factor = 1.1;    ///< link when |r_i - r_j| <= link_factor (r_i + r_j)
  std::size_t min_tail = 10;   ///< smallest power-law tail the size fit accepts
};

/// The whole cluster analysis of one state: `score` (D2min; NaN = undefined), positions (m),
/// volumes (m^3) of the same grains.
ClusterStatistics cluster_statistics(const std::vector<double>& score, const std::vector<Eigen::Vector3d>& positions,
                                     const std::vector<double>& volumes, const ClusterOptions& options);

}  // namespace graintwin::micro
