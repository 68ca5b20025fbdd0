#pragma once
// Predicting where a grain went from grains already matched around it (the improved matcher):
// a robust global affine map (axial compression, bulging on average) and, on top of it, a local
// weighted least-squares affine fit of the matched neighbours' residual displacements (shear bands,
// barrelling), evaluated leave-one-out so that a grain never predicts itself.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "graintwin/core/point_grid.hpp"

namespace graintwin::track {

/// x -> a x + b.
struct Affine {
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const { return a * x + b; }
};

/// Weighted least-squares affine map taking `from` to `to` (same lengths; weights >= 0, empty =
/// all 1). Points that do not span 3-D (fewer than 4 with weight, or nearly coplanar) give the
/// weighted mean translation instead; no point with weight gives the identity.
Affine fit_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                  const std::vector<double>& weight = {});

/// How one residual of a right pair is distributed. A wrong pair's residual is taken as uniform
/// over the range the residuals span (for a length: uniform in the ball of that radius).
enum class ResidualLaw {
  length3,      ///< the length of an isotropic 3-D Gaussian vector; spread = its per-component standard deviation
  gaussian,     ///< Gaussian about an unknown centre
  half_normal,  ///< the magnitude of a Gaussian about 0
};

/// One residual of every pair with its law when the pair is right.
struct ResidualTerm {
  ResidualLaw law = ResidualLaw::gaussian;
  std::vector<double> value;  ///< one per pair
  double spread = 0.0;        ///< in: a start; out: the right pairs' standard deviation
  double centre = 0.0;        ///< gaussian: in: a start; out: the right pairs' mean
  double floor = 0.0;         ///< the smallest spread (> 0): how well the quantity repeats at best
};

/// Right pairs told from wrong ones by all their residuals at once: a two-component mixture,
/// right pairs with the terms' laws (independent), wrong pairs uniform in each, fitted by
/// expectation-maximisation, starting from `start` (each pair's prior probability of being right,
/// e.g. a consensus set) or, when that is empty or all zero, from the terms' spreads. Returns each
/// pair's probability of being right and sets the terms' spreads and centres to the right pairs'
/// maximum-likelihood values. Unlike a median, these do not widen with the share of wrong pairs as
/// long as the right ones cluster. UsageError for lengths that differ or a floor that is not positive.
std::vector<double> right_pair_probability(std::vector<ResidualTerm>& terms, const std::vector<double>& start = {});

/// Robust affine map for pairs of which many may be wrong: RANSAC over minimal samples (4 pairs,
/// seeded: deterministic) scoring pairs within `inlier_distance`, drawing until a sample of right
/// pairs has been drawn with 99 % probability at the best share found so far (at most
/// `max_trials`), then the map refitted by least squares weighted by each pair's probability of
/// being right (right_pair_probability on the residual lengths from the RANSAC inliers on, spread
/// at least inlier_distance / 4), alternately. `weights` (optional) receives those probabilities.
Affine robust_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     double inlier_distance, int max_trials = 4096, std::uint64_t seed = 1,
                     std::vector<double>* weights = nullptr);

/// Displacement field from known pairs: base affine plus, at each query point x, a weighted
/// least-squares affine fit (biweight kernel of radius `radius`, ridge on the gradient) of the
/// known pairs' residual displacements around x.
class DisplacementField {
 public:
  static constexpr std::size_t none = std::numeric_limits<std::size_t>::max();

  DisplacementField() = default;
  /// from/to: positions of the known pairs in the two scans; weight: per pair in [0, 1] (empty =
  /// all 1); radius > 0.
  DisplacementField(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                    const std::vector<double>& weight, const Affine& base, double radius);

  /// Where a grain at x in the first scan is predicted in the second, leaving known pair
  /// `exclude` out; where the neighbourhood holds fewer than ~3 pairs' worth of weight the local
  /// correction fades out and the base affine map remains. With `errors` (one per known pair, e.g.
  /// their own leave-one-out prediction errors |e|), also the weighted root-mean-square of
  /// min(|e|, clip) / sqrt(3) over the same neighbourhood (a per-component spread) and the weight
  /// it rests on, in the same pass over the neighbours.
  struct Estimate {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    double spread = 0.0;
    double weight = 0.0;
  };
  Estimate estimate(const Eigen::Vector3d& x, std::size_t exclude = none, const std::vector<double>* errors = nullptr,
                    double clip = std::numeric_limits<double>::infinity()) const;
  Eigen::Vector3d predict(const Eigen::Vector3d& x, std::size_t exclude = none) const {
    return estimate(x, exclude).position;
  }

  const Affine& base() const { return base_; }
  std::size_t size() const { return residual_.size(); }

 private:
  Affine base_;
  double radius_ = 1.0;
  PointGrid grid_;
  std::vector<Eigen::Vector3d> residual_;  ///< to - base(from) per pair
  std::vector<double> weight_;
};

}  // namespace graintwin::track
