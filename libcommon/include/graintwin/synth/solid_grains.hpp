#pragma once
// Grains that are not star-shaped about their centroid, for ctsynth: angular grains with an
// undercut (a tilted flat cavity below the surface, open on one side, so that some rays from the
// centroid leave the grain, cross the cavity and enter the grain again under its roof), and grains read
// from a segmented scan (their label's voxels, smoothed; shape_library.hpp). A star-shaped radial
// description cannot hold such a grain, so each carries, beside its solid, a star-shaped hull that
// contains it: the packer, the overlap relaxation and the contact search work on the hull, the
// renderer and the ground truth ask the solid (docs/ctsynth.md, "Grains that are not star-shaped").
#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/shape/radial_table.hpp"
#include "graintwin/shape/sand_shape.hpp"

namespace graintwin::synth {

/// A solid grain in its body frame (metres, origin at its centroid).
class GrainSolid {
 public:
  virtual ~GrainSolid() = default;
  /// Signed level at body point p: > 0 inside, < 0 outside, 0 on the surface, continuous in p.
  virtual double level(const Eigen::Vector3d& p) const = 0;
  bool contains(const Eigen::Vector3d& p) const { return level(p) > 0.0; }
  /// False only where the solid equals its hull (the star-shaped table it is placed with) within
  /// `radius` of body point p, so that the hull's analytic partial volume holds there.
  virtual bool may_differ_from_hull(const Eigen::Vector3d& p, double radius) const = 0;
  /// A radius beyond which every point is outside (m).
  virtual double reach() const = 0;
};

/// A cavity removed from a grain (body frame, m): a ball of `radius` (half_height 0), or a flat
/// cylinder (a disc) of `radius` and height 2 half_height about unit `axis`.
struct Pocket {
  Eigen::Vector3d centre{0.0, 0.0, 0.0};
  double radius = 0.0;
  double half_height = 0.0;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  /// > 0 outside, < 0 inside, never more than the distance to the surface (so a value above d means
  /// the point is farther than d): |p - centre| - radius, or max(|axial| - half_height, |lateral| - radius).
  double outside_level(const Eigen::Vector3d& p) const;
  bool contains(const Eigen::Vector3d& p) const { return outside_level(p) < 0.0; }
  /// Radius of the ball about `centre` that holds the cavity.
  double bound() const { return std::hypot(radius, half_height); }
};

/// A star-shaped body (a table) with cavities removed; the body is its hull.
class PocketedGrain final : public GrainSolid {
 public:
  PocketedGrain(shape::RadialTable body, std::vector<Pocket> pockets);
  /// min(body radius - |p|, each cavity's outside_level).
  double level(const Eigen::Vector3d& p) const override;
  /// True within `radius` of a pocket.
  bool may_differ_from_hull(const Eigen::Vector3d& p, double radius) const override;
  double reach() const override { return body_.max_radius(); }
  const std::vector<Pocket>& pockets() const { return pockets_; }

 private:
  shape::RadialTable body_;
  std::vector<Pocket> pockets_;
};

/// A grain given by a smoothed indicator on a voxel grid: the solid is where the trilinear
/// interpolant exceeds `iso`. The grid's origin and voxel size (Volume's) are in the body frame.
class VoxelGrain final : public GrainSolid {
 public:
  /// `field` is 0 outside and 1 inside, smoothed; its faces must lie outside the grain; iso in (0, 1).
  explicit VoxelGrain(Volume<float> field, double iso = 0.5);
  /// Trilinear field - iso (-iso outside the grid).
  double level(const Eigen::Vector3d& p) const override;
  bool may_differ_from_hull(const Eigen::Vector3d&, double) const override { return true; }
  double reach() const override { return reach_; }
  const Volume<float>& field() const { return field_; }

 private:
  Volume<float> field_;
  double iso_ = 0.5;
  double reach_ = 0.0;
};

/// The level of a smoothed indicator whose trilinear solid holds `voxels` voxels of volume: the
/// level at 0.5 loses about 3 sigma^2 / r^2 of a ball's volume to the smoothing (2 % for sigma 0.7 and
/// 8 voxels of radius), which this undoes for any shape. From the field sampled 4 x 4 x 4 per voxel.
double volume_preserving_level(const Volume<float>& field, double voxels);

/// What a radial description misses of a solid, measured along rays from its origin the way
/// labels2shapes measures a segmented grain (GrainShape's fields of the same names), exactly, with
/// no noise floor.
struct NonStarMeasures {
  double multi_exit_fraction = 0.0;   ///< share of directions (uniform on the sphere) whose ray re-enters
  double hidden_void_fraction = 0.0;  ///< void between first exit and last re-entry, over the solid's volume
  double reentry_depth = 0.0;         ///< m: largest (last exit - first exit) |cos(ray, normal at the last exit)|
};

/// Where a ray from the origin along unit u leaves the solid: its first and last exits (m).
struct RayExits {
  double first = 0.0, last = 0.0;
};
/// Marches the ray in steps of `step` (m) out to solid.reach() and bisects each crossing to 1e-4 of
/// a step. Crossings closer than a step may be missed. DataError if the origin is not inside.
RayExits ray_exits(const GrainSolid& solid, const Eigen::Vector3d& unit, double step);

/// NonStarMeasures over `directions` Fibonacci directions, marched in steps of `step` (m); `volume`
/// is the solid's (m^3).
NonStarMeasures non_star_measures(const GrainSolid& solid, double volume, double step, int directions = 4096);

/// The solid's star hull about its origin as a table with n nodes per cube-face edge: the last exit
/// along each node direction, then, where a neighbour's exit lies more than 4 steps farther (a jump:
/// the radial wall over a pocket or cavity) and the solid may differ from its hull, the largest of
/// it and its 8 neighbours', so that the bilinear table stays outside the solid there. Features
/// narrower than a table cell may still poke out of it.
shape::RadialTable last_exit_table(const GrainSolid& solid, int n, double step);

/// Volume, area and inertia of the solid from its level sampled on a grid of spacing h (m): area
/// and volume of the zero isosurface (marching tetrahedra), second moments from the grid cells
/// inside. Errors O(h^2) on smooth parts.
shape::ShapeStats solid_stats(const GrainSolid& solid, double h);

}  // namespace graintwin::synth
