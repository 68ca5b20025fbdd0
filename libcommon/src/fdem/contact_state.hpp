#pragma once
// Internal to the contact model (fdem/contact*.cpp): ContactModel::State, the kernels' tuning
// constants and the per-step records they share. The state's geometry queries (where a node is,
// how fast it moves, pseudonormals, facing areas, a grain's tree and sphere) are inline here; the
// near-node lists live in contact_near_nodes.cpp, the narrow phase in contact_narrow_phase.cpp,
// the step in contact.cpp, walls and membrane balls in contact_boundary.cpp, the initial-overlap
// measure in contact_overlaps.cpp and the history checkpoint in contact_checkpoint.cpp.
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <tuple>
#include <vector>

#include "graintwin/fdem/contact.hpp"
#include "graintwin/fdem/contact_broadphase.hpp"
#include "graintwin/fdem/contact_bvh.hpp"
#include "graintwin/fdem/contact_law.hpp"

namespace graintwin::fdem::contact_detail {

inline constexpr std::uint32_t kNoTriangle = UINT32_MAX;
inline constexpr std::uint32_t kNoNode = UINT32_MAX;
/// Fraction of the contact limit 2 sqrt(m / k) (damped) that stable_time_step() returns: a node
/// can meet two contacts at once (a grain and a platen, or both directions), which halves m / k.
inline constexpr double kTimeStepSafety = 0.5;
/// Automatic skin, as a fraction of the smallest grain's box diagonal.
inline constexpr double kSkinFraction = 0.05;
/// Deepest detectable penetration, as a fraction of the smallest grain's smallest box side: the
/// closest-triangle search looks no farther (penalty overlaps are a few per mille of a grain).
inline constexpr double kMaxPenetrationFraction = 0.1;
/// Relative allowance for round-off between a rigid grain's nodes, as the solver places them, and
/// its pose (orientation matrices are orthogonal to about 1e-15): the pose-derived bounding radius
/// and displacement bound are widened by this fraction of the grain's size and distance from the
/// origin, so they stay bounds.
inline constexpr double kRigidRoundOff = 1e-9;
/// Relative allowance on the reach of the near-node lists for round-off in the distances, so a
/// node exactly at the bound is kept rather than lost.
inline constexpr double kReachRoundOff = 1e-6;

/// How far, as a fraction of the skin, a listed node may move in the other rigid grain's body frame
/// before its remembered search is redone (SearchMemo). Larger keeps answers longer but remembers
/// more triangles per node in contact.
inline constexpr double kMemoMarginFraction = 0.05;
/// Triangles a node in contact remembers (SearchMemo); a node with more within reach searches anew.
inline constexpr std::size_t kMemoTriangles = 6;

/// How many candidates ahead the narrow phase prefetches a pair's near-node lists.
inline constexpr std::size_t kPrefetchCandidates = 3;

// Below these sizes a parallel region costs more than the loop (and much more on a loaded machine).
inline constexpr std::size_t kParallelGrains = 64, kParallelNodes = 16384, kParallelCandidates = 4;

/// One node in contact this step.
struct NodeHit {
  std::uint32_t node = 0;
  std::uint32_t triangle = kNoTriangle;  ///< other grain's triangle; kNoTriangle against a platen
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< midpoint of node and surface point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, the direction the node is pushed
  Eigen::Vector3d arm = Eigen::Vector3d::Zero();     ///< from a rigid grain's centroid to the node
  double overlap = 0;
  /// Of `overlap`, what the contact started with and carries no force (keep_initial_overlaps);
  /// the force acts on overlap - offset.
  double offset = 0;
  NodeContactForce law;
};

/// A surface node beyond the cylinder wall.
struct WallHit {
  std::uint32_t node = 0;
  Eigen::Vector3d arm = Eigen::Vector3d::Zero();  ///< from a rigid grain's centroid to the node
  NodeContactForce law;
};

/// What one candidate's node contacts add up to (found with them, in parallel).
struct CandidateSum {
  ContactRecord record;
  double elastic_energy = 0, dissipated = 0;
  std::array<RigidLoad, 2> load;  ///< on grains a and b when rigid
};

/// A surface node to test against another grain, with the triangle of that grain it was last
/// closest to (a starting bound for the search, SurfaceTrees::kNoHint: none).
struct NearNode {
  std::uint32_t node = 0;
  std::uint32_t hint = SurfaceTrees::kNoHint;
  /// The node's reference position: between two rigid grains the step maps it straight into the
  /// other grain's body frame, so the prefilters read the list in order instead of the node's
  /// scattered current position (a cache miss per listed node: half of grain_hits by perf).
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();
  /// Between two rigid or framed grains: the node's distance outside the other grain at the build
  /// (0 when inside). The lists are sorted by it, and a step reads a list only up to the relative
  /// motion of the pair since the build: a node farther out cannot have reached the other surface.
  double clearance = 0;
};

/// What the last closest-triangle search of a listed node against the other of two rigid grains
/// found, in that grain's body frame where its surface never moves. With m the memo margin, d the
/// distance found at `at` and q the node now (the distance to a fixed surface changes by at most
/// |q - at|): a node outside at d stays outside while |q - at| < d; a node deeper than the deepest
/// detectable penetration P stays so while |q - at| < d - P; a node with nothing within P + 2m
/// stays without contact while |q - at| < 2m; and for a node in contact, the triangle closest to q
/// is among those within d + 2m of `at` while |q - at| <= m. A membrane ball's centre, which
/// touches within its radius r outside, keeps the same memo: outside at d >= r, no contact while
/// |q - at| < d - r. Answers from the memo are therefore the search's own, bit for bit (ties go to
/// the lowest index in both), and a restart that starts without memos continues exactly.
struct SearchMemo {
  Eigen::Vector3d at = Eigen::Vector3d::Zero();
  double valid2 = -1;       ///< the memo holds while |q - at|^2 < valid2 (never when negative)
  std::uint32_t count = 0;  ///< 0: no contact; else the triangles to test
  std::array<std::uint32_t, kMemoTriangles> slots{};  ///< as SurfaceTrees leaf slots
};

/// One candidate interaction of a step: grains a < b (entry `pair` of the broad phase's pairs), or
/// grain a and platen b - grains.
struct Candidate {
  std::uint32_t a = 0, b = 0, pair = 0;
};
/// Work done on one candidate (for the benchmark's throughput figures and the ranks' balance).
struct Checks {
  std::size_t nodes = 0, triangles = 0;
  bool lists_built = false;  ///< the pair's near-node lists were built again this step
  std::size_t list_nodes = 0;  ///< surface nodes the lists' building visited
};

// What a rank's balance weighs (ContactModel::take_grain_work), in checks of a node against
// another grain's surface (220 ns each with its closest-triangle searches): a node against a
// platen's plane costs 11 ns, a node visited building a pair's near-node lists 54 ns (timed in
// the pressed 1 989-grain twin of the fdem_ranks bench, where a step checks twice as many nodes
// against the platen as against grains, and building lists takes a quarter of the step).
inline constexpr double kPlatenNodeWork = 0.05;
inline constexpr double kListNodeWork = 0.25;

/// A grain pair (a < b) whose search looks deeper than max_penetration, to `depth` (m): pairs that
/// started overlapping, with their overlaps kept (ContactModel::keep_initial_overlaps).
struct DeepPair {
  std::uint32_t a = 0, b = 0;
  double depth = 0;
};

using HistoryEntry = ContactHistoryEntry;  ///< offset: NodeHit::offset
inline bool key_less(const HistoryEntry& h, std::uint32_t a, std::uint32_t b, std::uint32_t node) {
  return std::tie(h.a, h.b, h.node) < std::tie(a, b, node);
}

/// The tangential spring of one ball against one grain.
struct BallHistoryEntry {
  std::uint32_t ball = 0, grain = 0;
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();
};

/// One ball touching one grain this step.
struct BallHit {
  std::uint32_t grain = 0, triangle = 0;
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  /// On an implicit (framed) grain: the surface nodes under the ball's footprint and their shares of
  /// its force, summing to 1 (ContactModel::State::ball_footprint); else empty, and the force acts
  /// on the triangle's corners by `weights`.
  std::vector<std::pair<std::uint32_t, double>> spread;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, the direction the ball is pushed
  double overlap = 0;
  NodeContactForce law;
};

/// A grain a membrane ball may touch before its ball's list is rebuilt, with the ball's search memo
/// on it (rigid grains, in their body frame) and the triangle it last found nearest.
struct BallCandidate {
  std::uint32_t grain = 0;
  std::uint32_t hint = SurfaceTrees::kNoHint;
  SearchMemo memo;
};

/// Twice the area times the unit normal of triangle t at node positions x.
inline Eigen::Vector3d triangle_normal(const std::array<std::uint32_t, 3>& t, std::span<const Eigen::Vector3d> x) {
  return (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
}

}  // namespace graintwin::fdem::contact_detail

namespace graintwin::fdem {

using namespace contact_detail;  // ContactModel::State and the contact*.cpp files read these unqualified

struct ContactModel::State {
  std::vector<Grain> grains;
  std::vector<Material> materials;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> triangle_grain;
  std::vector<double> node_mass;
  std::size_t node_count = 0;
  ContactOptions options;
  double skin = 0, max_penetration = 0;

