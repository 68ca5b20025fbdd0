#pragma once
// The only code that touches gmsh (Debian's 4.8.4). gmsh keeps one global model and is not
// thread-safe: in-process calls hold one process-wide lock (callers may call from many threads, the
// gmsh part runs one at a time); parallel meshing goes through GmshWorkers, worker processes with
// a gmsh each.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <sys/types.h>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "graintwin/core/error.hpp"
#include "graintwin/mesh/sliver_removal.hpp"
#include "graintwin/mesh/surface.hpp"
#include "graintwin/mesh/tet_mesh.hpp"

namespace graintwin::mesh {

struct TetOptions {
  double size = 0.0;  ///< target element edge length, m (> 0)
  int order = 1;      ///< 1: 4-node, 2: 10-node (curved onto the surface)
  /// After setOrder(2), run optimize("HighOrder") when any element's Jacobian is not positive.
  bool fix_inverted = true;
  /// An exact surface: every boundary node gmsh placed (on the triangulated surface) is moved onto
  /// it by `project` (point -> nearest surface point); an element whose corners that flattens or
  /// inverts keeps gmsh's corners. Order 2: gmsh places the mid-edge nodes straight and they are
  /// snapped too, instead of gmsh curving onto its reparametrised triangulation (exact geometry,
  /// and no optimisation pass: an element this leaves with min det J / max det J below 0.2 gets its
  /// mid-edge nodes pulled back halfway, up to 4 times, then straight).
  std::function<Eigen::Vector3d(const Eigen::Vector3d&)> project;
  /// Optional graded sizing: the target element size (m) at a point given in the coordinates of
  /// the returned mesh (gmsh's size callback), never above `size`; e.g. fine near the point where
  /// a grain will touch another (fdem::graded_element_size).
  std::function<double(const Eigen::Vector3d&)> size_at;
  /// The surface's own triangles become the boundary of the mesh (gmsh only fills the volume, no
  /// classification or reparametrisation): for a surface already remeshed to about `size`
  /// (remesh_isotropic), of any genus. Without it gmsh remeshes the surface and needs it one
  /// sphere-like piece.
  bool keep_surface = false;
  /// After meshing and snapping: remove_slivers to these thresholds (with `project`, boundary nodes
  /// may slide along the surface where nothing inside lifts an element). None asked by default.
  SliverThresholds slivers;
  /// gmsh must answer by then, or GmshOverrun is thrown (a worker is killed and replaced; in this
  /// process the run is refused when the time has already passed, since it cannot be stopped).
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
};

/// gmsh did not finish before TetOptions::deadline (the grain's time budget).
class GmshOverrun : public DataError {
 public:
  using DataError::DataError;
};

struct TetReport {
  std::size_t inverted_after_curving = 0;  ///< 10-node elements with min det J <= 0 straight after setOrder(2)
  bool optimized = false;                  ///< optimize("HighOrder") ran
  std::size_t inverted = 0;                ///< after the fix (0 unless the fix failed)
  std::size_t straightened = 0;            ///< mid-edge nodes pulled back towards straight edges to restore validity
  std::size_t unsnapped = 0;               ///< boundary corners left off the exact surface (snapping flattened an element)
  double seconds = 0.0;                    ///< wall time inside gmsh (classification, meshing, curving)
  SliverReport slivers;                    ///< the sliver pass after gmsh (TetOptions::slivers), in this process
};

/// Tetrahedral mesh of the solid bounded by `surface` (closed, outward; check_surface first): the
/// surface goes in as a discrete entity, is classified and reparametrised (classifySurfaces,
/// createGeometry), bounded as one volume and meshed with gmsh's Delaunay at `size`. For order 2
/// the elements are curved onto the reparametrised surface; inverted ones (det J <= 0 at a node or
/// Gauss point) trigger optimize("HighOrder"), and mid-edge nodes of any still inverted element
/// are put back on the straight edge (always valid). DataError (one sentence) when gmsh fails.
namespace detail {
struct GmshRequest;
}

/// A pool of worker processes, each running its own gmsh, for meshing grains in parallel: a call
/// from any thread takes a free worker (waiting for one), sends it the body and options through a
/// socket and gets the mesh back. Results do not depend on which worker meshed (each request is a
/// fresh gmsh model). A worker that dies is reported as a DataError for that call and forked again
/// for the next; so is one whose gmsh failed (its global state may be broken) or that overran the
/// request's deadline (killed, GmshOverrun); an interrupt (graintwin::interrupted) kills the worker
/// being waited for and throws InterruptedError. Workers end and are reaped when the pool is destroyed, and die with the
/// parent. Create it before starting threads and before reading large inputs: fork copies the
/// process as it is.
class GmshWorkers {
 public:
  /// How many workers are worth starting for `meshes` meshes at `threads` threads: no more than
  /// the meshes, nor than the processors (each worker is a busy single-threaded process, so more
  /// of them only cost memory and start-up time), and at least one.
  static int useful_count(int threads, std::size_t meshes);
  explicit GmshWorkers(int count);
  ~GmshWorkers();
  GmshWorkers(const GmshWorkers&) = delete;
  GmshWorkers& operator=(const GmshWorkers&) = delete;
  int size() const { return static_cast<int>(workers_.size()); }
  /// Process ids of the live workers (0 where one is gone and not yet forked again).
  std::vector<pid_t> pids() const;
  /// Runs one request in a worker (the adapter's functions call this). When no reply has come by
  /// `deadline`, the worker is killed (and forked again for the next call) and GmshOverrun thrown.
  TetMesh run(const detail::GmshRequest& request, TetReport& report,
              std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

 private:
  struct Worker {
    pid_t pid = 0;
    int socket = -1;
    bool busy = false;
  };
  void start(std::size_t slot);
  /// Closes the socket of each given slot (killing the busy ones and all of them when `kill`), then
  /// reaps them together: one idle worker ends at end of stream within milliseconds, so
  /// stopping N takes about as long as stopping one. Any still alive after 2 s are killed.
  void stop(const std::vector<std::size_t>& slots, bool kill);
  std::vector<Worker> workers_;
  mutable std::mutex mutex_;
  std::condition_variable freed_;
};

TetMesh tetrahedralize(const TriangleSurface& surface, const TetOptions& options, TetReport* report = nullptr,
                       GmshWorkers* workers = nullptr);

/// A solid ellipsoid x = centre + rotation * diag(semi_axes) * (unit ball), meshed from gmsh's
/// exact OpenCASCADE sphere (the primitive grains of fdemrun scenes; a sphere when the three
/// semi-axes are equal).
TetMesh mesh_ellipsoid(const Eigen::Vector3d& centre, const Eigen::Vector3d& semi_axes,
                       const Eigen::Quaterniond& rotation, const TetOptions& options, TetReport* report = nullptr,
                       GmshWorkers* workers = nullptr);

}  // namespace graintwin::mesh
