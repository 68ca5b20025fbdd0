#include "graintwin/fdem/contact.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <tuple>
#include <unordered_map>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/contact_broadphase.hpp"
#include "graintwin/fdem/contact_bvh.hpp"
#include "graintwin/fdem/contact_law.hpp"
#include "graintwin/io/h5file.hpp"

namespace graintwin::fdem {

namespace {

constexpr std::uint32_t kNoTriangle = UINT32_MAX;
/// Fraction of the contact limit 2 sqrt(m / k) (damped) that stable_time_step() returns: a node
/// can meet two contacts at once (a grain and a platen, or both directions), which halves m / k.
constexpr double kTimeStepSafety = 0.5;
/// Automatic skin, as a fraction of the smallest grain's box diagonal.
constexpr double kSkinFraction = 0.05;
/// Deepest detectable penetration, as a fraction of the smallest grain's smallest box side: the
/// closest-triangle search looks no farther (penalty overlaps are a few per mille of a grain).
constexpr double kMaxPenetrationFraction = 0.1;
/// Relative allowance for round-off between a rigid grain's nodes, as the solver places them, and
/// its pose (orientation matrices are orthogonal to about 1e-15): the pose-derived bounding radius
/// and displacement bound are widened by this fraction of the grain's size and distance from the
/// origin, so they stay bounds.
constexpr double kRigidRoundOff = 1e-9;
/// Relative allowance on the reach of the near-node lists for round-off in the distances, so a
/// node exactly at the bound is kept rather than lost.
constexpr double kReachRoundOff = 1e-6;

/// How far, as a fraction of the skin, a listed node may move in the other rigid grain's body frame
/// before its remembered search is redone (SearchMemo). Larger keeps answers longer but remembers
/// more triangles per node in contact.
constexpr double kMemoMarginFraction = 0.02;
/// Triangles a node in contact remembers (SearchMemo); a node with more within reach searches anew.
constexpr std::size_t kMemoTriangles = 6;

/// How many candidates ahead the narrow phase prefetches a pair's near-node lists.
constexpr std::size_t kPrefetchCandidates = 3;

// Below these sizes a parallel region costs more than the loop (and much more on a loaded machine).
constexpr std::size_t kParallelGrains = 64, kParallelNodes = 16384, kParallelCandidates = 4;

/// One node in contact this step.
struct NodeHit {
  std::uint32_t node = 0;
  std::uint32_t triangle = kNoTriangle;  ///< other grain's triangle; kNoTriangle against a platen
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< midpoint of node and surface point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, the direction the node is pushed
  Eigen::Vector3d arm = Eigen::Vector3d::Zero();     ///< from a rigid grain's centroid to the node
  double overlap = 0;
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
  /// Between two rigid grains: the node's distance outside the other grain at the build (0 when
  /// inside). The lists are sorted by it, and a step reads a list only up to the relative motion
  /// of the pair since the build: a node farther out cannot have reached the other surface.
  double clearance = 0;
};

/// What the last closest-triangle search of a listed node against the other of two rigid grains
/// found, in that grain's body frame where its surface never moves. With m the memo margin, d the
/// distance found at `at` and q the node now (the distance to a fixed surface changes by at most
/// |q - at|): a node outside at d stays outside while |q - at| < d; a node deeper than the deepest
/// detectable penetration P stays so while |q - at| < d - P; a node with nothing within P + 2m
/// stays without contact while |q - at| < 2m; and for a node in contact, the triangle closest to q
/// is among those within d + 2m of `at` while |q - at| <= m. Answers from the memo are therefore
/// the search's own, bit for bit (ties go to the lowest index in both), and a restart that starts
/// without memos continues exactly.
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
/// Work done on one candidate (for the benchmark's throughput figures).
struct Checks {
  std::size_t nodes = 0, triangles = 0;
  bool lists_built = false;  ///< the pair's near-node lists were built again this step
};

struct HistoryEntry {
  std::uint32_t a = 0, b = 0, node = 0;
  Eigen::Vector3d spring = Eigen::Vector3d::Zero();
};
bool key_less(const HistoryEntry& h, std::uint32_t a, std::uint32_t b, std::uint32_t node) {
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
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, the direction the ball is pushed
  double overlap = 0;
  NodeContactForce law;
};

/// Twice the area times the unit normal of triangle t at node positions x.
Eigen::Vector3d triangle_normal(const std::array<std::uint32_t, 3>& t, std::span<const Eigen::Vector3d> x) {
  return (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
}

}  // namespace

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
  /// Parallel to node_triangles: each triangle's reference unit outward normal and a third of its
  /// reference area (rigid grains' facing_area).
  std::vector<Eigen::Vector4d> node_facets;
  SurfaceTrees trees;

  std::vector<BoxPair> grain_pairs;          ///< broad phase result
  /// Per grain pair (a, b) of the broad phase: the surface nodes of a ([0]) and of b ([1]) that were
  /// within max_penetration + skin of the other grain's surface at the build. A node moves at most
  /// skin / 2 until the next build and so does every point of the other surface (linear
  /// triangles), so the distance changes by at most skin: an unlisted node stays farther than
  /// max_penetration, where the closest-triangle search would not find it either. Without
  /// options.near_node_lists: every surface node, no hints.
  std::vector<std::array<std::vector<NearNode>, 2>> near_nodes;
  /// Per listed node of near_nodes (same layout): its search memo (used between rigid grains).
  std::vector<std::array<std::vector<SearchMemo>, 2>> memos;
  /// Per grain pair: the poses of a and b when its lists were built. Between two rigid grains the
  /// lists stay valid while the pair's relative motion since then is below the skin (a node then
  /// farther than max_penetration + skin from the other surface is still beyond max_penetration),
  /// whatever the other grains do: they outlive the broad phase's rebuilds and are rebuilt alone
  /// when the pair has moved that much. Other pairs' lists are rebuilt with the broad phase.
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
  std::size_t rebuilds = 0;

  std::vector<HistoryEntry> history;  ///< sorted by (a, b, node)
  std::vector<ContactRecord> records;

  std::vector<BallHistoryEntry> ball_history;  ///< sorted by (ball, grain)
  std::vector<std::vector<BallHit>> ball_hits;   ///< per ball, this step

  std::vector<RigidLoad> loads;  ///< per grain, this step's (rigid_loads())

  std::vector<Candidate> candidates;
  std::vector<std::array<double, 2>> candidate_motion;  ///< per grain-pair candidate: pair_motion
  std::vector<std::vector<NodeHit>> hits;
  std::vector<CandidateSum> sums;  ///< per candidate with hits
  std::vector<std::vector<WallHit>> wall_hits;  ///< per grain, this step
  std::vector<Checks> checks;

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

