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

/// Robust affine map for pairs of which many may be wrong: RANSAC over minimal samples (4 pairs,
/// `trials` draws, seeded: deterministic) scoring pairs within `inlier_distance`, then
/// iteratively reweighted least squares with Tukey's biweight at 4.685 robust standard deviations
/// (floored at inlier_distance / 4). `weights` (optional) receives each pair's final weight in [0, 1].
Affine robust_affine(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     double inlier_distance, int trials = 256, std::uint64_t seed = 1,
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