  std::vector<std::uint32_t> surface_offset, surface_nodes;  ///< per grain, sorted node indices
  std::vector<std::uint32_t> node_triangle_offset, node_triangles;  ///< CSR: triangles around a node
  std::vector<std::array<std::uint32_t, 3>> neighbour;  ///< triangle across edge 01, 12, 20
  std::vector<double> triangle_area;                    ///< reference, m^2
  std::vector<Eigen::Vector3d> reference_normal;        ///< per triangle, twice its reference area long
  /// Per node, the angle-weighted sum of its triangles' reference unit normals (zero off the
  /// surface): a rigid grain's corner pseudonormal, turned by its pose instead of recomputed from
  /// the corner's neighbours every test (that recomputation was a ninth of a shearing step).
  std::vector<Eigen::Vector3d> reference_corner_normal;
  /// Parallel to node_triangles: each triangle's reference unit outward normal and a third of its
  /// reference area (rigid grains' facing_area).
  std::vector<Eigen::Vector4d> node_facets;
  SurfaceTrees trees;

  std::vector<BoxPair> grain_pairs;          ///< broad phase result
  /// Per grain pair (a, b) of the broad phase: the surface nodes of a ([0]) and of b ([1]) that were
  /// within search_depth(a, b) + skin of the other grain's surface at the build. A node moves at most
  /// skin / 2 until the next build and so does every point of the other surface (linear
  /// triangles), so the distance changes by at most skin: an unlisted node stays farther than
  /// max_penetration, where the closest-triangle search would not find it either. Without
  /// options.near_node_lists: every surface node, no hints.
  std::vector<std::array<std::vector<NearNode>, 2>> near_nodes;
  /// Per listed node of near_nodes (same layout): its search memo (used between rigid grains).
  std::vector<std::array<std::vector<SearchMemo>, 2>> memos;
  /// Per grain pair: the poses of a and b when its lists were built. Between two rigid or framed
  /// grains the lists stay valid while the pair's relative motion since then is below the skin (a
  /// node then farther than max_penetration + skin from the other surface is still beyond
  /// max_penetration), whatever the other grains do: they outlive the broad phase's rebuilds and are
  /// rebuilt alone when the pair has moved that much. Other pairs' lists are rebuilt with the broad
  /// phase.
  std::vector<std::array<RigidPose, 2>> list_pose;
  double memo_margin = 0;  ///< m of SearchMemo
  /// Per grain: a sphere around its surface this step (centre, radius), a tighter prefilter than
  /// the box for nodes near a box corner (most of a round grain's box is empty).
  std::vector<Eigen::Vector3d> sphere_centre;
  std::vector<double> sphere_radius;
  /// Per grain, in the reference configuration: the centre of its surface box and the distance to
  /// its farthest surface node. A rigid grain's sphere is this one moved by its pose, without a
  /// pass over its nodes.
  std::vector<Eigen::Vector3d> reference_centre;
  std::vector<double> reference_radius;
  std::vector<Eigen::Vector3d> built_at;     ///< surface node positions at the last build
  std::vector<RigidPose> built_pose;         ///< per grain, its pose at the last build (rigid = false: none)
  std::vector<RigidPose> pose;               ///< per grain, this step's pose (rigid = false: none)
  bool need_rebuild = true;
  /// The trees and poses are those an overlaps() call left (no step since): overlaps() may update
  /// only the grains that moved.
  bool overlap_configuration = false;
  /// The next step's node contacts take their overlaps as force-free offsets (keep_initial_overlaps).
  bool adopt_initial_overlaps = false;
  std::vector<DeepPair> deep_pairs;  ///< sorted by (a, b)
  std::size_t rebuilds = 0;