  /// Candidate c's record, energies and rigid loads from its hits.
  CandidateSum sum_hits(const Candidate& c, std::span<const NodeHit> hits) const {
    CandidateSum sum;
    const bool platen = c.b >= grains.size();
    const Grain& b_grain = grains[platen ? c.a : c.b];
    ContactRecord& record = sum.record;
    record.a = c.a;
    record.b = c.b;
    Eigen::Vector3d normal_force_on_b = Eigen::Vector3d::Zero(), point_sum = Eigen::Vector3d::Zero();
    double weight = 0;
    for (const NodeHit& h : hits) {
      const Eigen::Vector3d& force = h.law.force;
      // The node belongs to b (pushed along +normal by a) or to a (its reaction acts on b).
      const bool on_b = !platen && h.node >= b_grain.node_begin && h.node < b_grain.node_end;
      if (pose[on_b ? c.b : c.a].rigid) sum.load[on_b].add(h.arm, force);
      if (!platen && pose[on_b ? c.a : c.b].rigid) sum.load[!on_b].add(surface_arm(h.triangle, h.weights), -force);
      const double sign = on_b ? 1.0 : -1.0;
      record.force += sign * force;
      normal_force_on_b += sign * h.law.normal_force * h.normal;
      record.point += h.law.normal_force * h.point;
      weight += h.law.normal_force;
      point_sum += h.point;
      record.overlap = std::max(record.overlap, h.overlap);
      sum.elastic_energy += h.law.elastic_energy;
      sum.dissipated += h.law.dissipated;
    }
    // Normal-force-weighted; a plain mean when every node force is clamped to zero.
    record.point = weight > 0 ? Eigen::Vector3d(record.point / weight) : Eigen::Vector3d(point_sum / static_cast<double>(hits.size()));
    const double nf = normal_force_on_b.norm();
    record.normal = nf > 0 ? Eigen::Vector3d(normal_force_on_b / nf) : Eigen::Vector3d::Zero();
    return sum;
  }

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
  /// (angle-weighted pseudonormals at corners, the two faces' sum at edges).
  Eigen::Vector3d pseudonormal(std::uint32_t t, TriangleFeature feature, std::span<const Eigen::Vector3d> x) const {
    const Eigen::Vector3d n = normal_of(t, x).normalized();
    auto across = [&](int edge) -> Eigen::Vector3d {
      const std::uint32_t o = neighbour[t][edge];
      return o == kNoTriangle ? n : Eigen::Vector3d(n + normal_of(o, x).normalized());
    };
    switch (feature) {
      case TriangleFeature::face: return n;
      case TriangleFeature::edge_ab: return across(0);
      case TriangleFeature::edge_bc: return across(1);
      case TriangleFeature::edge_ca: return across(2);
      default: break;
    }
    const std::uint32_t v = triangles[t][static_cast<int>(feature) - static_cast<int>(TriangleFeature::vertex_a)];
    const std::uint32_t g = triangle_grain[t];
    const Eigen::Vector3d at_v = position(v, g, x);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::uint32_t k = node_triangle_offset[v]; k < node_triangle_offset[v + 1]; ++k) {
      const auto& tri = triangles[node_triangles[k]];
      const int i = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
      const Eigen::Vector3d e1 = (position(tri[(i + 1) % 3], g, x) - at_v).normalized();
      const Eigen::Vector3d e2 = (position(tri[(i + 2) % 3], g, x) - at_v).normalized();
      sum += std::acos(std::clamp(e1.dot(e2), -1.0, 1.0)) * normal_of(node_triangles[k], x).normalized();
    }
    return sum;
  }

