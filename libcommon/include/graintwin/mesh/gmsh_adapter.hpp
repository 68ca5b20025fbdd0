#pragma once
// The only code that touches gmsh (Debian's 4.8.4). gmsh keeps one global model and is not
// thread-safe, so every call here holds one process-wide lock: callers may call from many threads,
// but the gmsh part runs one at a time (parallel meshing needs worker processes).
#include <functional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "graintwin/mesh/surface.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

namespace graintwin::mesh {

struct TetOptions {
  double size = 0.0;  ///< target element edge length, m (> 0)
  int order = 1;      ///< 1: 4-node, 2: 10-node (curved onto the surface)
  /// After setOrder(2), run optimize("HighOrder") when any element's Jacobian is not positive.
  bool fix_inverted = true;
  /// Order 2 with an exact surface: gmsh places the mid-edge nodes straight, then every boundary
  /// node is moved onto the surface by `project` (point -> nearest surface point), instead of
  /// gmsh curving onto its reparametrised triangulation (exact geometry, and no optimisation
  /// pass: an element this leaves with min det J / max det J below 0.2 gets its mid-edge nodes
  /// pulled back halfway, up to 4 times, then straight).
  std::function<Eigen::Vector3d(const Eigen::Vector3d&)> project;
};

struct TetReport {
  std::size_t inverted_after_curving = 0;  ///< 10-node elements with min det J <= 0 straight after setOrder(2)
  bool optimized = false;                  ///< optimize("HighOrder") ran
  std::size_t inverted = 0;                ///< after the fix (0 unless the fix failed)
  std::size_t straightened = 0;            ///< mid-edge nodes pulled back towards straight edges to restore validity
  double seconds = 0.0;                    ///< wall time inside gmsh (classification, meshing, curving)
};

/// Tetrahedral mesh of the solid bounded by `surface` (closed, outward; check_surface first): the
/// surface goes in as a discrete entity, is classified and reparametrised (classifySurfaces,
/// createGeometry), bounded as one volume and meshed with gmsh's Delaunay at `size`. For order 2
/// the elements are curved onto the reparametrised surface; inverted ones (det J <= 0 at a node or
/// Gauss point) trigger optimize("HighOrder"), and mid-edge nodes of any still inverted element
/// are put back on the straight edge (always valid). DataError (one sentence) when gmsh fails.
TetMesh tetrahedralize(const TriangleSurface& surface, const TetOptions& options, TetReport* report = nullptr);

/// A solid ellipsoid x = centre + rotation * diag(semi_axes) * (unit ball), meshed from gmsh's
/// exact OpenCASCADE sphere (the primitive grains of fdemrun scenes; a sphere when the three
/// semi-axes are equal).
TetMesh mesh_ellipsoid(const Eigen::Vector3d& centre, const Eigen::Vector3d& semi_axes,
                       const Eigen::Quaterniond& rotation, const TetOptions& options, TetReport* report = nullptr);

}  // namespace graintwin::mesh
