#pragma once
// The closed surface of one CT grain, ready for the mesher: from its SH fit (an icosphere's
// directions displaced to r(direction) about the centroid) or, where that fit is flagged
// unreliable, from its smoothed voxels (marching tetrahedra on the Gaussian-smoothed indicator).
#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "graintwin/core/volume.hpp"
#include "graintwin/mesh/surface.hpp"
#include "graintwin/shape/sh_surface.hpp"

namespace graintwin::mesh {

/// Vertices centroid + r_i d_i with r = basis * coeffs (basis: shape::sh_design_matrix of the
/// sphere's directions), triangles of the sphere. Radii are not clamped: an SH fit that goes
/// negative somewhere folds through the centroid, and check_surface reports it.
TriangleSurface sh_surface(const shape::SphereMesh& sphere, const Eigen::MatrixXd& basis, const Eigen::VectorXd& coeffs,
                           const Eigen::Vector3d& centroid);

/// The isosurface 0.5 of the grain's indicator (voxels == label within the half-open box `bbox`
/// (z0, y0, x0, z1, y1, x1), padded by 2 + 3 sigma voxels) smoothed with a Gaussian of `smooth_vox`
/// voxels; shared vertices welded (marching tetrahedra computes each edge crossing identically from
/// both sides), degenerate triangles dropped. Metres, outward. `stride` > 1 contours the smoothed
/// field sampled every `stride` voxels: marching tetrahedra make about 12 triangles per voxel of
/// surface, far more than a mesher needs once the element size is several voxels.
/// `preserve_volume`: the level is chosen (bisection, to 0.1 %) so that the surface encloses the
/// grain's voxel volume instead of 0.5, which loses volume at convex edges (more so on a coarse
/// grid: 5 % on a U of 5-voxel arms at stride 1, 10 % at stride 2).
TriangleSurface voxel_surface(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& bbox,
                              double smooth_vox, int stride = 1, bool preserve_volume = false);

}  // namespace graintwin::mesh