  const Eigen::Vector3d* previous_spring(std::uint32_t a, std::uint32_t b, std::uint32_t node) const {
    auto it = std::lower_bound(history.begin(), history.end(), 0,
                               [&](const HistoryEntry& h, int) { return key_less(h, a, b, node); });
    return it != history.end() && it->a == a && it->b == b && it->node == node ? &it->spring : nullptr;
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
    double reach2 = 0;
    for (std::uint32_t node : surface(g)) reach2 = std::max(reach2, (x[node] - c).squaredNorm());
    sphere_centre[g] = c;
    sphere_radius[g] = std::sqrt(reach2);
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

  /// The surface nodes of grain `from` within `reach` of grain `to`'s surface, with their closest
  /// triangles (into `out`, in surface order).
  void collect_near_nodes(std::uint32_t from, std::uint32_t to, double reach, std::span<const Eigen::Vector3d> x,
                          std::vector<NearNode>& out) const {
    out.clear();
    if (!options.near_node_lists) {
      for (std::uint32_t node : surface(from)) out.push_back({node, SurfaceTrees::kNoHint, trees.reference_positions()[node]});
      return;
    }
    const Aabb box = trees.bounds(to).inflated(reach);
    const Eigen::Vector3d& centre = sphere_centre[to];
    const double sphere_reach2 = (sphere_radius[to] + reach) * (sphere_radius[to] + reach);
    SurfaceTrees::Nearest near;
    const bool rigid_pair = pose[from].rigid && pose[to].rigid;
    for (std::uint32_t node : surface(from)) {
      const Eigen::Vector3d p = position(node, from, x);
      if (!box.contains(p) || (p - centre).squaredNorm() > sphere_reach2 || !nearest(to, p, reach, x, near)) continue;
      const bool inside = (near.closest.point - p).dot(pseudonormal(near.triangle, near.closest.feature, x)) > 0;
      out.push_back({node, near.triangle, trees.reference_positions()[node],
                     rigid_pair && !inside ? std::sqrt(near.distance2) : 0.0});
    }
    if (rigid_pair)  // nearest first; stable, so the order is the same on every run
      std::stable_sort(out.begin(), out.end(), [](const NearNode& a, const NearNode& b) { return a.clearance < b.clearance; });
  }

  /// How far any surface node of rigid grain `from` can have moved in rigid grain `to`'s body frame
  /// since both were at poses f0 and t0 (infinity unless all four poses are rigid): with the map
  /// q = A X + b of reference positions X into `to`'s frame, |dA| r + |dA c + db| for the reference
  /// sphere (c, r) of `from`, plus round-off.
  double relative_motion(std::uint32_t from, std::uint32_t to, const RigidPose& f0, const RigidPose& t0) const {
    const RigidPose &f = pose[from], &t = pose[to];
    if (!(f.rigid && t.rigid && f0.rigid && t0.rigid)) return std::numeric_limits<double>::infinity();
    const Eigen::Matrix3d turn = t.rotation.transpose() * f.rotation - t0.rotation.transpose() * f0.rotation;
    const Eigen::Vector3d shift =
        t.rotation.transpose() * (f.translation - t.translation) - t0.rotation.transpose() * (f0.translation - t0.translation);
    const double slack = kRigidRoundOff * (reference_radius[from] + reference_centre[from].norm() +
                                           reference_radius[to] + reference_centre[to].norm());
    return turn.norm() * reference_radius[from] + (turn * reference_centre[from] + shift).norm() + slack;
  }

  /// The relative motion of pair k's grains since its lists were built, seen from each side's
  /// other grain ([0]: a's nodes in b's frame, [1]: b's nodes in a's frame).
  std::array<double, 2> pair_motion(std::size_t k) const {
    const auto [a, b] = grain_pairs[k];
    return {relative_motion(a, b, list_pose[k][0], list_pose[k][1]), relative_motion(b, a, list_pose[k][1], list_pose[k][0])};
  }

  /// Builds pair k's lists at positions x and this step's poses.
  void build_pair_lists(std::size_t k, std::span<const Eigen::Vector3d> x) {
    const double reach = (max_penetration + skin) * (1 + kReachRoundOff);
    const auto [a, b] = grain_pairs[k];
    collect_near_nodes(a, b, reach, x, near_nodes[k][0]);
    collect_near_nodes(b, a, reach, x, near_nodes[k][1]);
    for (int side : {0, 1}) memos[k][side].assign(near_nodes[k][side].size(), SearchMemo{});
    list_pose[k] = {pose[a], pose[b]};
  }

  /// Lists whose pair moved `motion` (pair_motion) since they were built still hold: both grains
  /// rigid and moved less than the skin relative to each other.
  bool lists_hold(const std::array<double, 2>& motion) const { return motion[0] < skin && motion[1] < skin; }

  /// Replaces the broad phase's pairs by `pairs` (sorted) at positions x: a rigid pair that stays
  /// keeps its lists and memos while they hold (lists_hold); the others are built anew.
  void rebuild_pairs(std::vector<BoxPair> pairs, std::span<const Eigen::Vector3d> x) {
    std::vector<std::array<std::vector<NearNode>, 2>> kept_nodes(pairs.size());
    std::vector<std::array<std::vector<SearchMemo>, 2>> kept_memos(pairs.size());
    std::vector<std::array<RigidPose, 2>> kept_pose(pairs.size());
    std::vector<char> fresh(pairs.size(), 1);
    for (std::size_t k = 0, old = 0; k < pairs.size(); ++k) {
      while (old < grain_pairs.size() && grain_pairs[old] < pairs[k]) ++old;
      if (old == grain_pairs.size() || grain_pairs[old] != pairs[k] || !lists_hold(pair_motion(old))) continue;
      kept_nodes[k] = std::move(near_nodes[old]);
      kept_memos[k] = std::move(memos[old]);
      kept_pose[k] = list_pose[old];
      fresh[k] = 0;
    }
    grain_pairs = std::move(pairs);
    near_nodes = std::move(kept_nodes);
    memos = std::move(kept_memos);
    list_pose = std::move(kept_pose);
#pragma omp parallel for schedule(dynamic, 4) if (grain_pairs.size() >= kParallelCandidates)
    for (std::int64_t k = 0; k < static_cast<std::int64_t>(grain_pairs.size()); ++k)
      if (fresh[k]) build_pair_lists(static_cast<std::size_t>(k), x);
  }

  /// The closest-triangle search of a listed node q (in `to`'s body frame) between two rigid
  /// grains, from its memo when that still holds, else anew (and remembered). True when a triangle
  /// lies within the deepest detectable penetration; `near` is then in the body frame. `outside`
  /// tells whether the node is outside `to` given a search's answer (in the body frame).
  template <class Outside>
  bool nearest_remembered(std::uint32_t to, const Eigen::Vector3d& q, NearNode& listed, SearchMemo& memo,
                          SurfaceTrees::Nearest& near, Checks& checks, Outside outside) const {
    const double deepest2 = max_penetration * max_penetration;
    if (options.search_memos && (q - memo.at).squaredNorm() < memo.valid2) {
      if (memo.count == 0) return false;
      double best2 = std::numeric_limits<double>::infinity();
      std::uint32_t best = 0;
      for (std::uint32_t k = 0; k < memo.count; ++k) {
        const std::uint32_t slot = memo.slots[k];
        const TrianglePoint closest = trees.closest_in_slot(slot, q);
        const double d2 = (closest.point - q).squaredNorm();
        if (d2 < best2 || (d2 == best2 && trees.slot_triangle(slot) < trees.slot_triangle(best)))
          near.closest = closest, near.distance2 = d2, best2 = d2, best = slot;
      }
      near.triangle = trees.slot_triangle(best);
      checks.triangles += memo.count;
      return best2 < deepest2;
    }
    // Round-off allowance on the memo's distances (positions are rounded at ~1e-16 of their size).
    const double slack = kRigidRoundOff * (reference_radius[to] + reference_centre[to].norm());
    const double margin = memo_margin;
    memo.at = q;
    memo.count = 0;
    const bool found = trees.nearest_in_body(to, q, max_penetration + 2 * margin, near, listed.hint);
    checks.triangles += near.tested;
    if (!found) {
      memo.valid2 = 2 * margin > slack ? (2 * margin - slack) * (2 * margin - slack) : -1;
      return false;
    }
    if (listed.hint != SurfaceTrees::kNoHint) listed.hint = near.triangle;
    const double d = std::sqrt(near.distance2);
    if (outside(near)) {
      memo.valid2 = d > slack ? (d - slack) * (d - slack) : -1;
      return false;
    }
    if (!options.search_memos) return near.distance2 < deepest2;
    if (!(near.distance2 < deepest2)) {
      memo.valid2 = d - max_penetration > slack ? (d - max_penetration - slack) * (d - max_penetration - slack) : -1;
      return false;
    }
    const std::size_t count = trees.slots_within_in_body(to, q, d + 2 * margin + slack, memo.slots);
    memo.count = static_cast<std::uint32_t>(std::min(count, kMemoTriangles));
    memo.valid2 = count <= kMemoTriangles ? margin * margin : -1;
    return true;
  }

  /// Nodes of grain `from` inside grain `to` (pair key a < b), with their forces, among `nodes`
  /// (whose hints are moved to the triangles found; `memos` has one per node).
  /// `moved`: the pair's relative motion since the lists were built (pair_motion; infinity
  /// unless both grains are rigid), as far as the clearance-sorted list is read.
  void grain_hits(std::uint32_t from, std::uint32_t to, const Candidate& key, std::span<NearNode> nodes,
                  std::span<SearchMemo> memos, double moved, std::span<const Eigen::Vector3d> x,
                  std::span<const Eigen::Vector3d> v, double dt, std::vector<NodeHit>& out, Checks& checks) const {
    // Two rigid grains: a listed node's reference position X maps into `to`'s body frame by one
    // affine map, q = R_to^T (R_from X + t_from - t_to), where `to`'s box and sphere are its
    // reference ones and its search memo holds; the node is placed in the world only once it is
    // found close.
    const RigidPose& body_from = pose[from];
    const RigidPose& body_to = pose[to];
    const bool rigid_pair = body_from.rigid && body_to.rigid;
    const Eigen::Matrix3d to_body = rigid_pair ? Eigen::Matrix3d(body_to.rotation.transpose() * body_from.rotation)
                                               : Eigen::Matrix3d::Identity();
    const Eigen::Vector3d to_body_shift = rigid_pair ? Eigen::Vector3d(body_to.rotation.transpose() *
                                                                       (body_from.translation - body_to.translation))
                                                     : Eigen::Vector3d::Zero();
    const Aabb& box = rigid_pair ? trees.reference_bounds(to) : trees.bounds(to);
    const Eigen::Vector3d& centre = rigid_pair ? reference_centre[to] : sphere_centre[to];
    const double reach2 = sphere_radius[to] * sphere_radius[to];
    const Material& mf = material_of(from);
    const Material& mt = material_of(to);
    const double p_n = std::min(mf.normal_penalty, mt.normal_penalty);
    const double p_t = std::min(mf.tangential_penalty, mt.tangential_penalty);
    const double mu = std::min(mf.friction, mt.friction);
    const double beta = 0.5 * (mf.damping_ratio + mt.damping_ratio);
    SurfaceTrees::Nearest near;
    // Between rigid grains the list is sorted by clearance: read it only as far as the pair moved.
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      NearNode& listed = nodes[i];
      if (listed.clearance > moved) break;
      ++checks.nodes;
      const std::uint32_t node = listed.node;
      PlacedNode placed;
      const Eigen::Vector3d& p = placed.at;
      const auto place_node = [&] { placed = place(node, body_from, listed.reference, x); };
      // From the node out to the surface, and whether that leaves the node outside.
      const auto to_surface = [&](const SurfaceTrees::Nearest& n) -> Eigen::Vector3d { return n.closest.point - p; };
      const auto outside = [&](const SurfaceTrees::Nearest& n) {
        return !(to_surface(n).dot(pseudonormal(n.triangle, n.closest.feature, x)) > 0);
      };
      bool close = false;
      if (rigid_pair) {
        const Eigen::Vector3d q = to_body * listed.reference + to_body_shift;
        if (!box.contains(q) || (q - centre).squaredNorm() > reach2) continue;
        place_node();
        const auto outside_in_world = [&](SurfaceTrees::Nearest n) {
          n.closest.point = body_to.rotation * n.closest.point + body_to.translation;
          return outside(n);
        };
        close = nearest_remembered(to, q, listed, memos[i], near, checks, outside_in_world);
        if (close) near.closest.point = body_to.rotation * near.closest.point + body_to.translation;
      } else {
        place_node();
        if (!box.contains(p) || (p - centre).squaredNorm() > reach2) continue;
        close = nearest(to, p, max_penetration, x, near, listed.hint);
        checks.triangles += near.tested;
        if (close && listed.hint != SurfaceTrees::kNoHint) listed.hint = near.triangle;
      }
      if (!close || outside(near)) continue;
      const Eigen::Vector3d d = to_surface(near);
      NodeHit hit;
      hit.overlap = std::sqrt(near.distance2);
      hit.normal = near.closest.feature == TriangleFeature::face ? Eigen::Vector3d(normal_of(near.triangle, x).normalized())
                                                                 : Eigen::Vector3d(d / hit.overlap);
      // Both directions are evaluated, each with half the penalty (docs/fdem_contact.md).
      const double area = 0.5 * facing_area(node, hit.normal, x, body_from);
      if (!(area > 0)) continue;
      const Eigen::Vector3d w = near.closest.weights;
      const Eigen::Vector3d relative = velocity(node, from, v) - surface_velocity(near.triangle, w, v);
      const Eigen::Vector3d* spring = previous_spring(key.a, key.b, node);
      hit.law = node_contact_force(contact_law(p_n, p_t, area, node_mass[node], beta, mu), hit.normal, hit.overlap,
                                   relative, spring ? *spring : Eigen::Vector3d::Zero(), dt);
      hit.node = node;
      hit.triangle = near.triangle;
      hit.weights = w;
      hit.arm = placed.arm;
      hit.point = 0.5 * (p + near.closest.point);
      out.push_back(hit);
    }
  }

