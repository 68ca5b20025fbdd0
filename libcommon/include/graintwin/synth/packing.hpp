#pragma once
// Dense random packing of star-shaped grains (shape::RadialTable) in a cylinder or a box, for
// synthetic CT scans with exact ground truth (ctsynth), and the pair geometry (penetration depth,
// contact point, normal) shared by the packer and the ground-truth contact list.
//
// Method (growth with overlap relaxation, Lubachevsky-Stillinger-like; details in packing.cpp):
//  1. Every grain is shrunk by a common factor s0 (0.55, lower for elongated shapes) and placed at
//     a random position and orientation without bounding-sphere overlap (random sequential
//     addition, largest grains first).
//  2. Sweeps: the common scale s grows toward 1 at an adaptive rate that keeps the mean overlap
//     near 1 % of the mean grain radius (quasi-static compression); each sweep finds the
//     overlapping pairs (Verlet list built on a cell grid, never all pairs) and the grains that
//     cross a wall, and moves every grain by one FIRE step (a damped-dynamics energy minimiser)
//     on the overlap energy: forces along the contact normals, and torques from off-centre
//     contacts so that elongated grains turn into the gaps.
//  3. At full size the steps go on until every pair and wall overlap is within the tolerance.
// Contacts are evaluated in parallel into per-pair slots and summed per grain in a fixed order,
// so the result depends only on the inputs and the seed (bit-identical for any thread count).
// Cost: 2000 spheres or ellipsoids in 7-10 s on one core; 15 961 ellipsoids at 0.628 (the
// reference sample) in 31 s on two cores. Rough SH sand grains are much slower near jamming
// (the final relaxation creeps): 452 grains at 0.56 in ~30 s, 878 at 0.58 in ~200 s (2 cores);
// grown directly, 320 grains at 0.578 in a 3.6 mm cylinder took 18 204 sweeps in 7 min of CPU.
// Rough grains jam near 0.58 in such small cylinders (0.577 in 3.0 mm, 0.581 in 3.6 mm), where
// 300 smooth 1.3:1 ellipsoids reach 0.60 (packing test): bumps lock into each other's hollows.
// pack_in_stages() grows them with the roughness off and adds it back: the bundled series, 310
// grains at 0.5804 in 3.6 mm, 6 687 sweeps in 318 s wall (2.5 min CPU with the rest of ctsynth);
// 3 037 grains at 0.60 in a cylinder 6 mm by 12.5 mm, 1 920 sweeps in 252 s (2 cores, loaded);
// 15 226 grains at 0.60 in 10.2 mm by 21.25 mm, 943 sweeps in 440 s (2 cores, idle). A sweep costs
// 26-31 us per grain at any size; the sweeps are set by the last stage's slowest few grains.
//
// Walls and density: a hard wall leaves a looser layer about half a grain thick beside it, so
// the solid fraction over the whole container is lower than in the bulk of the packing, the more
// so the fewer grains fit across it. Measured with the Ottawa-sand size spread (d50 0.551 mm) in
// a cylinder with height = diameter: spheres jam at about 0.58 over the container with 300 grains
// (0.63 in the core) and reach 0.60 with 2000; 1.3:1 ellipsoids reach 0.63 with 300.
// PackingReport::core_solid_fraction gives the bulk value, away from the walls.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "graintwin/shape/radial_table.hpp"

namespace graintwin::synth {

/// The rigid container. Cylinder: axis z, base at z = 0, top at z = height, centred on x = y = 0.
/// Box: from (0, 0, 0) to box_size. Metres.
struct Container {
  enum class Kind { cylinder, box } kind = Kind::cylinder;
  double radius = 0.0;                          ///< cylinder radius (m)
  double height = 0.0;                          ///< cylinder height (m)
  Eigen::Vector3d box_size{0.0, 0.0, 0.0};      ///< box edge lengths (m)

