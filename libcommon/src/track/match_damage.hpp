#pragma once
// Internal to the improved matcher (match.cpp): what it shares with the explanations of grains
// damaged by the other scan's segmentation (merged with a neighbour into one label, or cut into
// two), which match_damage.cpp weighs against the matches.
#include <Eigen/Core>

#include <cmath>
#include <vector>

#include "graintwin/core/point_grid.hpp"
#include "graintwin/track/assignment.hpp"
#include "graintwin/track/match.hpp"

namespace graintwin::track::detail {

/// Spreads of the cost's terms over the right anchors: position (per component, m), shape
/// (D / ||R_0||) and volume (ln(v_def / v_ref), about its scan-wide bias).
struct Scales {
  double position = 0.0, shape = 0.0, volume_mean = 0.0, volume = 0.0;
};

/// The standardised volume residual of a label of volume v_def for a grain (or grains) of v_ref.
inline double volume_z(double v_def, double v_ref, const Scales& k) { return (std::log(v_def / v_ref) - k.volume_mean) / k.volume; }

/// Where each reference grain is looked for: its predicted position, the position spread there
/// and the candidate window.
struct Prediction {
  std::vector<Eigen::Vector3d> position;
  std::vector<double> sigma, window;
};

/// Each reference grain's lost cost: `lost_cost`, or the cost of its damage explanation when that
/// is lower, so that a damaged grain is lost rather than steal a neighbour's label. The
/// explanations are taken cheapest first, each label explaining one grain's damage (a merged
/// label: the pair's), so that one damaged grain's labels do not explain away another grain.
std::vector<double> damage_lost_costs(const ScanGrains& ref, const ScanGrains& def, const PointGrid& ref_grid,
                                      const PointGrid& def_grid, const Prediction& at, const Scales& k,
                                      const SparseCosts& costs, double lost_cost);

}  // namespace graintwin::track::detail
