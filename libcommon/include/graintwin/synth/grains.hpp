#pragma once
// The grains of a synthetic sample: shapes (sphere, ellipsoid, random SH sand grain or angular
// grain, angular_grains.hpp) scaled to diameters drawn from a PSD, with their SH coefficients and
// radial tables, made in parallel and deterministically (grain i draws from its own random stream).
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "graintwin/shape/radial_table.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/synth/angular_grains.hpp"

namespace graintwin::synth {

enum class GrainShape { sphere, ellipsoid, sand, angular };
/// "sphere", "ellipsoid", "sand", "angular"; UsageError otherwise.
GrainShape parse_grain_shape(const std::string& name);

struct GrainSetParams {
  GrainShape shape = GrainShape::sand;
  shape::SandShapeParams sand;     ///< sand.degree is also the SH degree stored for every shape
  AngularShapeParams angular;      ///< angular grains
  double aspect_ratio = 1.3;       ///< ellipsoids: prolate spheroids a/c, volume-equivalent
  double voxel_size = 27.5e-6;     ///< m; sets the table resolution (surface error <= 0.02 voxel)
  std::uint64_t seed = 1;
};

struct GrainSet {
  int sh_degree = 0;
  std::vector<double> diameters;          ///< volume-equivalent (m), as drawn
  std::vector<shape::RadialTable> tables; ///< body frame, origin at the centroid, final size
  Eigen::MatrixXd coeffs_body;            ///< N x (L+1)^2 SH coefficients (m) of the body-frame surface
  std::vector<shape::ShapeStats> stats;
  /// Angular grains (empty for the others, whose coefficients are exact): RMS over the fit
  /// directions of the exact radius minus its SH fit at sh_degree, relative to the grain's
  /// volume-equivalent radius. Sharp edges cannot be represented by a finite SH sum; this says
  /// how far the stored coefficients are from the rendered surface.
  std::vector<double> sh_fit_rms;
  std::vector<const shape::RadialTable*> table_pointers() const;
};

/// Bytes one grain of `diameter` (m) takes in a GrainSet tabulated at `voxel_size` with SH
/// `degree` (its radial table and coefficients): lets a caller estimate a sample before making it.
double grain_bytes(double diameter, double voxel_size, int degree);

GrainSet make_grains(const GrainSetParams& p, const std::vector<double>& diameters,
                     const std::function<void(double)>& progress = {});

/// The grains' surfaces low-passed to SH degree `degree` (coefficients above it dropped; for angular
/// grains, of their SH fit; same body frame and origin), tabulated like make_grains() does at `voxel_size`: smooth stand-ins for
/// packing with the roughness off (pack_in_stages()). UsageError unless 0 <= degree <= sh_degree.
std::vector<shape::RadialTable> smoothed_tables(const GrainSet& set, int degree, double voxel_size);

/// SH coefficients of the grain rotated by `body_to_world` (same degree), exact up to rounding:
/// the rotated surface is re-expanded by least squares on a fixed well-conditioned direction set.
class ShRotator {
 public:
  explicit ShRotator(int degree);
  Eigen::VectorXd rotate(const Eigen::VectorXd& body, const Eigen::Matrix3d& body_to_world) const;

 private:
  int degree_;
  std::vector<Eigen::Vector3d> dirs_;
  Eigen::MatrixXd pinv_;  // (L+1)^2 x n_dirs pseudo-inverse of the design matrix
};

}  // namespace graintwin::synth