  std::vector<HistoryEntry> history;  ///< sorted by (a, b, node)
  std::vector<ContactRecord> records;

  std::vector<BallHistoryEntry> ball_history;  ///< sorted by (ball, grain)
  std::vector<std::vector<BallHit>> ball_hits;   ///< per ball, this step
  std::vector<BallContact> ball_contacts;        ///< this step's, in (ball, grain) order (add_ball_forces)
  /// Per ball, the grains it may touch: every grain whose box, grown by the ball radius and the
  /// skin, held the ball's centre at the build. Complete until the ball moves skin / 2 from
  /// ball_built_at or the broad phase rebuilds (a grain node moved skin / 2); then built again.
  std::vector<std::vector<BallCandidate>> ball_candidates;
  std::vector<Eigen::Vector3d> ball_built_at;
  std::size_t ball_lists_rebuilds = ~std::size_t{0};  ///< `rebuilds` when the lists were built
  double ball_lists_radius = 0;                      ///< the ball radius they were built for

  std::vector<RigidLoad> loads;  ///< per grain, this step's (rigid_loads())
  bool record_node_forces = false;
  std::vector<Eigen::Vector3d> node_forces;  ///< per model node, this step's when recording (node_forces())
  /// Adds force to node `node` (kNoNode: a membrane ball's, not a model node) and -force over
  /// triangle t's nodes by `weights` (kNoTriangle: a platen or the wall, nothing to spread), when
  /// recording.
  void record(std::uint32_t node, std::uint32_t t, const Eigen::Vector3d& weights, const Eigen::Vector3d& force) {
    if (!record_node_forces) return;
    if (node != kNoNode) node_forces[node] += force;
    if (t != kNoTriangle)
      for (int k = 0; k < 3; ++k) node_forces[triangles[t][k]] -= weights[k] * force;
  }

