#pragma once
// Surface remeshing for grains whose surface gmsh should not reparametrise (voxel surfaces of
// angular or non-star grains, or an SH surface whose gmsh run overran its time budget): the dense
// surface becomes near-equilateral triangles of about the element size, which gmsh then keeps as
// the boundary of the volume it tetrahedralises. The only code using CGAL (surface_remesh.cpp).
#include <functional>

#include <Eigen/Core>

#include "graintwin/mesh/surface.hpp"

namespace graintwin::mesh {

/// `surface` (closed, outward) remeshed to triangles of edge about `edge` (m) by CGAL's isotropic
/// remeshing (split edges longer than 4/3 edge, collapse those shorter than 4/5 edge, flip towards
/// valence 6, tangential smoothing, every vertex projected back onto the input), `iterations`
/// rounds. The result follows the input within a fraction of `edge`; it is usually embedded, but
/// collapses in thin parts can make it cross itself: check_surface it before use.
TriangleSurface remesh_isotropic(const TriangleSurface& surface, double edge, int iterations = 5);

/// The closest point of `surface` to a point (an AABB tree over its triangles, built once and kept
/// by the returned function; one thread at a time).
std::function<Eigen::Vector3d(const Eigen::Vector3d&)> closest_point_on(const TriangleSurface& surface);

}  // namespace graintwin::mesh
