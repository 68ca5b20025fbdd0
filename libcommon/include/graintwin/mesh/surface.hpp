#pragma once
// Closed triangle surfaces of grains before they are meshed, and the checks that make them safe to
// hand to a mesher: closed and manifold (every edge shared by exactly two triangles with opposite
// directions, one fan of triangles around every vertex), one sphere-like piece (Euler
// characteristic 2), positive enclosed volume (outward orientation) and no self-intersection.
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace graintwin::mesh {

/// Triangles index `vertices`; counter-clockwise seen from outside. Lengths in metres.
struct TriangleSurface {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
};

/// Enclosed volume by the divergence theorem (m^3; negative when the triangles face inwards).
double enclosed_volume(const TriangleSurface& surface);
double surface_area(const TriangleSurface& surface);
/// Total mean curvature, the integral of H = (k1 + k2) / 2 over the surface (m): half the sum over
/// edges of length x signed dihedral angle (positive where convex); 4 pi R for a sphere. Needs a
/// closed, consistently oriented surface (edges of one triangle are skipped).
double total_mean_curvature(const TriangleSurface& surface);

struct SurfaceCheck {
  std::size_t open_edges = 0;           ///< edges used by one triangle
  std::size_t nonmanifold_edges = 0;    ///< edges used by three or more triangles
  std::size_t misoriented_edges = 0;    ///< edges whose two triangles run the same way along them
  std::size_t nonmanifold_vertices = 0; ///< vertices whose triangles form more than one fan
  long euler_characteristic = 0;        ///< V - E + F of the used vertices; 2 for a sphere-like surface
  std::size_t intersecting_pairs = 0;   ///< pairs of triangles that cross each other (or fold onto each other)
  double volume = 0.0;                  ///< enclosed volume, m^3
  bool ok() const { return embedded() && euler_characteristic == 2; }
  /// Closed, manifold, outward and without self-intersection, of any genus: enough to bound a
  /// volume that is meshed from these very triangles (no reparametrisation, which needs ok()).
  bool embedded() const {
    return open_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 && nonmanifold_vertices == 0 && intersecting_pairs == 0 &&
           volume > 0.0;
  }
  /// One sentence naming every failed condition ("" when ok()).
  std::string problems() const;
};

/// The piece of the surface (triangles connected through shared vertices) that encloses the largest
/// volume, its vertices renumbered; the whole surface when it is one piece. A grain's voxels can
/// give a main body plus crumbs or inner cavity shells (negative volume): the mesher keeps the body.
TriangleSurface largest_piece(const TriangleSurface& surface);

/// Runs every check. Self-intersection: triangles are binned on a uniform grid of their bounding
/// boxes (O(N) for a surface of even triangles); pairs without a shared vertex cross when an edge
/// of one passes through the other, pairs sharing one vertex when the opposite edge of either
/// passes through the other, pairs sharing an edge when they fold back onto each other (normals
/// more than 175 degrees apart).
SurfaceCheck check_surface(const TriangleSurface& surface);

}  // namespace graintwin::mesh