  std::vector<Candidate> candidates;
  std::vector<std::array<double, 2>> candidate_motion;  ///< per grain-pair candidate: pair_motion
  std::vector<std::vector<NodeHit>> hits;
  std::vector<CandidateSum> sums;  ///< per candidate with hits
  std::vector<std::vector<WallHit>> wall_hits;  ///< per grain, this step
  std::vector<WallContactSum> wall_sums;        ///< this step's, in grain order (add_wall_forces)
  std::vector<Checks> checks;

  // A rank's share of the grains (contact_ranks.cpp); empty roles: every grain owned.
  std::vector<GrainRole> roles;
  std::vector<PairStepSum> owned_pair_sums;  ///< with roles: this step's, of candidates with an owned a
  /// Per grain, the checks of the candidates it was in and the nodes its pairs' lists visited
  /// (kPlatenNodeWork, kListNodeWork), owned grains only, since the last take_grain_work (the
  /// measured work a rank balances)
  std::vector<double> grain_work;
  /// Adds `work` to grain a's and grain b's (b < grains) grain_work, those owned; nothing without roles.
  void add_grain_work(std::uint32_t a, std::uint32_t b, double work);
  bool present(std::uint32_t g) const { return roles.empty() || roles[g] != GrainRole::absent; }
  bool owned(std::uint32_t g) const { return roles.empty() || roles[g] == GrainRole::owned; }
  /// The broad phase's `pairs` a rank evaluates: those with an owned grain (all without roles).
  std::vector<BoxPair> rank_pairs(std::vector<BoxPair> pairs) const;

  const Material& material_of(std::uint32_t grain) const { return materials[grains[grain].material]; }

