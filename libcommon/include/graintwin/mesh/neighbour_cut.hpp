#pragma once
// Where a CT grain's labelled region meets its neighbours' regions. An SH fit or a smoothed voxel
// surface overshoots the grain's voxels by a voxel or two where it touches another grain (the fit
// rounds the flat contact, the smoothed level is chosen to keep the grain's volume), and two such
// surfaces overlap by twice that: on the soil crop, 0.27 mm on grains of 0.7 mm. Cutting each
// surface at this boundary makes neighbouring grains touch at the interface segmentation found
// between them, as in the scan, instead of starting the simulation pressed into each other.
#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "graintwin/core/volume.hpp"
#include "graintwin/mesh/surface.hpp"

namespace graintwin::mesh {

class NeighbourCut {
 public:
  /// The field f = (grain indicator - other grains' indicator) of grain `label` over its half-open box
  /// `bbox` (z0, y0, x0, z1, y1, x1) padded by `pad_vox` voxels (within the volume), read trilinearly:
  /// f = 0 on the faces where the grain's voxels meet a neighbour's (on both grains' fields alike),
  /// f > 0 on the grain's side and in void away from neighbours. Not smoothed, so that f = 1 at every
  /// voxel of the grain's own: a smoothed field went negative inside the thin parts of a large grain
  /// wedged between neighbours, and the cut split it (80 % of one soil-crop grain lost).
  NeighbourCut(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& bbox,
               std::size_t pad_vox);

  /// Whether any other grain's voxel lies in the box (else nothing is ever cut).
  bool any() const { return any_; }

  /// f at the point p (x, y, z, metres), trilinear between voxel centres: < 0 inside a neighbour's
  /// region; 1 outside the box (no neighbour known there).
  double side(const Eigen::Vector3d& p) const;

  /// Along the ray c + t d (d unit), t in [0, r]: where it first crosses into a neighbour's region
  /// (f < 0), to 1e-4 voxel, on the grain's side; r when it does not, or when c itself is not on
  /// the grain's side (nothing to measure from).
  double radial_limit(const Eigen::Vector3d& c, const Eigen::Vector3d& d, double r) const;

  /// p when it is on the grain's side; else the point where the path up the gradient of f smoothed
  /// (a Gaussian of kGuideSigma voxels: f itself is flat a voxel inside a neighbour) from p first
  /// reaches f = 0 (to 1e-4 voxel), or p when it does not within `reach_vox` voxels.
  Eigen::Vector3d onto_own_side(const Eigen::Vector3d& p, double reach_vox = 3.0) const;

 private:
  /// f at p read from `field` (1 outside the box).
  static double read(const Volume<float>& field, const Eigen::Vector3d& p);
  Volume<float> field_, guide_;  ///< f; f smoothed, whose slope onto_own_side climbs
  bool any_ = false;
};

/// Cuts any closed surface at the neighbours: each vertex inside a neighbour's region moves up the
/// field's gradient (towards the grain's own voxels) to f = 0; one with no way out within a few
/// voxels stays. Unlike cut_radial_surface this can fold a surface where vertices converge (thin
/// neighbours wedged into the grain), so callers check it. Returns how many vertices moved.
std::size_t cut_surface(TriangleSurface& surface, const NeighbourCut& cut);

/// Cuts a surface that is radial about c (every vertex on its own ray, as SH surfaces are) at the
/// neighbours: each vertex moves in along its ray to cut.radial_limit. It stays radial with r > 0,
/// so an embedded surface stays embedded.
void cut_radial_surface(TriangleSurface& surface, const Eigen::Vector3d& c, const NeighbourCut& cut);

}  // namespace graintwin::mesh
