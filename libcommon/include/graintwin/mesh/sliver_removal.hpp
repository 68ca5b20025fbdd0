#pragma once
// Slivers: tetrahedra whose four corners are nearly coplanar although their edges are fair. They
// set an explicit solver's step: fdemrun's element limit is k h_min / c_d with h_min the smallest
// altitude of an element's corner tetrahedron, so one sliver of a grain halves or worse what the
// grain's element size allows. remove_slivers improves a grain's mesh until every element has a
// smallest dihedral angle and a smallest altitude above thresholds; boundary nodes move only along
// the grain's surface, when one is given, and only where nothing inside helps, so the grain's
// surface stays, but for the odd boundary element taken out as a last resort.
#include <cstddef>
#include <functional>

#include "graintwin/mesh/tet_mesh.hpp"

namespace graintwin::mesh {

struct SliverReport {
  std::size_t before = 0, after = 0;  ///< elements below the thresholds before and after the pass
  std::size_t moved = 0;              ///< interior corner nodes moved (accepted moves)
  std::size_t flips = 0;              ///< face (2 -> 3) and edge (n -> 2n - 4) flips
  std::size_t splits = 0;             ///< interior edges split by a new interior node
  std::size_t slid = 0;               ///< boundary nodes moved along the surface (accepted moves)
  double slid_volume = 0.0;           ///< m^3, what those moves added to the elements' volume (signed)
  std::size_t peeled = 0;             ///< boundary elements taken out (caps and spikes)
  double peeled_volume = 0.0;         ///< their volume, m^3: what the grain loses
  std::size_t straightened = 0;       ///< 10-node: mid-edge nodes pulled back afterwards (tet_mesh's straighten_distorted)
  double seconds = 0.0;
};

/// A point -> the nearest point of a grain's surface (the exact SH surface or the smoothed voxel
/// surface its boundary nodes were snapped onto), m.
using SurfaceProjection = std::function<Eigen::Vector3d(const Eigen::Vector3d&)>;

/// Improves the elements below `thresholds` (altitudes against the mesh's median altitude as it
/// comes in), worst first, by local operations that each must raise the smallest quality of the
/// elements they replace: moving interior corner nodes (compass search), face and edge flips, and
/// splitting an interior edge with a node then moved into place (a sliver whose four corners lie on
/// the boundary has no interior node to move). These keep the boundary nodes and triangles. Given
/// `project`, an element they cannot lift next has its boundary corners moved along the surface
/// (compass search, every trial point projected onto it): a boundary triangle with a small height
/// (a cap, its apex near the opposite edge, or a needle, with a short edge) bounds the altitude of
/// the element on it, and only moving its corners changes that. The nodes stay on the surface; the
/// grain's volume changes by what `slid_volume` reports. What still cannot be lifted on the
/// boundary is taken out as the last resort (the boundary then changes there, by the element's
/// volume): a cap (two boundary faces; no node moves, a boundary edge flips) or a spike (three
/// boundary faces; its apex, in no other element, goes). 10-node meshes keep the mid-edge nodes of
/// unchanged edges (those of the boundary included); new or moved edges get straight ones (on the
/// boundary, projected onto the surface), then distorted elements are pulled back as after
/// snapping. Deterministic. Elements it cannot lift stay as they are and are counted in `after`.
SliverReport remove_slivers(TetMesh& mesh, const SliverThresholds& thresholds, const SurfaceProjection& project = {});

}  // namespace graintwin::mesh