  /// Where a node is now, and for a rigid grain's node its arm from the centroid (else zero).
  struct PlacedNode {
    Eigen::Vector3d at, arm;
  };
  /// Node `node` of a grain posed `body` (reference position X): placed by a rigid pose, else x[node].
  static PlacedNode place(std::uint32_t node, const RigidPose& body, const Eigen::Vector3d& X,
                          std::span<const Eigen::Vector3d> x) {
    if (!body.rigid) return {x[node], Eigen::Vector3d::Zero()};
    const Eigen::Vector3d arm = body.arm(X);
    return {body.centre + arm, arm};
  }
  /// Node `node` of grain g now.
  PlacedNode place(std::uint32_t node, std::uint32_t g, std::span<const Eigen::Vector3d> x) const {
    return place(node, pose[g], trees.reference_positions()[node], x);
  }
  Eigen::Vector3d position(std::uint32_t node, std::uint32_t g, std::span<const Eigen::Vector3d> x) const {
    return place(node, g, x).at;
  }
  /// How fast node `node` of grain g moves: by a rigid grain's pose, else v[node].
  Eigen::Vector3d velocity(std::uint32_t node, std::uint32_t g, std::span<const Eigen::Vector3d> v) const {
    const RigidPose& body = pose[g];
    return body.rigid ? body.velocity_of(trees.reference_positions()[node]) : v[node];
  }
  /// Triangle t's normal now, twice its area long: a rigid grain's reference one turned.
  Eigen::Vector3d normal_of(std::uint32_t t, std::span<const Eigen::Vector3d> x) const {
    const RigidPose& body = pose[triangle_grain[t]];
    return body.rigid ? Eigen::Vector3d(body.rotation * reference_normal[t]) : triangle_normal(triangles[t], x);
  }
  /// How fast the point with barycentric weights w on triangle t moves.
  Eigen::Vector3d surface_velocity(std::uint32_t t, const Eigen::Vector3d& w, std::span<const Eigen::Vector3d> v) const {
    const std::uint32_t g = triangle_grain[t];
    const auto& c = triangles[t];
    return w[0] * velocity(c[0], g, v) + w[1] * velocity(c[1], g, v) + w[2] * velocity(c[2], g, v);
  }
  /// From the centroid of triangle t's rigid grain to the point with barycentric weights w on it
  /// (the arm is affine in the reference position and the weights sum to 1).
  Eigen::Vector3d surface_arm(std::uint32_t t, const Eigen::Vector3d& w) const {
    const auto& c = triangles[t];
    const auto& X = trees.reference_positions();
    return pose[triangle_grain[t]].arm(w[0] * X[c[0]] + w[1] * X[c[1]] + w[2] * X[c[2]]);
  }

  /// Candidate c's record, energies and rigid loads from its hits (contact_narrow_phase.cpp).
  CandidateSum sum_hits(const Candidate& c, std::span<const NodeHit> hits) const;

  std::span<const std::uint32_t> surface(std::uint32_t grain) const {
    return {surface_nodes.data() + surface_offset[grain], surface_offset[grain + 1] - surface_offset[grain]};
  }

  /// Reference area of `node` facing `normal` in the current configuration: one third of each
  /// surrounding triangle's reference area times the cosine between the triangle's outward normal
  /// and -normal (0 when it faces away). Equals A_node on a flat patch pressed head-on, and makes a
  /// face's nodes carry exactly the face's area even when its rim nodes also border side faces.
  /// A rigid grain's `body` turns `normal` into its body frame instead, where its triangles'
  /// normals never change (node_facets: no pass over their corners).
  double facing_area(std::uint32_t node, const Eigen::Vector3d& normal, std::span<const Eigen::Vector3d> x,
                     const RigidPose& body) const {
    double area = 0;
    if (body.rigid) {
      const Eigen::Vector3d n = body.rotation.transpose() * normal;
      for (std::uint32_t k = node_triangle_offset[node]; k < node_triangle_offset[node + 1]; ++k)
        area += node_facets[k].w() * std::max(0.0, -node_facets[k].head<3>().dot(n));
      return area;
    }
    for (std::uint32_t k = node_triangle_offset[node]; k < node_triangle_offset[node + 1]; ++k) {
      const std::uint32_t t = node_triangles[k];
      const Eigen::Vector3d n = normal_of(t, x);
      const double len = n.norm();
      if (len > 0) area += triangle_area[t] / 3.0 * std::max(0.0, -n.dot(normal) / len);
    }
    return area;
  }