  void platen_hits(const Candidate& key, const PlatenState& platen, std::span<const Eigen::Vector3d> x,
                   std::span<const Eigen::Vector3d> v, double dt, std::vector<NodeHit>& out, Checks& checks) const {
    const Material& m = material_of(key.a);
    checks.nodes += surface(key.a).size();
    for (std::uint32_t node : surface(key.a)) {
      const auto [p, arm] = place(node, key.a, x);
      const double height = (p - platen.point).dot(platen.normal);
      if (!(height < 0)) continue;
      NodeHit hit;
      hit.overlap = -height;
      hit.normal = platen.normal;
      const double area = facing_area(node, hit.normal, x, pose[key.a]);
      if (!(area > 0)) continue;
      const Eigen::Vector3d* spring = previous_spring(key.a, key.b, node);
      hit.law = node_contact_force(
          contact_law(m.normal_penalty, m.tangential_penalty, area, node_mass[node], m.damping_ratio, platen.friction),
          hit.normal, hit.overlap, velocity(node, key.a, v) - platen.velocity,
          spring ? *spring : Eigen::Vector3d::Zero(), dt);
      hit.node = node;
      hit.arm = arm;
      hit.point = p + 0.5 * hit.overlap * platen.normal;
      out.push_back(hit);
    }
  }
};

ContactModel::ContactModel(const Model& model, std::span<const double> node_mass, const ContactOptions& options)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  if (node_mass.size() != model.nodes.size())
    throw DataError(fmt::format("fdem contact: {} node masses for {} model nodes; pass one lumped mass per node.",
                                node_mass.size(), model.nodes.size()));
  if (model.triangle_grain.size() != model.triangles.size())
    throw DataError("fdem contact: the model's triangle_grain does not match its triangles; rebuild the model.");
  s.grains = model.grains;
  s.materials = model.materials;
  s.triangles = model.triangles;
  s.triangle_grain = model.triangle_grain;
  s.node_mass.assign(node_mass.begin(), node_mass.end());
  s.node_count = model.nodes.size();
  s.options = options;
  for (const Grain& g : model.grains)
    if (g.material >= model.materials.size())
      throw DataError(fmt::format("fdem contact: grain {} uses material {} of {}; fix the model's materials.",
                                  g.label, g.material, model.materials.size()));

  // Surface nodes per grain and the triangles around every node.
  s.node_triangle_offset.assign(s.node_count + 1, 0);
  for (const auto& t : s.triangles)
    for (std::uint32_t v : t) {
      if (v >= s.node_count)
        throw DataError(fmt::format("fdem contact: a surface triangle uses node {} of {}; rebuild the model.", v,
                                    s.node_count));
      ++s.node_triangle_offset[v + 1];
    }
  for (std::size_t n = 0; n < s.node_count; ++n) s.node_triangle_offset[n + 1] += s.node_triangle_offset[n];
  s.node_triangles.resize(s.node_triangle_offset.back());
  {
    std::vector<std::uint32_t> fill(s.node_triangle_offset.begin(), s.node_triangle_offset.end() - 1);
    for (std::uint32_t t = 0; t < s.triangles.size(); ++t)
      for (std::uint32_t v : s.triangles[t]) s.node_triangles[fill[v]++] = t;
  }
  s.surface_offset.push_back(0);
  double smallest_diagonal = std::numeric_limits<double>::infinity();
  double smallest_side = std::numeric_limits<double>::infinity();
  for (const Grain& g : model.grains) {
    const std::size_t first = s.surface_nodes.size();
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t)
      for (std::uint32_t v : s.triangles[t]) s.surface_nodes.push_back(v);
    std::sort(s.surface_nodes.begin() + first, s.surface_nodes.end());
    s.surface_nodes.erase(std::unique(s.surface_nodes.begin() + first, s.surface_nodes.end()), s.surface_nodes.end());
    Aabb box;
    for (std::size_t k = first; k < s.surface_nodes.size(); ++k) {
      const std::uint32_t v = s.surface_nodes[k];
      if (v < g.node_begin || v >= g.node_end)
        throw DataError(fmt::format("fdem contact: grain {}'s surface uses node {} outside its nodes; rebuild the model.",
                                    g.label, v));
      if (!(s.node_mass[v] > 0))
        throw DataError(fmt::format("fdem contact: surface node {} of grain {} has mass {}; node masses must be positive.",
                                    v, g.label, s.node_mass[v]));
      box.grow(model.nodes[v]);
    }
    s.surface_offset.push_back(static_cast<std::uint32_t>(s.surface_nodes.size()));
    const Eigen::Vector3d centre = 0.5 * (box.lo + box.hi);
    double radius2 = 0;
    for (std::size_t k = first; k < s.surface_nodes.size(); ++k)
      radius2 = std::max(radius2, (model.nodes[s.surface_nodes[k]] - centre).squaredNorm());
    s.reference_centre.push_back(centre);
    s.reference_radius.push_back(std::sqrt(radius2));
    if (s.surface_nodes.size() > first) {
      smallest_diagonal = std::min(smallest_diagonal, (box.hi - box.lo).norm());
      smallest_side = std::min(smallest_side, (box.hi - box.lo).minCoeff());
    }
  }
  if (!std::isfinite(smallest_diagonal) || !(smallest_side > 0))
    throw DataError("fdem contact: no grain has a closed surface of positive size; mesh the grains first.");
  s.skin = options.skin > 0 ? options.skin : kSkinFraction * smallest_diagonal;
  s.memo_margin = kMemoMarginFraction * s.skin;
  s.max_penetration = kMaxPenetrationFraction * smallest_side;

  // Reference triangle areas and edge neighbours (for edge pseudonormals): each grain's edges
  // sorted by their end nodes, so the two uses of an edge are adjacent.
  s.triangle_area.resize(s.triangles.size());
  s.reference_normal.resize(s.triangles.size());
  s.neighbour.assign(s.triangles.size(), {kNoTriangle, kNoTriangle, kNoTriangle});
  struct EdgeUse {
    std::uint32_t low, high, triangle;
    int edge;
  };
  std::vector<EdgeUse> edges;
  for (const Grain& g : model.grains) {
    edges.clear();
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t) {
      s.reference_normal[t] = triangle_normal(s.triangles[t], model.nodes);
      s.triangle_area[t] = 0.5 * s.reference_normal[t].norm();
      for (int e = 0; e < 3; ++e) {
        const auto [low, high] = std::minmax(s.triangles[t][e], s.triangles[t][(e + 1) % 3]);
        edges.push_back({low, high, t, e});
      }
    }
    std::sort(edges.begin(), edges.end(), [](const EdgeUse& p, const EdgeUse& q) {
      return std::tie(p.low, p.high, p.triangle) < std::tie(q.low, q.high, q.triangle);
    });
    for (std::size_t k = 0; k + 1 < edges.size(); ++k)
      if (edges[k].low == edges[k + 1].low && edges[k].high == edges[k + 1].high) {
        s.neighbour[edges[k].triangle][edges[k].edge] = edges[k + 1].triangle;
        s.neighbour[edges[k + 1].triangle][edges[k + 1].edge] = edges[k].triangle;
        ++k;
      }
  }
  s.node_facets.resize(s.node_triangles.size());
  for (std::size_t k = 0; k < s.node_triangles.size(); ++k) {
    const std::uint32_t t = s.node_triangles[k];
    const Eigen::Vector3d n = triangle_normal(s.triangles[t], model.nodes);
    const double len = n.norm();
    s.node_facets[k] << (len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero()), s.triangle_area[t] / 3.0;
  }
  s.trees = SurfaceTrees(model);
  s.pose.assign(model.grains.size(), RigidPose{});
}