  /// Inner volume (m^3).
  double volume() const;
};

/// The container kinds' names (ctsynth's --container, the packer's messages).
const char* container_kind_name(Container::Kind kind);
/// The kind named `name`; UsageError naming --container and listing the kinds otherwise.
Container::Kind parse_container_kind(const std::string& name);

/// The densest packing of equal spheres, pi / sqrt(18) = 0.7405, rounded down: no container is
/// filled beyond it (random packings of sand stop near 0.64, rough grains in narrow cylinders
/// near 0.58).
inline constexpr double kDensestPacking = 0.74;

/// Pose of one grain: position of the body origin (the grain centroid) in the world frame, and the
/// body -> world rotation.
struct PackedGrain {
  Eigen::Vector3d position{0.0, 0.0, 0.0};
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

struct PackingParams {
  /// Seed of the random start (positions, orientations). Same seed + same inputs -> same packing.
  std::uint64_t seed = 1;
  /// Largest allowed interpenetration depth of two grains (and of a grain into a wall), as a
  /// FRACTION of the smallest grain's equivalent-sphere radius (3V/4pi)^(1/3). Pairs whose gap or
  /// overlap is within the same distance count as touching. 0.005 is 0.75 um for a 0.30 mm grain,
  /// far below a CT voxel.
  double contact_tolerance = 0.005;
  /// Upper bound on relaxation sweeps (growth + final relaxation) before giving up with DataError.
  int max_sweeps = 20000;
  /// Initial common scale of the grains (0 = automatic: 0.55 for compact shapes, smaller when the
  /// bounding spheres fill much more than the grains, e.g. for elongated grains).
  double initial_scale = 0.0;
};

struct PackingReport {
  double solid_fraction = 0.0;      ///< total grain volume / container volume
  double max_overlap = 0.0;         ///< largest pair interpenetration depth (m), 0 if none
  double mean_overlap = 0.0;        ///< mean depth (m) over the pairs that interpenetrate
  int sweeps = 0;                   ///< relaxation sweeps done (growth + final)
  std::size_t touching_pairs = 0;   ///< pairs with |gap or overlap| <= tolerance
  // Additions beyond the minimum:
  double max_wall_overlap = 0.0;    ///< largest penetration of a grain into a wall (m), 0 if none
  std::size_t wall_contacts = 0;    ///< grain-wall pairs within the tolerance
  double tolerance = 0.0;           ///< the absolute tolerance used (m)
  double initial_scale = 0.0;       ///< scale the grains started from
  /// Solid fraction of the core of the container: the container shrunk by core_margin on every
  /// side (see core_solid_fraction()); NaN if the container is too small to have a core.
  double core_solid_fraction = 0.0;
  double core_margin = 0.0;         ///< d50 of the grains (volume-weighted median diameter, m)
  double seconds = 0.0;             ///< wall-clock time of pack_grains
};

/// Where a packing stands after a sweep. How long a packing takes is not known in advance: the
/// grains grow as fast as their overlaps let them, then relax until the deepest overlap is within
/// the tolerance (or jam), so this, not a share of the work, is what it reports.
struct PackingStatus {
  std::size_t stage = 0, stages = 1;  ///< pack_in_stages: this stage (from 0) of how many
  int sweep = 0, max_sweeps = 0;      ///< sweeps of this stage so far, and the most it may take
  double scale = 1.0;                 ///< the grains' size, of their full size
  double worst_overlap = 0.0;         ///< m, the deepest pair or wall overlap after the sweep
  double tolerance = 0.0;             ///< m, what every overlap must end within
};
/// Called after every sweep, from the calling thread.
using PackingObserver = std::function<void(const PackingStatus&)>;

/// A status line, e.g. "stage 1 of 3, sweep 812 of at most 20000: growing, 93.1 % of full size,
/// deepest overlap 12.30 um" or "sweep 4000 of at most 20000: at full size, deepest overlap
/// 12.30 um, to end within 5.50 um" (the stage only when there are several).
std::string packing_status_text(const PackingStatus& status);

/// An observer that logs (info) `what`, the time since it was made and packing_status_text when a
/// stage begins and every kStatusLineSeconds after: the status lines of a packing in a run's log.
PackingObserver log_packing_status(const std::string& what);

/// Places grains (shapes[i] scaled to their final size, body origin = centroid) inside the
/// container without interpenetration beyond the tolerance, densely: every pair overlaps by at most
/// the tolerance, and every grain surface lies inside the container within the tolerance. The
/// solid fraction is the total grain volume over the container volume, so the container sets the
/// density: choose it for the density wanted, below the jamming limit of the shapes, size spread
/// and grain count (see the note on walls above).
/// Throws UsageError for empty/invalid shapes or container, DataError when the grains cannot fit
/// (over kDensestPacking of the container, a grain larger than the container, or no convergence: jammed
/// before full size or overlaps not relaxed within max_sweeps). `observe` (optional) gets the
/// status after every sweep.
std::vector<PackedGrain> pack_grains(const std::vector<const shape::RadialTable*>& shapes,
                                     const Container& c, const PackingParams& p,
                                     PackingReport* report = nullptr, const PackingObserver& observe = {});

/// Removes the overlaps of grains at given poses (e.g. after prescribed loading kinematics): the
/// relaxation of pack_grains() at full size inside the container, until every pair and wall
/// overlap is within the tolerance. With p.initial_scale > 0 the grains first shrink about their
/// centres to that scale and regrow as in pack_grains() (room to rearrange, then a quasi-static
/// compression); 0 relaxes at full size. `poses` is updated in place (on success only). Grains
/// that start outside the walls are pushed in. Returns the report (sweeps counts only the
/// relaxation). Throws as pack_grains() does; p.seed is not used.
PackingReport relax_grains(const std::vector<const shape::RadialTable*>& shapes,
                           std::vector<PackedGrain>& poses, const Container& c,
                           const PackingParams& p, const PackingObserver& observe = {});

/// Packing with the roughness off, then on: the geometric counterpart of the DEM practice of
/// compacting a sample with low interparticle friction and restoring it afterwards, the usual way
/// to set a DEM sample's density (Thornton 2000, Geotechnique 50(1) 43-53; reviewed by Nawaz &
/// Combe 2021, EPJ Web of Conferences 249, 02012). Rough
/// grains lock their bumps into each other's hollows while they grow, so growing them with their
/// true surfaces jams early (near 0.58 over a 6.5 d50 cylinder, 0.64 in its core); their smooth
/// forms slide past each other into a denser arrangement, and the roughness added back at those
/// poses only needs local adjustment.
/// `stages` holds one shape per grain for every stage, smoothest first (e.g. the surfaces
/// low-passed to SH degree 7, then 11, then the true degree-15 grains; the same body frame and
/// origin in every stage): stages.front() is packed by pack_grains(), and each later stage
/// replaces the shapes at the poses reached, relax_grains() removing the overlaps the added
/// roughness makes, from grains shrunk to 0.98 that regrow (at full size a jammed packing has no
/// room to push the new bumps out: tried, it jammed). The last stage must hold the true shapes: the packing guarantees its
/// tolerance for them. The report is the last relaxation's (solid fraction of the true shapes,
/// overlaps, contacts, core fraction) with sweeps and seconds summed over all stages and the
/// growth's initial_scale. One stage is pack_grains(). `observe` gets every sweep's status with
/// its stage. Throws as pack_grains() and relax_grains() do (a DataError names the stage that
/// jammed), UsageError for no stages or stages of unequal length.
std::vector<PackedGrain> pack_in_stages(
    const std::vector<std::vector<const shape::RadialTable*>>& stages, const Container& c,
    const PackingParams& p, PackingReport* report = nullptr, const PackingObserver& observe = {});

/// Stage k's shapes (one per grain, as in pack_in_stages() above), made when that stage starts;
/// the pointers must stay valid until the next call. Lets a caller hold one stage's tables at a
/// time instead of all of them (at 20 voxels per d50 a grain's table is about 0.3 MB).
using StageShapes = std::function<std::vector<const shape::RadialTable*>(std::size_t stage)>;

/// pack_in_stages() over `stage_count` stages made one by one by `stage_shapes`; same result as
/// passing them all at once.
std::vector<PackedGrain> pack_in_stages(std::size_t stage_count, const StageShapes& stage_shapes,
                                        const Container& c, const PackingParams& p,
                                        PackingReport* report = nullptr, const PackingObserver& observe = {});

/// Solid fraction by distance from the nearest wall (the cylinder's side, base or top, or a box
/// face): element k is the fraction of the container's volume between edges[k] and edges[k + 1]
/// metres from the walls that lies inside some grain (edges increasing, >= 0; the last may be
/// HUGE_VAL for "the rest"), NaN for an empty band. Counted at deterministic quasi-random points
/// (the R3 sequence) in the container, about 512 per mean grain volume (10^5 to 4 10^6 in all;
/// error about 0.003 for a shell holding a fifth of a few hundred grains' container). Shows the
/// loose layer a hard wall leaves: in the bundled sand series, 0.31 within a quarter d50 of the
/// walls against 0.65 deeper in. Throws UsageError for mismatched or empty shapes, or edges that
/// are fewer than two or not increasing.
std::vector<double> solid_fraction_by_wall_distance(
    const std::vector<const shape::RadialTable*>& shapes, const std::vector<PackedGrain>& grains,
    const Container& c, const std::vector<double>& edges);

/// Geometry of a grain pair. overlap > 0: interpenetration depth (m); < 0: gap (m). point: world
/// contact point (midway between the two surfaces at the deepest point). normal: unit vector from
/// a to b (the outward surface normal of a at the contact, in the limit of touching grains).
struct PairContact {
  double overlap = 0.0;
  Eigen::Vector3d point{0.0, 0.0, 0.0};
  Eigen::Vector3d normal{0.0, 0.0, 0.0};
};

/// Pair geometry of grains a and b at their poses; nullopt when they are separated by more than
/// `search_gap` (m). Method: surface points of each grain at Fibonacci-lattice directions facing
/// the other grain (400, or 1600 for rough shapes) are tested against the other's radius function
/// (radial depth); every local maximum within reach seeds a local search on the unit sphere
/// (to ~0.03 degree), and depths are measured along the other grain's surface normal there; both
/// ways, the deepest point of all wins. Accurate for |overlap| much smaller than the grain radii
/// (the use case: touching grains); deep overlaps are detected but their depth is approximate.
/// Thread-safe. Each call samples both shapes afresh: for many pairs use find_contacts().
std::optional<PairContact> pair_contact(const shape::RadialTable& a, const PackedGrain& ga,
                                        const shape::RadialTable& b, const PackedGrain& gb,
                                        double search_gap);

/// A contact re-measured as the local separating direction, for the truth file. The packer's
/// kernel (pair_contact) measures depth radially and takes the normal of the deeper grain's
/// surface; at a sharp edge or corner of an angular grain that normal is undefined (the table
/// blends it over a cell) and the depth overstated: an edge pressed on a face came out 52 degrees
/// off the face normal and 8 % too deep. Here, with A and B the two grains' surface points
/// within `reach` (m) of the first contact's point (a local grid of their tables, one point per
/// table cell), the signed overlap along a unit n (from a to b) is
/// g(n) = max over A of n.x - min over B of n.y, and the contact's overlap and normal are the
/// minimum of g and its direction, found by a pattern search within 60 degrees of the first
/// normal. For convex bodies that minimum is the penetration depth (or, when apart, minus the
/// gap) and its direction the contact normal, exact for polyhedra and for spheres; on
/// non-convex (dented, rough) patches it is that of their local convex hulls. The point stays.
/// reach <= 0 takes a quarter of the smaller grain's volume-equivalent radius.
PairContact separating_contact(const shape::RadialTable& a, const PackedGrain& ga, const shape::RadialTable& b,
                               const PackedGrain& gb, const PairContact& first, double reach = 0.0);

/// A contact of grains a < b (indices into the grain list).
struct GrainContact {
  std::size_t a = 0, b = 0;
  PairContact contact;
};

/// Every pair of grains separated by at most `search_gap` (m), overlapping pairs included, as
/// pair_contact() sees them; sorted by (a, b). Candidate pairs come from a cell grid of the
/// bounding spheres (never all pairs); parallel and deterministic. For ground-truth contact lists.
std::vector<GrainContact> find_contacts(const std::vector<const shape::RadialTable*>& shapes,
                                        const std::vector<PackedGrain>& grains, double search_gap);

/// Fraction of the container's core (farther than `margin` metres from every wall) that lies
/// inside some grain: solid_fraction_by_wall_distance() over [margin, infinity). NaN when the core
/// is empty. Throws UsageError if shapes and grains differ in length.
double core_solid_fraction(const std::vector<const shape::RadialTable*>& shapes,
                           const std::vector<PackedGrain>& grains, const Container& c,
                           double margin);

/// Largest penetration depth (m) of the grain's surface through the container walls (negative: the
/// smallest clearance to the nearest wall). Same sampling + refinement as pair_contact().
double wall_penetration(const shape::RadialTable& a, const PackedGrain& ga, const Container& c);

}  // namespace graintwin::synth