  /// A normal at the closest feature whose sign tells inside from outside for a closed surface
  /// (angle-weighted pseudonormals at corners, the two faces' sum at edges). A rigid grain's is its
  /// reference one turned by its pose.
  Eigen::Vector3d pseudonormal(std::uint32_t t, TriangleFeature feature, std::span<const Eigen::Vector3d> x) const {
    const RigidPose& body = pose[triangle_grain[t]];
    if (body.rigid) return body.rotation * reference_pseudonormal(t, feature);
    const std::uint32_t g = triangle_grain[t];
    return feature_normal(
        t, feature, [&](std::uint32_t triangle) { return normal_of(triangle, x); },
        [&](std::uint32_t v) {
          return corner_normal(v, [&](std::uint32_t node) { return position(node, g, x); },
                               [&](std::uint32_t triangle) { return normal_of(triangle, x); });
        });
  }
  /// The pseudonormal of triangle t's feature on its grain's reference surface (body frame).
  Eigen::Vector3d reference_pseudonormal(std::uint32_t t, TriangleFeature feature) const {
    return feature_normal(
        t, feature, [&](std::uint32_t triangle) { return reference_normal[triangle]; },
        [&](std::uint32_t v) { return reference_corner_normal[v]; });
  }
  /// The pseudonormal of triangle t's feature from its triangles' normals (any length) and, at a
  /// corner, the corner's.
  template <class Normal, class Corner>
  Eigen::Vector3d feature_normal(std::uint32_t t, TriangleFeature feature, Normal normal_of_triangle, Corner corner) const {
    const Eigen::Vector3d n = normal_of_triangle(t).normalized();
    auto across = [&](int edge) -> Eigen::Vector3d {
      const std::uint32_t o = neighbour[t][edge];
      return o == kNoTriangle ? n : Eigen::Vector3d(n + normal_of_triangle(o).normalized());
    };
    switch (feature) {
      case TriangleFeature::face: return n;
      case TriangleFeature::edge_ab: return across(0);
      case TriangleFeature::edge_bc: return across(1);
      case TriangleFeature::edge_ca: return across(2);
      default: break;
    }
    return corner(triangles[t][static_cast<int>(feature) - static_cast<int>(TriangleFeature::vertex_a)]);
  }
  /// Node v's angle-weighted pseudonormal from its corners' positions and its triangles' normals
  /// (any length: each is normalised).
  template <class Position, class Normal>
  Eigen::Vector3d corner_normal(std::uint32_t v, Position position_of, Normal normal_of_triangle) const {
    const Eigen::Vector3d at_v = position_of(v);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::uint32_t k = node_triangle_offset[v]; k < node_triangle_offset[v + 1]; ++k) {
      const auto& tri = triangles[node_triangles[k]];
      const int i = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
      const Eigen::Vector3d e1 = (position_of(tri[(i + 1) % 3]) - at_v).normalized();
      const Eigen::Vector3d e2 = (position_of(tri[(i + 2) % 3]) - at_v).normalized();
      sum += std::acos(std::clamp(e1.dot(e2), -1.0, 1.0)) * normal_of_triangle(node_triangles[k]).normalized();
    }
    return sum;
  }

  /// How deep the closest-triangle search of grain pair (a < b) looks: max_penetration, deeper for
  /// a pair that started overlapping (deep_pairs). Fixed for the run, so lists and memos stay bounds.
  double search_depth(std::uint32_t a, std::uint32_t b) const {
    if (deep_pairs.empty()) return max_penetration;
    auto it = std::lower_bound(deep_pairs.begin(), deep_pairs.end(), 0, [&](const DeepPair& d, int) {
      return std::tie(d.a, d.b) < std::tie(a, b);
    });
    return it != deep_pairs.end() && it->a == a && it->b == b ? it->depth : max_penetration;
  }

  /// The history of candidate (a, b): found once per candidate, so that each node contact searches
  /// only its pair's few entries (a search over the whole history per node contact missed the cache
  /// at every probe).
  std::span<const HistoryEntry> history_of(std::uint32_t a, std::uint32_t b) const {
    const auto first = std::lower_bound(history.begin(), history.end(), 0,
                                        [&](const HistoryEntry& h, int) { return key_less(h, a, b, 0); });
    auto last = first;
    while (last != history.end() && last->a == a && last->b == b) ++last;
    return {first, last};
  }
  static const HistoryEntry* previous_entry(std::span<const HistoryEntry> pair_history, std::uint32_t node) {
    auto it = std::lower_bound(pair_history.begin(), pair_history.end(), node,
                               [](const HistoryEntry& h, std::uint32_t n) { return h.node < n; });
    return it != pair_history.end() && it->node == node ? &*it : nullptr;
  }
  /// A node contact's force-free overlap this step: what it kept from its start (never more than
  /// its overlap now: it only shrinks as the contact opens), or all of it in the first step after
  /// keep_initial_overlaps(), else none.
  double offset_of(const HistoryEntry* previous, double overlap) const {
    if (previous) return std::min(previous->offset, overlap);
    return adopt_initial_overlaps ? overlap : 0.0;
  }

