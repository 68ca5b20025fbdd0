#pragma once
// A meshed sphere rolling on a rigid plane under gravity: the check of contact fidelity on curved
// grains (docs/fdemrun.md, rolling). A sphere meshed with flat facets is a polyhedron: it pivots
// from vertex to vertex, its centre rising and falling by about h^2 / (8 R), and each new vertex
// strikes the plane. Whether it keeps the contact (rolls) or hops depends on the mesh size h, the
// speed against sqrt(g R) and the contact's restitution; this module measures it. gmsh is passed
// in (mesh/ellipsoid_grain.hpp: mesh::append_ellipsoid_grain), as for the impacts.
#include <cstddef>

#include "graintwin/fdem/model.hpp"
#include "graintwin/fdem/scene.hpp"

namespace graintwin::fdem {

struct RollingSetup {
  Material material;           ///< friction: enough to roll without slip; density: rescaled to the exact sphere mass
  double radius = 0;           ///< m
  double element_size = 0;     ///< m, uniform over the sphere
  GrainKind kind = GrainKind::rigid;
  double speed = 0;            ///< m/s along x at the start, with the spin speed / radius of rolling without slip
  double gravity = 9.81;       ///< m/s^2, along -z
  /// p_n = p_t = penalty_per_size x E / element_size when > 0; 0 keeps the material's penalties.
  double penalty_per_size = 10;
  double turns = 1;            ///< the run ends when the centroid has moved this many circumferences
  double max_steps = 5e7;      ///< a setup that needs more steps is refused before it runs
};

struct RollingOutcome {
  std::size_t elements = 0, nodes = 0;
  double time_step = 0;        ///< s, the stable step used
  std::size_t steps = 0;
  /// Share of the steps in which the plane carried a normal force: 1 for a sphere that rolls, far
  /// below for one that hops.
  double contact_share = 0;
  /// Rotation about y (the spin integrated over the run) x R over the centroid's travel along x:
  /// 1 for rolling without slip on the sphere's radius.
  double rolling_ratio = 0;
  double speed_ratio = 0;      ///< the centroid's speed at the end over the speed at the start
  /// m, the highest the centroid rose above its height at the start (a hop's height).
  double largest_rise = 0;
  /// m, the centre's rise over a pivot between neighbouring surface nodes, h^2 / (8 R) with h the
  /// mesh's contact_element_size (median surface edge).
  double pivot_rise = 0;
  /// m, the plane's static penalty overlap under the sphere's weight, m g / k of one contact node
  /// (k = p_n x its share of the surface): below pivot_rise the plane cannot hold every pivot.
  double static_overlap = 0;
  /// m, the mesh's mass centre from the sphere's centre (gmsh's nodes are not symmetric; frames
  /// and fdemrun's centroids are the mesh's).
  double centroid_offset = 0;
  double seconds = 0;          ///< wall time of the steps (meshing excluded)
};

/// Meshes the sphere (through `mesher`, e.g. mesh::append_ellipsoid_grain), sets it on the plane
/// z = 0 at its lowest node, rolling along x without slip at `speed`, and runs at the stable step
/// until its centroid has travelled `turns` circumferences. UsageError for a bad setup (naming the
/// value) or one needing more than max_steps steps.
RollingOutcome run_rolling(const RollingSetup& setup, const CurvedGrainMesher& mesher);

}  // namespace graintwin::fdem
