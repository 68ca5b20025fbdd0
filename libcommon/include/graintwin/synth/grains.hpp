#pragma once
// The grains of a synthetic sample: shapes (sphere, ellipsoid, random SH sand grain or angular
// grain, angular_grains.hpp, some of them not star-shaped; or grains of a segmented scan,
// shape_library.hpp) scaled to diameters drawn from a PSD, with their SH coefficients and radial
// tables, made in parallel and deterministically (grain i draws from its own random stream).
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "graintwin/shape/radial_table.hpp"
#include "graintwin/shape/sand_shape.hpp"
#include "graintwin/shape/sh_fitter.hpp"
#include "graintwin/synth/angular_grains.hpp"
#include "graintwin/synth/solid_grains.hpp"

namespace graintwin::synth {

enum class GrainShape { sphere, ellipsoid, sand, angular, library };
/// "sphere", "ellipsoid", "sand", "angular", "library"; UsageError otherwise.
GrainShape parse_grain_shape(const std::string& name);

struct GrainSetParams {
  GrainShape shape = GrainShape::sand;
  shape::SandShapeParams sand;     ///< sand.degree is also the SH degree stored for every shape
  AngularShapeParams angular;      ///< angular grains
  /// Angular grains: the share drawn with a pocket (not star-shaped), in [0, 1]; round(share N)
  /// grains, chosen at random.
  double non_star_share = 0.0;
  double aspect_ratio = 1.3;       ///< ellipsoids: prolate spheroids a/c, volume-equivalent
  double voxel_size = 27.5e-6;     ///< m; sets the table resolution (surface error <= 0.02 voxel)
  std::uint64_t seed = 1;
};

/// Whether make_grains() tabulates grains of this shape as their SH surfaces (sand), so that
/// smoothed_tables() at the full degree remakes their tables bit for bit.
inline bool tables_are_sh_surfaces(GrainShape shape) { return shape == GrainShape::sand; }

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
  /// Grains that are not star-shaped: their solid, contained in their table (which is then a hull);
  /// null where the table is the grain. Grains of a set may share a solid (a shape library's).
  std::vector<std::shared_ptr<const GrainSolid>> solids;
  /// What a radial description misses of each grain (zeros where the table is the grain).
  std::vector<NonStarMeasures> non_star;
  /// True when every table is its grain's SH surface (tables_are_sh_surfaces(shape)):
  /// smoothed_tables(set, sh_degree, v) with the set's voxel size v makes the same tables bit for
  /// bit, so a caller short of memory may free them for a while.
  bool tables_are_sh_surfaces = false;
  std::vector<const shape::RadialTable*> table_pointers() const;
  std::vector<const GrainSolid*> solid_pointers() const;
};

/// Bytes one grain of `diameter` (m) takes in a GrainSet tabulated at `voxel_size` with SH
/// `degree` (its radial table and coefficients): lets a caller estimate a sample before making it.
double grain_bytes(double diameter, double voxel_size, int degree);

GrainSet make_grains(const GrainSetParams& p, const std::vector<double>& diameters,
                     const std::function<void(double)>& progress = {});

/// A grain that is not star-shaped, made ready for a set: `table` its hull, `coeffs` the fitter's SH
/// fit of its last exits, `stats` and `non_star` measured on the solid (rays stepped by r/100 or
/// `resolution` m, whichever is smaller; the statistics' grid by r/30 or 2 `resolution`; r its
/// volume-equivalent radius).
struct SolidGrainRecord {
  shape::RadialTable table;
  Eigen::VectorXd coeffs;
  double sh_fit_rms = 0.0;  ///< RMS of last exit - fit over the fit directions / volume-equivalent radius
  shape::ShapeStats stats;
  NonStarMeasures non_star;
};
SolidGrainRecord solid_grain_record(const GrainSolid& solid, shape::RadialTable hull, const shape::ShFitter& fitter,
                                    double resolution);

/// The grains' surfaces low-passed to SH degree `degree` (coefficients above it dropped; for angular
/// grains, of their SH fit; same body frame and origin), tabulated like make_grains() does at `voxel_size`: smooth stand-ins for
/// packing with the roughness off (pack_in_stages()). UsageError unless 0 <= degree <= sh_degree.
/// `progress` (optional) gets the fraction of grains done, one call at a time.
std::vector<shape::RadialTable> smoothed_tables(const GrainSet& set, int degree, double voxel_size,
                                                const std::function<void(double)>& progress = {});

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