ContactModel::~ContactModel() = default;
ContactModel::ContactModel(ContactModel&&) noexcept = default;
ContactModel& ContactModel::operator=(ContactModel&&) noexcept = default;

ContactStepStats ContactModel::add_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                          std::span<const PlatenState> platens, double dt,
                                          std::span<Eigen::Vector3d> f, std::span<const RigidPose> poses) {
  State& s = *state_;
  if (x.size() != s.node_count || v.size() != s.node_count || f.size() != s.node_count)
    throw DataError(fmt::format("fdem contact: positions, velocities and forces have {}, {} and {} entries for {} "
                                "nodes; pass one per model node.",
                                x.size(), v.size(), f.size(), s.node_count));
  ContactStepStats stats;
  s.records.clear();
  if (!s.options.enabled) {
    s.history.clear();
    return stats;
  }
  const auto grain_count = static_cast<std::uint32_t>(s.grains.size());

  s.sphere_centre.resize(grain_count);
  s.sphere_radius.resize(grain_count);
  s.pose.resize(grain_count);
  s.loads.assign(grain_count, RigidLoad{});
  if (!poses.empty() && poses.size() != grain_count)
    throw DataError(fmt::format("fdem contact: {} rigid poses for {} grains; pass one per grain or none.", poses.size(),
                                grain_count));
  // Trees and spheres; the pairs stay complete until a node has moved skin / 2 since the build.
  s.overlap_configuration = false;
  const bool check_moved = !s.need_rebuild;
  bool moved = false;
#pragma omp parallel for schedule(dynamic, 16) reduction(|| : moved) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g) {
    const auto k = static_cast<std::uint32_t>(g);
    if (s.update_grain(k, x, poses.empty() ? nullptr : &poses[k], check_moved)) moved = true;
  }
  s.need_rebuild = s.need_rebuild || moved;
  if (s.need_rebuild) {
    std::vector<Aabb> boxes(grain_count);
    for (std::uint32_t g = 0; g < grain_count; ++g) boxes[g] = s.trees.bounds(g).inflated(0.5 * s.skin);
    s.rebuild_pairs(overlapping_box_pairs(boxes), x);
    s.built_at.resize(s.surface_nodes.size());
    for (std::uint32_t g = 0; g < grain_count; ++g)
      for (std::uint32_t k = s.surface_offset[g]; k < s.surface_offset[g + 1]; ++k)
        s.built_at[k] = s.position(s.surface_nodes[k], g, x);
    if (poses.empty()) s.built_pose.assign(grain_count, RigidPose{});
    else s.built_pose.assign(poses.begin(), poses.end());
    s.need_rebuild = false;
    ++s.rebuilds;
    stats.rebuilt = true;
  }
  stats.pairs = s.grain_pairs.size();

  // This step's candidates in (a, b) order: grain pairs whose current boxes overlap, then each
  // grain's platens whose plane cuts its box.
  s.candidates.clear();
  for (std::size_t k = 0, a = 0; a < grain_count; ++a) {
    for (; k < s.grain_pairs.size() && s.grain_pairs[k].first == a; ++k)
      if (s.trees.bounds(a).overlaps(s.trees.bounds(s.grain_pairs[k].second)))
        s.candidates.push_back({s.grain_pairs[k].first, s.grain_pairs[k].second, static_cast<std::uint32_t>(k)});
    const Aabb& box = s.trees.bounds(a);
    if (!(box.lo.array() <= box.hi.array()).all()) continue;
    for (std::uint32_t p = 0; p < platens.size(); ++p) {
      // The box corner deepest along -normal decides whether the plane can touch the grain.
      const Eigen::Vector3d& n = platens[p].normal;
      const Eigen::Vector3d deepest{n.x() > 0 ? box.lo.x() : box.hi.x(), n.y() > 0 ? box.lo.y() : box.hi.y(),
                                    n.z() > 0 ? box.lo.z() : box.hi.z()};
      if ((deepest - platens[p].point).dot(n) < 0) s.candidates.push_back({static_cast<std::uint32_t>(a), grain_count + p});
    }
  }

  // Narrow phase: each candidate's hits depend only on the state, not on the thread that found
  // them, and are applied below in candidate order: results are the same for any thread count.
  if (s.hits.size() < s.candidates.size()) s.hits.resize(s.candidates.size());
  s.checks.assign(s.candidates.size(), {});
  s.sums.resize(s.candidates.size());
  // Rigid pairs whose lists no longer hold build them again first, so that the narrow phase below
  // changes no list's storage (its prefetches read other pairs' lists).
  s.candidate_motion.resize(s.candidates.size());
#pragma omp parallel for schedule(static) if (s.candidates.size() >= kParallelCandidates)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(s.candidates.size()); ++i)
    if (s.candidates[i].b < grain_count) s.candidate_motion[i] = s.pair_motion(s.candidates[i].pair);
  std::vector<std::uint32_t> stale;
  for (std::uint32_t i = 0; i < s.candidates.size(); ++i)
    if (s.candidates[i].b < grain_count && std::isfinite(s.candidate_motion[i][0]) && !s.lists_hold(s.candidate_motion[i]))
      stale.push_back(i);
#pragma omp parallel for schedule(dynamic, 1) if (stale.size() >= kParallelCandidates)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(stale.size()); ++k) {
    const std::uint32_t i = stale[k];
    s.build_pair_lists(s.candidates[i].pair, x);
    s.checks[i].lists_built = true;
    s.candidate_motion[i] = s.pair_motion(s.candidates[i].pair);
  }
#pragma omp parallel for schedule(dynamic, 4) if (s.candidates.size() >= kParallelCandidates)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(s.candidates.size()); ++i) {
    const Candidate& c = s.candidates[i];
    // The heads of a later pair's lists are scattered over the heap: fetch them early (a cache miss
    // per list was a quarter of grain_hits by perf). Prefetching never faults.
    if (const std::size_t ahead = static_cast<std::size_t>(i) + kPrefetchCandidates; ahead < s.candidates.size()) {
      const Candidate& later = s.candidates[ahead];
      if (later.b < grain_count)
        for (int side : {0, 1}) {
          __builtin_prefetch(s.near_nodes[later.pair][side].data());
          __builtin_prefetch(s.memos[later.pair][side].data());
        }
    }
    std::vector<NodeHit>& out = s.hits[i];
    out.clear();
    if (c.b >= grain_count) {
      s.platen_hits(c, platens[c.b - grain_count], x, v, dt, out, s.checks[i]);
    } else {
      const std::array<double, 2>& moved = s.candidate_motion[i];
      s.grain_hits(c.a, c.b, c, s.near_nodes[c.pair][0], s.memos[c.pair][0], moved[0], x, v, dt, out, s.checks[i]);
      s.grain_hits(c.b, c.a, c, s.near_nodes[c.pair][1], s.memos[c.pair][1], moved[1], x, v, dt, out, s.checks[i]);
      // History lookups need (a, b, node) order; the grains' node ranges need not be increasing.
      if (!std::is_sorted(out.begin(), out.end(), [](const NodeHit& p, const NodeHit& q) { return p.node < q.node; }))
        std::sort(out.begin(), out.end(), [](const NodeHit& p, const NodeHit& q) { return p.node < q.node; });
    }
    if (!out.empty()) s.sums[i] = s.sum_hits(c, out);
  }

  s.history.clear();
  for (std::size_t i = 0; i < s.candidates.size(); ++i) {
    const Candidate& c = s.candidates[i];
    stats.node_checks += s.checks[i].nodes;
    stats.triangle_checks += s.checks[i].triangles;
    stats.pair_lists_built += s.checks[i].lists_built;
    if (s.hits[i].empty()) continue;
    // Forces on deformable grains' nodes, in candidate order; rigid grains get their sums.
    const bool platen = c.b >= grain_count;
    const bool node_rigid[2] = {s.pose[c.a].rigid, !platen && s.pose[c.b].rigid};
    const Grain& b_grain = s.grains[platen ? c.a : c.b];
    for (const NodeHit& h : s.hits[i]) {
      const bool on_b = !platen && h.node >= b_grain.node_begin && h.node < b_grain.node_end;
      if (!node_rigid[on_b]) f[h.node] += h.law.force;
      if (!platen && !node_rigid[!on_b]) {
        const auto& tri = s.triangles[h.triangle];
        for (int k = 0; k < 3; ++k) f[tri[k]] -= h.weights[k] * h.law.force;
      }
      s.history.push_back({c.a, c.b, h.node, h.law.spring});
    }
    const CandidateSum& sum = s.sums[i];
    if (node_rigid[0]) s.loads[c.a] += sum.load[0];
    if (node_rigid[1]) s.loads[c.b] += sum.load[1];
    stats.elastic_energy += sum.elastic_energy;
    stats.dissipated += sum.dissipated;
    stats.node_contacts += s.hits[i].size();
    stats.max_overlap = std::max(stats.max_overlap, sum.record.overlap);
    s.records.push_back(sum.record);
  }
  return stats;
}

