#pragma once
// Internal to the packer: contact kernels between star-shaped grains (RadialTable) and between a
// grain and the container walls, with grains optionally scaled by a common growth factor.
//
// A contact region is found in two stages. (1) Samples: the grain's surface points at a fixed
// Fibonacci lattice of directions that face the other body are scored (depth inside it), and the
// local maxima of the scores among samples within reach (gap + margin) seed (2) local searches
// on the unit sphere (refine_max) that climb to the deepest point of each region. The margin
// covers what the lattice can miss between samples: a curvature term plus the grain's roughness
// (twice the largest deviation of a sample's radius from the mean of its neighbours).
#include <Eigen/Core>
#include <vector>

#include "graintwin/shape/radial_table.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::synth::detail {

/// Sample lattices: Fibonacci (golden-spiral) directions with each direction's neighbours within
/// 1.6 spacings (CSR). The coarse one (400 directions, spacing 0.18 rad) serves smooth shapes
/// (spheres, ellipsoids); the fine one (1600, 0.09 rad) rough ones, whose bumps (a degree-15 SH
/// sand grain's are about 0.2 rad wide) the coarse one would step over.
inline constexpr int kCoarseSamples = 400;
inline constexpr int kFineSamples = 1600;
struct Lattice {
  int size = 0;
  std::vector<Eigen::Vector3d> dir;
  std::vector<int> nb_start, nb;
  double spacing = 0.0;
};
const Lattice& coarse_lattice();
const Lattice& fine_lattice();

/// One shape as the kernels see it: its table, its sample lattice and its radii there (unscaled,
/// float: they only seed the searches, which look the table up exactly), and its roughness
/// slack (m, unscaled; see sample_slack()).
struct SurfaceView {
  const shape::RadialTable* table = nullptr;
  const Lattice* lattice = nullptr;
  const std::vector<float>* radii = nullptr;
  double max_radius = 0.0;  // unscaled
  double slack = 0.0;       // unscaled
};

/// Precomputed sampling data of one shape: the lattice (coarse unless the shape is rough on the
/// coarse lattice's scale, i.e. its coarse slack exceeds 8 % of its largest radius), the radii and
/// the slack.
struct ShapeSampling {
  const Lattice* lattice = nullptr;
  std::vector<float> radii;
  double slack = 0.0;
};
ShapeSampling sample_shape(const shape::RadialTable& t);
/// Twice the largest deviation of a sample's radius from the mean of its neighbours.
double sample_slack(const Lattice& lattice, const std::vector<float>& radii);
SurfaceView view_of(const shape::RadialTable& t, const ShapeSampling& sampling);

/// One distinct shape of a grain list, as the kernels see it (its sampling computed once).
struct ShapeData {
  const shape::RadialTable* table = nullptr;
  ShapeSampling sampling;
  double max_radius = 0.0;
  double volume = 0.0;
  SurfaceView view() const { return view_of(*table, sampling); }
};

/// The distinct shapes of a grain list (by pointer) and each grain's index into them; the
/// samplings are computed in parallel.
void index_shapes(const std::vector<const shape::RadialTable*>& shapes, std::vector<ShapeData>& data,
                  std::vector<int>& grain_shape);

/// Final angular step (rad) of the deepest-point searches of the exact measures: pair_contact(),
/// find_contacts(), wall_penetration() and the packer's final check.
inline constexpr double kExactRefineStep = 5e-4;

/// Pose of a grain scaled by s about its body origin: world = x + R * (s * body).
struct Frame {
  Eigen::Vector3d x{0.0, 0.0, 0.0};
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double s = 1.0;
};

/// A point where a's surface is deepest inside b (locally). depth: > 0 inside b by that distance
/// along b's normal, < 0 outside. point: midway between the two surfaces; normal: unit, from a
/// to b.
struct Side {
  double depth = 0.0;
  Eigen::Vector3d point{0.0, 0.0, 0.0};
  Eigen::Vector3d normal{0.0, 0.0, 0.0};
};

/// Up to kMaxRegions separate contact regions of one grain's surface in the other (rough grains
/// touch at several bumps), deepest first; and the body-frame directions of all the local
/// maxima the searches ended on, within the gap or not (to warm-start the next evaluation).
inline constexpr int kMaxRegions = 3;
struct SideSet {
  int n = 0;
  Side side[kMaxRegions];
  int peaks = 0;
  Eigen::Vector3d peak_dir[kMaxRegions];
  SideSet() {
    for (Eigen::Vector3d& d : peak_dir) d.setZero();
  }
};

/// Result of a pair evaluation. found == false: separated by more than `gap` (then gap_bound is a
/// conservative lower bound of the separation, used to skip the pair while grains barely move;
/// -inf when unknown). side: the deepest contact of all. ab: regions of a's surface in b; ba: of
/// b's surface in a; all normals from a to b. A convex pair has one region, seen from both sides.
struct PairEval {
  bool found = false;
  Side side;
  double gap_bound = 0.0;
  SideSet ab, ba;
};

/// Both-ways pair kernel (see pair_contact()). h_min: final angular step (rad) of the searches.
/// With `warm` (the previous result of the same pair), a side whose searches found peaks last
/// time skips the sampling and searches again from those peaks with a small step: valid while
/// the grains have moved little since, blind to a new region appearing elsewhere, and it leaves
/// gap_bound at -inf.
PairEval evaluate_pair(const SurfaceView& a, const Frame& fa, const SurfaceView& b, const Frame& fb,
                       double gap, double h_min, const PairEval* warm = nullptr);

/// Wall kernel: the contact regions (up to kMaxRegions per wall, each at its deepest point) of
/// the grain with every wall of the container that its bounding sphere comes within `gap` of,
/// where the surface comes within `gap` of the wall (depth >= -gap).
struct WallHit {
  double depth = 0.0;
  Eigen::Vector3d point{0.0, 0.0, 0.0};
  Eigen::Vector3d normal{0.0, 0.0, 0.0};  // inward (into the container)
};
/// hits needs room for kMaxWallHits; returns the number written.
inline constexpr int kMaxWallHits = 6 * kMaxRegions;
int evaluate_walls(const SurfaceView& a, const Frame& fa, const Container& c, double gap,
                   double h_min, WallHit* hits);

}  // namespace graintwin::synth::detail