  /// Places or refits grain g's tree and sets its bounding sphere; true when one of its surface
  /// nodes may have moved more than skin / 2 since the last build (checked unless `check_moved` is
  /// false). A rigid grain with a pose needs no pass over its nodes: the sphere is its reference
  /// sphere moved, and its nodes moved at most |R - R_b| r + |(R - R_b) c + t - t_b| (reference
  /// centre c, radius r, build pose R_b, t_b).
  bool update_grain(std::uint32_t g, std::span<const Eigen::Vector3d> x, const RigidPose* pose, bool check_moved) {
    const Aabb& box = trees.bounds(g);
    this->pose[g] = pose ? *pose : RigidPose{};
    if (pose && pose->rigid) {
      trees.place(g, pose->rotation, pose->translation);
      const double slack = kRigidRoundOff * (reference_radius[g] + box.hi.cwiseAbs().maxCoeff());
      sphere_centre[g] = 0.5 * (box.lo + box.hi);
      sphere_radius[g] = reference_radius[g] + slack;
      if (!check_moved) return false;
      // built_pose is empty until the first build, which calls this with check_moved false.
      const RigidPose& b = built_pose[g];
      if (!b.rigid) return moved_nodes(g, x);
      const Eigen::Matrix3d turn = pose->rotation - b.rotation;
      const double bound = turn.norm() * reference_radius[g] +
                           (turn * reference_centre[g] + pose->translation - b.translation).norm() + slack;
      return bound > 0.5 * skin;
    }
    trees.refit(g, x);
    const Eigen::Vector3d c = 0.5 * (box.lo + box.hi);
    double reach2 = 0, deviation2 = 0;
    const RigidPose& frame = this->pose[g];
    const auto& X = trees.reference_positions();
    for (std::uint32_t node : surface(g)) {
      reach2 = std::max(reach2, (x[node] - c).squaredNorm());
      if (frame.framed) deviation2 = std::max(deviation2, (x[node] - frame.rotation * X[node] - frame.translation).squaredNorm());
    }
    sphere_centre[g] = c;
    sphere_radius[g] = std::sqrt(reach2);
    // Round-off as for a rigid grain's pose: the frame's bound stays a bound.
    if (frame.framed) this->pose[g].deviation = std::sqrt(deviation2) + kRigidRoundOff * (reference_radius[g] + box.hi.cwiseAbs().maxCoeff());
    return check_moved && moved_nodes(g, x);
  }

  /// The triangle of grain g nearest to the world point p within `radius` (SurfaceTrees::nearest);
  /// a rigid grain with a pose is searched in its body frame, on its tree that never moves.
  bool nearest(std::uint32_t g, const Eigen::Vector3d& p, double radius, std::span<const Eigen::Vector3d> x,
               SurfaceTrees::Nearest& out, std::uint32_t hint = SurfaceTrees::kNoHint) const {
    const RigidPose& body = pose[g];
    if (!body.rigid) return trees.nearest(g, p, radius, x, out, hint);
    if (!trees.nearest_in_body(g, body.rotation.transpose() * (p - body.translation), radius, out, hint)) return false;
    out.closest.point = body.rotation * out.closest.point + body.translation;
    return true;
  }

  /// Whether a surface node of grain g moved more than skin / 2 since the last build.
  bool moved_nodes(std::uint32_t g, std::span<const Eigen::Vector3d> x) const {
    const double limit2 = 0.25 * skin * skin;
    for (std::uint32_t k = surface_offset[g]; k < surface_offset[g + 1]; ++k)
      if ((position(surface_nodes[k], g, x) - built_at[k]).squaredNorm() > limit2) return true;
    return false;
  }

  // Near-node lists (contact_near_nodes.cpp).

  /// The surface nodes of grain `from` within `reach` of grain `to`'s surface, with their closest
  /// triangles (into `out`, in surface order).
  void collect_near_nodes(std::uint32_t from, std::uint32_t to, double reach, std::span<const Eigen::Vector3d> x,
                          std::vector<NearNode>& out) const;

  /// How far any surface node of grain `from` can have moved relative to grain `to`'s surface, in
  /// `to`'s body frame, since both were at poses f0 and t0 (infinity unless all four poses are rigid
  /// or framed): with the map q = A X + b of reference positions X into `to`'s frame, |dA| r + |dA c
  /// + db| for the reference sphere (c, r) of `from`, plus round-off, plus the four poses' deviations
  /// (a framed grain's nodes and surface lie that far from where its frame puts them).
  double relative_motion(std::uint32_t from, std::uint32_t to, const RigidPose& f0, const RigidPose& t0) const;