BoundaryContactStats ContactModel::add_wall_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                                   const CylinderWallState& wall, double dt, std::span<Eigen::Vector3d> f) {
  State& s = *state_;
  const auto grain_count = static_cast<std::int64_t>(s.grains.size());
  s.wall_hits.resize(s.grains.size());
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= static_cast<std::int64_t>(kParallelGrains))
  for (std::int64_t g = 0; g < grain_count; ++g) {
    std::vector<WallHit>& hits = s.wall_hits[g];
    hits.clear();
    const Aabb& box = s.trees.bounds(static_cast<std::size_t>(g));
    if (!(box.lo.array() <= box.hi.array()).all()) continue;
    // The box corner farthest from the axis, and the bounding sphere, decide whether the wall can
    // touch the grain.
    const double fx = std::max(std::abs(box.lo.x() - wall.axis_xy.x()), std::abs(box.hi.x() - wall.axis_xy.x()));
    const double fy = std::max(std::abs(box.lo.y() - wall.axis_xy.y()), std::abs(box.hi.y() - wall.axis_xy.y()));
    if (fx * fx + fy * fy <= wall.radius * wall.radius) continue;
    if ((s.sphere_centre[g].head<2>() - wall.axis_xy).norm() + s.sphere_radius[g] <= wall.radius) continue;
    const Material& m = s.material_of(static_cast<std::uint32_t>(g));
    const auto grain = static_cast<std::uint32_t>(g);
    for (std::uint32_t node : s.surface(grain)) {
      const auto [p, arm] = s.place(node, grain, x);
      const Eigen::Vector3d radial(p.x() - wall.axis_xy.x(), p.y() - wall.axis_xy.y(), 0.0);
      const double rho = radial.norm();
      if (!(rho > wall.radius)) continue;
      const Eigen::Vector3d outward = radial / rho;
      const double area = s.facing_area(node, -outward, x, s.pose[g]);
      if (!(area > 0)) continue;
      const ContactLaw law = contact_law(m.normal_penalty, m.tangential_penalty, area, s.node_mass[node], m.damping_ratio, 0.0);
      hits.push_back({node, arm, node_contact_force(law, -outward, rho - wall.radius,
                                                    s.velocity(node, grain, v) - wall.radial_velocity * outward,
                                                    Eigen::Vector3d::Zero(), dt)});
    }
  }
  BoundaryContactStats stats;
  for (std::uint32_t g = 0; g < grain_count; ++g)
    for (const auto& [node, arm, law] : s.wall_hits[g]) {
      if (s.pose[g].rigid) s.loads[g].add(arm, law.force);
      else f[node] += law.force;
      stats.radial_force += law.normal_force;
      stats.elastic_energy += law.elastic_energy;
      stats.dissipated += law.dissipated;
      ++stats.contacts;
    }
  return stats;
}

BoundaryContactStats ContactModel::add_ball_forces(std::span<const Eigen::Vector3d> x, std::span<const Eigen::Vector3d> v,
                                                   std::span<const Eigen::Vector3d> centres,
                                                   std::span<const Eigen::Vector3d> ball_velocity,
                                                   std::span<const Eigen::Vector3d> ball_spin,
                                                   const BallContactOptions& balls, double dt, std::span<Eigen::Vector3d> f,
                                                   std::span<Eigen::Vector3d> ball_force,
                                                   std::span<Eigen::Vector3d> ball_moment) {
  State& s = *state_;
  const std::size_t n = centres.size();
  if (ball_velocity.size() != n || ball_spin.size() != n || ball_force.size() != n || ball_moment.size() != n)
    throw DataError("fdem contact: ball positions, velocities, spins, forces and moments must have one entry per ball");
  if (!(balls.radius > 0) || !(balls.mass > 0)) throw UsageError("membrane balls need a positive radius and mass");
  const double r = balls.radius;
  // Broad phase: the grains' boxes, inflated by the ball radius, in a hash grid of cells as large
  // as the largest box, so a box spans at most 8 cells and a ball looks in one.
  double cell = 0;
  for (std::size_t g = 0; g < s.grains.size(); ++g) {
    const Aabb& box = s.trees.bounds(g);
    if ((box.lo.array() <= box.hi.array()).all()) cell = std::max(cell, (box.hi - box.lo).maxCoeff());
  }
  cell += 2 * r;
  const auto index = [cell](double c) { return static_cast<std::int64_t>(std::floor(c / cell)); };
  const auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const auto bits = [](std::int64_t a) { return static_cast<std::uint64_t>(a + (1 << 20)) & 0x1FFFFFu; };
    return bits(i) << 42 | bits(j) << 21 | bits(k);
  };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  for (std::uint32_t g = 0; g < s.grains.size(); ++g) {
    const Aabb& box = s.trees.bounds(g);
    if (!(box.lo.array() <= box.hi.array()).all()) continue;
    const Aabb grown = box.inflated(r);
    for (std::int64_t i = index(grown.lo.x()); i <= index(grown.hi.x()); ++i)
      for (std::int64_t j = index(grown.lo.y()); j <= index(grown.hi.y()); ++j)
        for (std::int64_t k = index(grown.lo.z()); k <= index(grown.hi.z()); ++k) grid[key(i, j, k)].push_back(g);
  }
  const auto spring_of = [&](std::uint32_t ball, std::uint32_t grain) -> Eigen::Vector3d {
    const auto it = std::lower_bound(s.ball_history.begin(), s.ball_history.end(), std::make_pair(ball, grain),
                                     [](const BallHistoryEntry& h, const std::pair<std::uint32_t, std::uint32_t>& k) {
                                       return std::tie(h.ball, h.grain) < std::tie(k.first, k.second);
                                     });
    return it != s.ball_history.end() && it->ball == ball && it->grain == grain ? it->spring : Eigen::Vector3d::Zero();
  };
  const double area = std::numbers::pi * r * r;
  if (s.ball_hits.size() < n) s.ball_hits.resize(n);
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelNodes / 4)
  for (std::int64_t b = 0; b < static_cast<std::int64_t>(n); ++b) {
    std::vector<BallHit>& out = s.ball_hits[b];
    out.clear();
    const Eigen::Vector3d& c = centres[b];
    const auto it = grid.find(key(index(c.x()), index(c.y()), index(c.z())));
    if (it == grid.end()) continue;
    for (std::uint32_t g : it->second) {
      if (!s.trees.bounds(g).inflated(r).contains(c)) continue;
      SurfaceTrees::Nearest near;
      if (!s.nearest(g, c, r + s.max_penetration, x, near)) continue;
      const Eigen::Vector3d d = near.closest.point - c;  // from the centre to the surface
      const double dist = std::sqrt(near.distance2);
      const bool inside = d.dot(s.pseudonormal(near.triangle, near.closest.feature, x)) > 0;
      BallHit hit;
      hit.overlap = inside ? r + dist : r - dist;
      if (!(hit.overlap > 0)) continue;
      const Eigen::Vector3d face = s.normal_of(near.triangle, x).normalized();
      hit.normal = dist > 1e-12 * r ? Eigen::Vector3d((inside ? 1.0 : -1.0) * d / dist) : face;
      const Eigen::Vector3d w = near.closest.weights;
      const Eigen::Vector3d surface_velocity = s.surface_velocity(near.triangle, w, v);
      const Eigen::Vector3d contact_velocity = ball_velocity[b] + ball_spin[b].cross(-r * hit.normal);
      const Material& m = s.material_of(g);
      hit.law = node_contact_force(contact_law(m.normal_penalty, m.tangential_penalty, area, balls.mass, m.damping_ratio,
                                               balls.friction),
                                   hit.normal, hit.overlap, contact_velocity - surface_velocity,
                                   spring_of(static_cast<std::uint32_t>(b), g), dt);
      hit.grain = g;
      hit.triangle = near.triangle;
      hit.weights = w;
      out.push_back(hit);
    }
    std::sort(out.begin(), out.end(), [](const BallHit& p, const BallHit& q) { return p.grain < q.grain; });
  }
  BoundaryContactStats stats;
  s.ball_history.clear();
  for (std::uint32_t b = 0; b < n; ++b)
    for (const BallHit& h : s.ball_hits[b]) {
      const Eigen::Vector3d& force = h.law.force;
      ball_force[b] += force;
      ball_moment[b] += (-r * h.normal).cross(force - h.law.normal_force * h.normal);
      if (s.pose[h.grain].rigid) {
        s.loads[h.grain].add(s.surface_arm(h.triangle, h.weights), -force);
      } else {
        const auto& tri = s.triangles[h.triangle];
        for (int k = 0; k < 3; ++k) f[tri[k]] -= h.weights[k] * force;
      }
      stats.elastic_energy += h.law.elastic_energy;
      stats.dissipated += h.law.dissipated;
      stats.max_overlap = std::max(stats.max_overlap, h.overlap);
      ++stats.contacts;
      s.ball_history.push_back({b, h.grain, h.law.spring});
    }
  return stats;
}

