#pragma once
// What one gmsh run is asked for, as plain data so it can cross to a worker process
// (gmsh_workers.cpp), and the in-process run itself (gmsh_adapter.cpp, the only code calling gmsh).
#include <cstdint>
#include <functional>

#include <Eigen/Core>

#include "graintwin/mesh/gmsh_adapter.hpp"

namespace graintwin::mesh::detail {

struct GmshRequest {
  enum class Body : std::uint8_t { surface = 0, ellipsoid = 1 };
  Body body = Body::surface;
  TriangleSurface surface;                          ///< body == surface: closed, outward
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Ones();  ///< body == ellipsoid, centred at 0, axis-aligned
  double size = 0.0;                                ///< element edge target, in the body's units
  int order = 1;
  bool fix_inverted = true;                         ///< order 2, gmsh's curving: optimize(HighOrder) when inverted
  bool straight = false;                            ///< order 2: straight mid-edge nodes (the caller snaps them)
  bool keep_surface = false;                        ///< body == surface: its triangles are the boundary mesh (no reparametrisation)
  /// Graded size at a point of the body's frame (TetOptions::size_at moved there); in-process
  /// only: a function cannot cross to a worker.
  std::function<double(const Eigen::Vector3d&)> size_at;
};

/// Runs `request` in this process's gmsh under the process-wide lock: a fresh model, meshed,
/// extracted (positive orientation) and removed. Fills the report's gmsh part (curving, optimize,
/// straightened, inverted, seconds). DataError (one sentence) when gmsh fails.
TetMesh run_gmsh(const GmshRequest& request, TetReport& report);
/// The same without the lock, for a single-threaded worker process (the lock's state is
/// undefined after fork when another thread held it).
TetMesh run_gmsh_unlocked(const GmshRequest& request, TetReport& report);

}  // namespace graintwin::mesh::detail
