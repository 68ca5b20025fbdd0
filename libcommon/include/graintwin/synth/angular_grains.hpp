#pragma once
// Angular sand grains (crushed-quartz-like: flat facets, sharp edges, local dents, fine roughness)
// as an exact radial function r(direction) about the grain's centroid, for ctsynth's
// --grain-shape angular. Construction (docs/methods.md, "Angular grains"):
//  1. a random ellipsoidal core (semi-axes 1 : b : c, b and c drawn);
//  2. a convex polyhedron: the intersection of 8-20 half-spaces n.x <= h whose planes touch or cut
//     slightly into the core (n drawn quasi-uniformly on the sphere, h = the core's support along n
//     times a factor in [1 - facet_cut, 1]); planes are added where a vertex would reach beyond
//     spike_limit times the core's radius in its direction, so no vertex is a needle and the
//     polyhedron is bounded;
//  3. dents: smooth radial depressions r <- r (1 - depth (1 - (angle / width)^2)^2) within an
//     angular radius `width` of a random axis, local concavities that keep the grain star-shaped;
//  4. roughness: r <- r (1 + rho(direction)), rho a random SH field of degrees
//     roughness_from_degree .. roughness_degree with an n^-1 amplitude spectrum and a given RMS;
//  5. the planes are shifted until the centroid of the whole body (dents and roughness included)
//     is at the origin, then everything is scaled to the drawn volume-equivalent radius.
// A convex polyhedron containing its centroid is star-shaped about it, and the dents and
// roughness are multiplicative radial factors, so r is exact and single-valued: these grains are
// star-shaped about their centroid. A grain drawn with an undercut (step 6) is not:
//  6. a flat cylindrical cavity (radius undercut_radius, height undercut_height, both x r_eq) is
//     removed with its centre undercut_depth x r_eq below a surface point, its axis tilted from the
//     surface normal there by undercut_tilt, so that its raised side opens through the surface and
//     the rest lies under a roof of grain. Rays through the roof leave the grain, cross the cavity
//     and re-enter; r then describes the grain without its cavity (solid_grains.hpp:
//     PocketedGrain), and the centring of step 5 includes the cavity.
// Multiplicative factors keep
// the polyhedron's edges as sharp kinks, and the table is sampled from r itself (never from a
// truncated SH sum), so the rendered scan has sharp edges.
#include <Eigen/Core>
#include <random>
#include <vector>

#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/solid_grains.hpp"

namespace graintwin::synth {

/// Parameters of the angular family. Defaults: crushed-quartz-like grains, measured over 200
/// grains in docs/ctsynth.md ("Angular grains").
struct AngularShapeParams {
  int min_facets = 8;              ///< fewest planes drawn per grain (>= 4)
  int max_facets = 20;             ///< most planes drawn (>= min_facets, <= 64); spike cuts may add a few
  double min_core_ratio = 0.7;     ///< core semi-axes 1 : b : c with b, c / b uniform in [this, 0.95]
  double facet_cut = 0.15;         ///< planes cut up to this fraction into the core, in [0, 0.5]
  double spike_limit = 1.5;        ///< no vertex beyond this many core radii (> 1)
  int max_dents = 2;               ///< dents per grain, uniform in 0..max_dents (<= 8)
  double dent_depth = 0.10;        ///< deepest dent, a fraction of the local radius, in [0, 0.3];
                                   ///< each dent draws depth uniform in [0.5, 1] x this
  double dent_width = 0.45;        ///< dent angular radius (rad) x uniform [0.75, 1.25], in (0, 1]
  double roughness = 0.01;         ///< RMS of rho (relative radius), in [0, 0.05]
  int roughness_from_degree = 8;   ///< lowest SH degree of the roughness, >= 2
  int roughness_degree = 32;       ///< highest SH degree of the roughness, >= roughness_from_degree, <= 64
  /// Grains drawn with an undercut (random_angular_grain's `pocketed`), over the grain's
  /// volume-equivalent radius and each grain 0.85-1.15 x these: the cavity's radius, in [0.2, 1] ...
  double undercut_radius = 0.6;
  /// ... its height, in [0.1, 0.6] ...
  double undercut_height = 0.35;
  /// ... the depth of its centre below the surface, in [0.1, 0.8] ...
  double undercut_depth = 0.35;
  /// ... and the tilt of its axis from the surface normal (degrees, +-5 per grain), in [5, 60].
  double undercut_tilt_deg = 35.0;
};

/// UsageError naming the field and its allowed range if a parameter is out of range.
void validate(const AngularShapeParams& p);

/// One angular grain: the exact radial function, in metres, about the grain's origin.
struct AngularGrain {
  std::vector<Eigen::Vector3d> normals;  ///< unit outward normals of the half-spaces n.x <= h
  std::vector<double> offsets;           ///< h (m), > 0: the origin is inside
  struct Dent {
    Eigen::Vector3d axis;  ///< unit
    double depth = 0.0;    ///< fraction of the radius at the axis
    double width = 0.0;    ///< angular radius (rad)
  };
  std::vector<Dent> dents;
  std::vector<Pocket> pockets;  ///< cavities removed (m, body frame); empty for a star-shaped grain
  int roughness_degree = 0;
  Eigen::VectorXd roughness;  ///< SH coefficients of rho (sh_basis.hpp convention), degree roughness_degree; empty: none