std::vector<Overlap> ContactModel::overlaps(std::span<const Eigen::Vector3d> x, std::span<const PlatenState> platens,
                                           std::span<const std::uint8_t> moved) {
  State& s = *state_;
  if (x.size() != s.node_count)
    throw DataError(fmt::format("fdem contact: {} positions for {} nodes; pass one per model node.", x.size(), s.node_count));
  const auto grain_count = static_cast<std::uint32_t>(s.grains.size());
  if (!moved.empty() && moved.size() != grain_count)
    throw DataError(fmt::format("fdem contact: {} moved flags for {} grains; pass one per grain.", moved.size(), grain_count));
  // Only a configuration left by an earlier overlaps() call (same poses, same trees) can be updated
  // in part; after a step (or the first time) every grain is placed again.
  const bool all = moved.empty() || !s.overlap_configuration;
  const auto changed = [&](std::uint32_t g) { return all || moved[g] != 0; };
  s.sphere_centre.resize(grain_count);
  s.sphere_radius.resize(grain_count);
  if (all) s.pose.assign(grain_count, RigidPose{});
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g)
    if (changed(static_cast<std::uint32_t>(g))) s.update_grain(static_cast<std::uint32_t>(g), x, nullptr, false);
  s.need_rebuild = true;  // the trees and poses are this configuration's, not the run's
  s.overlap_configuration = true;

  std::vector<Aabb> boxes(grain_count);
  for (std::uint32_t g = 0; g < grain_count; ++g) boxes[g] = s.trees.bounds(g);
  std::vector<BoxPair> pairs = overlapping_box_pairs(boxes);
  if (!all) std::erase_if(pairs, [&](const BoxPair& p) { return !changed(p.first) && !changed(p.second); });
  const double unbounded = std::numeric_limits<double>::infinity();
  // The deepest point of grain `from` inside grain `to`: its surface nodes and triangle centroids
  // within `to`'s box and bounding sphere, each searched without a bound.
  const auto deepest = [&](std::uint32_t from, std::uint32_t to) {
    const Aabb& box = boxes[to];
    const double reach2 = s.sphere_radius[to] * s.sphere_radius[to];
    double depth = 0;
    SurfaceTrees::Nearest near;
    const auto test = [&](const Eigen::Vector3d& p) {
      if (!box.contains(p) || (p - s.sphere_centre[to]).squaredNorm() > reach2) return;
      if (!s.nearest(to, p, unbounded, x, near)) return;
      const bool inside = (near.closest.point - p).dot(s.pseudonormal(near.triangle, near.closest.feature, x)) > 0;
      if (inside) depth = std::max(depth, std::sqrt(near.distance2));
    };
    for (std::uint32_t node : s.surface(from)) test(x[node]);
    const Grain& g = s.grains[from];
    for (std::uint32_t t = g.triangle_begin; t < g.triangle_end; ++t) {
      const auto& c = s.triangles[t];
      test((x[c[0]] + x[c[1]] + x[c[2]]) / 3.0);
    }
    return depth;
  };
  std::vector<double> pair_depth(pairs.size(), 0.0);
#pragma omp parallel for schedule(dynamic, 4) if (pairs.size() >= kParallelCandidates)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(pairs.size()); ++k) {
    const auto [a, b] = pairs[static_cast<std::size_t>(k)];
    pair_depth[static_cast<std::size_t>(k)] = std::max(deepest(a, b), deepest(b, a));
  }
  // Behind a platen: the deepest surface node (a flat cut's deepest point is a vertex).
  std::vector<std::vector<Overlap>> behind(grain_count);
#pragma omp parallel for schedule(dynamic, 16) if (grain_count >= kParallelGrains)
  for (std::int64_t g = 0; g < grain_count; ++g) {
    const auto grain = static_cast<std::uint32_t>(g);
    if (!changed(grain)) continue;
    for (std::uint32_t p = 0; p < platens.size(); ++p) {
      double depth = 0;
      for (std::uint32_t node : s.surface(grain)) depth = std::max(depth, (platens[p].point - x[node]).dot(platens[p].normal));
      if (depth > 0) behind[grain].push_back({grain, grain_count + p, depth});
    }
  }
  std::vector<Overlap> out;
  for (std::uint32_t g = 0, k = 0; g < grain_count; ++g) {
    for (; k < pairs.size() && pairs[k].first == g; ++k)
      if (pair_depth[k] > 0) out.push_back({pairs[k].first, pairs[k].second, pair_depth[k]});
    out.insert(out.end(), behind[g].begin(), behind[g].end());
  }
  return out;
}

double ContactModel::ball_stable_time_step(const BallContactOptions& balls) const {
  const State& s = *state_;
  double dt = std::numeric_limits<double>::infinity();
  for (const Material& m : s.materials) {
    const double k_n = m.normal_penalty * std::numbers::pi * balls.radius * balls.radius;
    if (!(k_n > 0) || !(balls.mass > 0)) continue;
    const double beta = m.damping_ratio;
    dt = std::min(dt, kTimeStepSafety * 2.0 / std::sqrt(k_n / balls.mass) * (std::sqrt(1 + beta * beta) - beta));
  }
  return dt;
}

std::span<const RigidLoad> ContactModel::rigid_loads() const { return state_->loads; }

std::vector<ContactRecord> ContactModel::contacts() const { return state_->records; }