  /// The relative motion of pair k's grains since its lists were built, seen from each side's
  /// other grain ([0]: a's nodes in b's frame, [1]: b's nodes in a's frame).
  std::array<double, 2> pair_motion(std::size_t k) const;

  /// A checkpoint file's friction history and contact records under `group` (ContactModel::save),
  /// checked against this model; DataError naming the file otherwise.
  std::vector<HistoryEntry> read_history(const io::H5File& file, const std::string& group) const;
  std::vector<ContactRecord> read_records(const io::H5File& file, const std::string& group) const;

  /// Builds pair k's lists at positions x and this step's poses; the surface nodes it visited.
  std::size_t build_pair_lists(std::size_t k, std::span<const Eigen::Vector3d> x);

  /// Lists whose pair moved `motion` (pair_motion) since they were built still hold: both grains
  /// rigid or framed and moved less than the skin relative to each other.
  bool lists_hold(const std::array<double, 2>& motion) const { return motion[0] < skin && motion[1] < skin; }

  /// Replaces the broad phase's pairs by `pairs` (sorted) at positions x: a rigid pair that stays
  /// keeps its lists and memos while they hold (lists_hold); the others are built anew.
  void rebuild_pairs(std::vector<BoxPair> pairs, std::span<const Eigen::Vector3d> x);

  // Narrow phase (contact_narrow_phase.cpp, with sum_hits above).

  /// The closest-triangle search of a listed node q (in `to`'s body frame) between two rigid
  /// grains, from its memo when that still holds, else anew (and remembered). True when a triangle
  /// lies within the deepest detectable penetration; `near` is then in the body frame. `outside`
  /// tells whether the node is outside `to` given a search's answer (in the body frame).
  /// `deepest`: the pair's search_depth (P of SearchMemo). `touch`: how near outside the surface a
  /// point still touches it (0 for a node; a membrane ball's radius for its centre): a point
  /// outside at d >= touch stays without contact while |q - at| < d - touch.
  template <class Outside>
  bool nearest_remembered(std::uint32_t to, const Eigen::Vector3d& q, double deepest, NearNode& listed, SearchMemo& memo,
                          SurfaceTrees::Nearest& near, Checks& checks, Outside outside, double touch = 0) const;

  /// Nodes of grain `from` inside grain `to` (pair key a < b), with their forces, among `nodes`
  /// (whose hints are moved to the triangles found; `memos` has one per node).
  /// `moved`: the pair's relative motion since the lists were built (pair_motion; infinity
  /// unless both grains are rigid), as far as the clearance-sorted list is read.
  void grain_hits(std::uint32_t from, std::uint32_t to, const Candidate& key, std::span<NearNode> nodes,
                  std::span<SearchMemo> memos, double moved, std::span<const Eigen::Vector3d> x,
                  std::span<const Eigen::Vector3d> v, double dt, std::vector<NodeHit>& out, Checks& checks) const;

  // Membrane balls (contact_boundary.cpp, contact_narrow_phase.cpp).

  /// Every ball's candidate grains (ball_candidates) for balls of `radius` at `centres`.
  void build_ball_lists(std::span<const Eigen::Vector3d> centres, double radius);
  /// The triangle of grain candidate.grain nearest to the ball centre c within `radius` (world
  /// frame): a rigid grain is searched in its body frame through the candidate's memo. False also
  /// when the centre lies outside the grain at least `ball_radius` from it (no contact either way).
  bool ball_nearest(BallCandidate& candidate, const Eigen::Vector3d& c, double radius, double ball_radius,
                    std::span<const Eigen::Vector3d> x, SurfaceTrees::Nearest& near) const;

  /// The surface nodes of triangle t's grain within `radius` of the point `at` on t, reached over
  /// the surface from t, with shares of a force pressed there (into `out`, by node index; the shares
  /// sum to 1): each node's reference area times (1 - distance / radius). Empty when no corner of t
  /// lies within the radius.
  void ball_footprint(std::uint32_t t, const Eigen::Vector3d& at, double radius, std::span<const Eigen::Vector3d> x,
                      std::vector<std::pair<std::uint32_t, double>>& out) const;

  /// Nodes of grain key.a behind `platen`, with their forces.
  void platen_hits(const Candidate& key, const PlatenState& platen, std::span<const Eigen::Vector3d> x,
                   std::span<const Eigen::Vector3d> v, double dt, std::vector<NodeHit>& out, Checks& checks) const;
};

}  // namespace graintwin::fdem