  /// Radius of the polyhedron alone along unit u: min over planes with n.u > 0 of h / (n.u);
  /// +infinity if no plane faces u (an unbounded polyhedron).
  double polyhedron_radius(const Eigen::Vector3d& unit) const;
  /// Multiplicative factor of the dents and roughness along unit u (1 without them).
  double modulation(const Eigen::Vector3d& unit) const;
  /// Exact radius along unit u: polyhedron_radius(u) * modulation(u).
  double radius(const Eigen::Vector3d& unit) const { return polyhedron_radius(unit) * modulation(unit); }
  /// Index of the plane that bounds the polyhedron along unit u (-1 if none does).
  int facet_of(const Eigen::Vector3d& unit) const;
  /// Number of planes that bound the polyhedron along at least one of `directions`: the facets
  /// one sees (drawn planes that lie wholly outside the polyhedron do not count).
  int visible_facets(const std::vector<Eigen::Vector3d>& directions) const;

  /// The grain translated by -shift (its planes and pockets move; dents and roughness stay functions
  /// of the direction about the new origin) and scaled by `scale` (> 0) about the new origin.
  void move_origin(const Eigen::Vector3d& shift);
  void scale(double s);

  /// Radial table with n nodes per cube-face edge, every node (ghost ring included) sampled from
  /// radius(); the roughness at the nodes may be passed precomputed (modulation_at_nodes, in
  /// RadialTable::node_directions(n) order) since it does not change when the origin moves.
  shape::RadialTable table(int n, const std::vector<double>* modulation_at_nodes = nullptr) const;
  /// modulation() at RadialTable::node_directions(n).
  std::vector<double> modulation_at_nodes(int n) const;
};

/// A random angular grain (AngularShapeParams), its centroid at the origin (the centroid of its
/// table at n nodes per edge, to 1e-6 of its volume-equivalent radius) and its volume-equivalent
/// radius 1 m (of that table); `table` receives the table at n nodes. With `pocketed` the grain
/// has one undercut (step 6) and is not star-shaped: its centroid and volume are those of the table
/// less the cavity (to about 1e-3 of the radius and of the volume, from the cavity sampled on a
/// grid), and the table is its body without the cavity. Deterministic for a given rng state. Throws UsageError for
/// invalid parameters.
AngularGrain random_angular_grain(const AngularShapeParams& p, std::mt19937_64& rng, int n,
                                  shape::RadialTable* table = nullptr, bool pocketed = false);

}  // namespace graintwin::synth