double ContactModel::stable_time_step() const {
  const State& s = *state_;
  double dt = std::numeric_limits<double>::infinity();
  for (std::uint32_t g = 0; g < s.grains.size(); ++g) {
    const Material& m = s.material_of(g);
    const double beta = m.damping_ratio;
    for (std::uint32_t node : s.surface(g)) {
      double area = 0;
      for (std::uint32_t k = s.node_triangle_offset[node]; k < s.node_triangle_offset[node + 1]; ++k)
        area += s.triangle_area[s.node_triangles[k]] / 3.0;
      const double k_n = m.normal_penalty * area;
      if (!(k_n > 0)) continue;
      // Critical step of a damped oscillator: (2 / omega) (sqrt(1 + beta^2) - beta).
      const double omega = std::sqrt(k_n / s.node_mass[node]);
      dt = std::min(dt, kTimeStepSafety * 2.0 / omega * (std::sqrt(1 + beta * beta) - beta));
    }
  }
  return dt;
}

std::size_t ContactModel::rebuild_count() const { return state_->rebuilds; }
double ContactModel::skin() const { return state_->skin; }

void ContactModel::save(io::H5File& file, const std::string& group) const {
  const State& s = *state_;
  file.ensure_group(group);
  file.set_attr(group, "entries", static_cast<long long>(s.history.size()));
  file.set_attr(group, "ball_entries", static_cast<long long>(s.ball_history.size()));
  file.set_attr(group, "record_entries", static_cast<long long>(s.records.size()));
  if (!s.records.empty()) {  // the last step's contacts, for a frame written before the next step
    std::vector<std::uint32_t> pair(2 * s.records.size());
    std::vector<double> values;
    values.reserve(10 * s.records.size());
    for (std::size_t i = 0; i < s.records.size(); ++i) {
      const ContactRecord& r = s.records[i];
      pair[2 * i] = r.a;
      pair[2 * i + 1] = r.b;
      values.insert(values.end(), {r.point[0], r.point[1], r.point[2], r.normal[0], r.normal[1], r.normal[2], r.force[0],
                                   r.force[1], r.force[2], r.overlap});
    }
    const hsize_t n = s.records.size();
    io::DatasetOptions exact;
    exact.compress = false;
    file.write(group + "/record_pair", pair.data(), {n, 2});
    file.write(group + "/record_values", values.data(), {n, 10}, exact);
  }
  if (!s.history.empty()) {
    std::vector<std::uint32_t> pair(2 * s.history.size()), node(s.history.size());
    std::vector<double> spring(3 * s.history.size());
    for (std::size_t i = 0; i < s.history.size(); ++i) {
      const HistoryEntry& h = s.history[i];
      pair[2 * i] = h.a;
      pair[2 * i + 1] = h.b;
      node[i] = h.node;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
    }
    const hsize_t n = s.history.size();
    file.write(group + "/pair", pair.data(), {n, 2});
    file.write(group + "/node", node.data(), {n});
    file.write(group + "/spring", spring.data(), {n, 3}, io::units("N"));
  }
  if (!s.ball_history.empty()) {  // membrane balls' friction springs
    std::vector<std::uint32_t> ball_grain(2 * s.ball_history.size());
    std::vector<double> spring(3 * s.ball_history.size());
    for (std::size_t i = 0; i < s.ball_history.size(); ++i) {
      const BallHistoryEntry& h = s.ball_history[i];
      ball_grain[2 * i] = h.ball;
      ball_grain[2 * i + 1] = h.grain;
      for (int k = 0; k < 3; ++k) spring[3 * i + k] = h.spring[k];
    }
    const hsize_t n = s.ball_history.size();
    file.write(group + "/ball_grain", ball_grain.data(), {n, 2});
    file.write(group + "/ball_spring", spring.data(), {n, 3}, io::units("N"));
  }
}

void ContactModel::load(const io::H5File& file, const std::string& group) {
  State& s = *state_;
  auto bad = [&](const std::string& why) {
    return DataError(fmt::format("{}: the contact history in {} {}; write the checkpoint with this model.",
                                 file.path().string(), group, why));
  };
  const auto entries = file.attr_int(group, "entries");
  if (!entries || *entries < 0) throw bad("has no 'entries' count");
  // Each count is checked against its tables before it sizes anything: a damaged count must
  // not allocate (a record_entries of 2^32 asked for 377 GB).
  std::vector<HistoryEntry> history;
  if (*entries > 0) {
    std::vector<hsize_t> pair_dims, node_dims, spring_dims;
    const auto pair = file.read<std::uint32_t>(group + "/pair", &pair_dims);
    const auto node = file.read<std::uint32_t>(group + "/node", &node_dims);
    const auto spring = file.read<double>(group + "/spring", &spring_dims);
    const auto n = static_cast<hsize_t>(*entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || node_dims != std::vector<hsize_t>{n} ||
        spring_dims != std::vector<hsize_t>{n, 3})
      throw bad(fmt::format("does not hold {} entries in pair (n x 2), node (n) and spring (n x 3)", n));
    history.resize(n);
    for (std::size_t i = 0; i < history.size(); ++i)
      history[i] = {pair[2 * i], pair[2 * i + 1], node[i], {spring[3 * i], spring[3 * i + 1], spring[3 * i + 2]}};
  }
  for (std::size_t i = 0; i < history.size(); ++i) {
    const HistoryEntry& h = history[i];
    if (h.a >= s.grains.size() || h.b <= h.a || h.node >= s.node_count)
      throw bad(fmt::format("names grain pair ({}, {}) and node {} outside a model of {} grains and {} nodes", h.a,
                            h.b, h.node, s.grains.size(), s.node_count));
    if (i > 0 && !key_less(history[i - 1], h.a, h.b, h.node)) throw bad("is not sorted by pair and node");
  }
  const auto ball_entries = file.attr_int(group, "ball_entries").value_or(0);
  if (ball_entries < 0) throw bad("has a negative 'ball_entries' count");
  std::vector<BallHistoryEntry> ball_history;
  if (ball_entries > 0) {
    std::vector<hsize_t> pair_dims, spring_dims;
    const auto ball_grain = file.read<std::uint32_t>(group + "/ball_grain", &pair_dims);
    const auto spring = file.read<double>(group + "/ball_spring", &spring_dims);
    const auto n = static_cast<hsize_t>(ball_entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || spring_dims != std::vector<hsize_t>{n, 3})
      throw bad(fmt::format("does not hold {} ball entries in ball_grain (n x 2) and ball_spring (n x 3)", n));
    ball_history.resize(n);
    for (std::size_t i = 0; i < ball_history.size(); ++i) {
      ball_history[i] = {ball_grain[2 * i], ball_grain[2 * i + 1], {spring[3 * i], spring[3 * i + 1], spring[3 * i + 2]}};
      const BallHistoryEntry& h = ball_history[i];
      if (h.grain >= s.grains.size()) throw bad(fmt::format("names grain {} of a model of {} grains", h.grain, s.grains.size()));
      if (i > 0 && std::make_pair(ball_history[i - 1].ball, ball_history[i - 1].grain) >= std::make_pair(h.ball, h.grain))
        throw bad("is not sorted by ball and grain");
    }
  }
  const auto record_entries = file.attr_int(group, "record_entries").value_or(0);
  if (record_entries < 0) throw bad("has a negative 'record_entries' count");
  std::vector<ContactRecord> records;
  if (record_entries > 0) {
    std::vector<hsize_t> pair_dims, value_dims;
    const auto pair = file.read<std::uint32_t>(group + "/record_pair", &pair_dims);
    const auto values = file.read<double>(group + "/record_values", &value_dims);
    const auto n = static_cast<hsize_t>(record_entries);
    if (pair_dims != std::vector<hsize_t>{n, 2} || value_dims != std::vector<hsize_t>{n, 10})
      throw bad(fmt::format("does not hold {} contact records in record_pair (n x 2) and record_values (n x 10)", n));
    records.resize(n);
    for (std::size_t i = 0; i < records.size(); ++i) {
      const double* v = values.data() + 10 * i;
      records[i] = {pair[2 * i], pair[2 * i + 1], {v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}, v[9]};
    }
  }
  s.history = std::move(history);
  s.ball_history = std::move(ball_history);
  s.records = std::move(records);
  s.need_rebuild = true;
  s.overlap_configuration = false;
}

}  // namespace graintwin::fdem
