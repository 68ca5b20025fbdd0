#include "graintwin/mesh/sliver_removal.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include <Eigen/Geometry>

#include "graintwin/fdem/element.hpp"

namespace graintwin::mesh {
namespace {

using Vec = Eigen::Vector3d;
using Tet = std::array<std::uint32_t, 4>;

/// Passes over the elements still below the thresholds; each pass tries every one of them.
constexpr int kPasses = 8;
/// Largest ring of elements around an edge that edge removal retriangulates (fans from each of
/// its corners; rings are 4 to 6 in Delaunay meshes).
constexpr std::size_t kLargestRing = 8;
/// New interior nodes (edge splits) allowed, as a share of the elements coming in.
constexpr double kSplitShare = 0.25;

/// The corner mesh the pass works on: positions of every node of the mesh (mid-edge nodes are
/// carried along unused, new split nodes appended), the elements' corners (positive orientation),
/// which elements are alive and which elements use each node.
class CornerMesh {
 public:
  CornerMesh(const TetMesh& mesh, const SliverThresholds& thresholds, SurfaceProjection project)
      : thresholds_(thresholds), project_(std::move(project)), x_(mesh.nodes) {
    fixed_.assign(x_.size(), 0);
    for (const auto& t : boundary_triangles(mesh))
      for (const std::uint32_t v : t) fixed_[v] = 1;
    moved_.assign(x_.size(), 0);
    around_.resize(x_.size());
    for (std::size_t e = 0; e < mesh.element_count(); ++e) {
      const std::uint32_t* n = mesh.element(e);
      add({n[0], n[1], n[2], n[3]});
    }
    median_altitude_ = median_altitude(mesh);
  }

  /// min over the active measures of measure / threshold (>= 1: no sliver); -1 when inverted.
  double quality(const Tet& t) const {
    const Vec &a = x_[t[0]], &b = x_[t[1]], &c = x_[t[2]], &d = x_[t[3]];
    const double altitude = tet_min_altitude(a, b, c, d);
    if (!(altitude > 0.0)) return -1.0;
    double q = std::numeric_limits<double>::infinity();
    if (thresholds_.min_altitude_ratio > 0.0) q = altitude / (thresholds_.min_altitude_ratio * median_altitude_);
    if (thresholds_.min_dihedral_degrees > 0.0) q = std::min(q, tet_min_dihedral_degrees(a, b, c, d) / thresholds_.min_dihedral_degrees);
    return q;
  }
  double quality(std::uint32_t e) const { return quality(tets_[e]); }
  double worst(const std::vector<std::uint32_t>& elements) const {
    double q = std::numeric_limits<double>::infinity();
    for (const std::uint32_t e : elements) q = std::min(q, quality(e));
    return q;
  }

  std::size_t below() const {
    std::size_t n = 0;
    for (std::uint32_t e = 0; e < tets_.size(); ++e) n += alive_[e] && quality(e) < 1.0;
    return n;
  }

  /// One attempt to lift element e: its interior corners moved, then flips, then a split, then
  /// (with a surface to slide on) its boundary corners moved along the surface, then a peel.
  bool improve(std::uint32_t e, SliverReport& report, std::size_t& splits_left) {
    bool any = false;
    for (const std::uint32_t v : tets_[e])
      if (!fixed_[v] && smooth(v)) ++report.moved, any = true;
    if (quality(e) >= 1.0) return true;
    if (flip_faces(e) || remove_edges(e)) return ++report.flips, true;
    if (splits_left > 0 && split_edges(e)) return ++report.splits, --splits_left, true;
    if (project_) {
      bool slid = false;
      for (const std::uint32_t v : tets_[e])
        if (fixed_[v] && slide(v, report.slid_volume)) ++report.slid, slid = true;
      if (quality(e) >= 1.0) return true;
      any = any || slid;
    }
    if (peel(e, report.peeled_volume)) return ++report.peeled, true;
    return any;
  }

  std::vector<std::uint32_t> below_worst_first() const {
    std::vector<std::pair<double, std::uint32_t>> bad;
    for (std::uint32_t e = 0; e < tets_.size(); ++e)
      if (alive_[e]) {
        const double q = quality(e);
        if (q < 1.0) bad.emplace_back(q, e);
      }
    std::sort(bad.begin(), bad.end());
    std::vector<std::uint32_t> out;
    for (const auto& [q, e] : bad) out.push_back(e);
    return out;
  }
  bool alive(std::uint32_t e) const { return alive_[e]; }

  /// The result: alive elements in order; 10-node meshes get their mid-edge nodes back (kept for
  /// unchanged edges, straight for new ones and those at a moved node); unused nodes dropped.
  TetMesh result(const TetMesh& in) const {
    const bool quadratic = in.nodes_per_element == 10;
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;  // corner pair -> mid-edge node
    const auto key = [](std::uint32_t a, std::uint32_t b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
    std::vector<Vec> nodes = x_;
    if (quadratic)
      for (std::size_t e = 0; e < in.element_count(); ++e) {
        const std::uint32_t* n = in.element(e);
        for (int k = 0; k < 6; ++k) {
          const std::uint32_t a = n[fdem::kTet10Edges[k][0]], b = n[fdem::kTet10Edges[k][1]];
          if (!moved_[a] && !moved_[b]) mid.emplace(key(a, b), n[4 + k]);
        }
      }
    // A new mid-edge node on the boundary goes onto the surface the corners were slid along.
    const std::set<std::pair<std::uint32_t, std::uint32_t>> on_boundary =
        quadratic && project_ ? boundary_edges() : std::set<std::pair<std::uint32_t, std::uint32_t>>{};
    std::vector<std::uint32_t> elements;
    for (std::uint32_t e = 0; e < tets_.size(); ++e) {
      if (!alive_[e]) continue;
      const Tet& t = tets_[e];
      elements.insert(elements.end(), t.begin(), t.end());
      if (!quadratic) continue;
      for (const auto& edge : fdem::kTet10Edges) {
        const std::uint32_t a = t[static_cast<std::size_t>(edge[0])], b = t[static_cast<std::size_t>(edge[1])];
        const auto [it, added] = mid.emplace(key(a, b), static_cast<std::uint32_t>(nodes.size()));
        if (added) {
          const Vec midpoint = 0.5 * (x_[a] + x_[b]);
          nodes.push_back(on_boundary.contains(key(a, b)) ? project_(midpoint) : midpoint);
        }
        elements.push_back(it->second);
      }
    }
    // Keep the nodes used, in their order.
    std::vector<std::uint32_t> index(nodes.size(), std::numeric_limits<std::uint32_t>::max());
    for (const std::uint32_t v : elements) index[v] = 0;
    TetMesh out;
    out.nodes_per_element = in.nodes_per_element;
    for (std::size_t v = 0; v < nodes.size(); ++v)
      if (index[v] == 0) index[v] = static_cast<std::uint32_t>(out.nodes.size()), out.nodes.push_back(nodes[v]);
    out.elements.reserve(elements.size());
    for (const std::uint32_t v : elements) out.elements.push_back(index[v]);
    return out;
  }

 private:
  std::uint32_t add(const Tet& t) {
    const auto e = static_cast<std::uint32_t>(tets_.size());
    tets_.push_back(t);
    alive_.push_back(1);
    for (const std::uint32_t v : t) around_[v].push_back(e);
    return e;
  }
  void kill(std::uint32_t e) {
    alive_[e] = 0;
    for (const std::uint32_t v : tets_[e]) std::erase(around_[v], e);
  }
  void revive(std::uint32_t e) {
    alive_[e] = 1;
    for (const std::uint32_t v : tets_[e]) around_[v].push_back(e);
  }
  static bool has(const Tet& t, std::uint32_t v) { return std::find(t.begin(), t.end(), v) != t.end(); }

  /// Replaces `old` by `created` when every created element is valid and the worst of them is
  /// better than the worst of `old`. Callers build `created` with the same boundary as `old`
  /// (positively oriented elements with the same boundary fill the same region exactly once).
  bool replace(const std::vector<std::uint32_t>& old, const std::vector<Tet>& created) {
    double worst_new = std::numeric_limits<double>::infinity();
    for (const Tet& t : created) worst_new = std::min(worst_new, quality(t));
    if (!(worst_new > 0.0) || !(worst_new > worst(old) + 1e-9)) return false;
    for (const std::uint32_t e : old) kill(e);
    for (const Tet& t : created) add(t);
    return true;
  }

  /// (c, d) such that (a, b, c, d) is an even permutation of element e's corners, hence positive.
  std::pair<std::uint32_t, std::uint32_t> others(std::uint32_t e, std::uint32_t a, std::uint32_t b) const {
    const Tet& t = tets_[e];
    std::array<std::uint32_t, 2> rest{};
    std::size_t k = 0;
    for (const std::uint32_t v : t)
      if (v != a && v != b) rest[k++] = v;
    const Tet order{a, b, rest[0], rest[1]};
    std::array<int, 4> position{};
    for (int i = 0; i < 4; ++i) position[static_cast<std::size_t>(i)] = static_cast<int>(std::find(t.begin(), t.end(), order[static_cast<std::size_t>(i)]) - t.begin());
    int inversions = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) inversions += position[static_cast<std::size_t>(i)] > position[static_cast<std::size_t>(j)];
    return inversions % 2 == 0 ? std::make_pair(rest[0], rest[1]) : std::make_pair(rest[1], rest[0]);
  }

  /// The elements around edge (a, b) and the ring of their other corners r such that every
  /// (a, b, r_i, r_i+1) is positive; empty when the edge is on the boundary (the ring is open).
  bool ring(std::uint32_t a, std::uint32_t b, std::vector<std::uint32_t>& elements, std::vector<std::uint32_t>& r) const {
    elements.clear(), r.clear();
    std::map<std::uint32_t, std::uint32_t> next;
    for (const std::uint32_t e : around_[a])
      if (has(tets_[e], b)) {
        elements.push_back(e);
        const auto [c, d] = others(e, a, b);
        if (!next.emplace(c, d).second) return false;
      }
    if (elements.size() < 3) return false;
    std::uint32_t v = next.begin()->first;
    for (std::size_t k = 0; k < elements.size(); ++k) {
      r.push_back(v);
      const auto it = next.find(v);
      if (it == next.end()) return false;  // open: a boundary edge
      v = it->second;
    }
    return v == r.front();
  }

  /// Edges (lower corner first) of the faces that only one alive element has.
  std::set<std::pair<std::uint32_t, std::uint32_t>> boundary_edges() const {
    std::map<std::array<std::uint32_t, 3>, int> faces;
    for (std::uint32_t e = 0; e < tets_.size(); ++e)
      if (alive_[e])
        for (std::size_t i = 0; i < 4; ++i) {
          std::array<std::uint32_t, 3> f{tets_[e][(i + 1) % 4], tets_[e][(i + 2) % 4], tets_[e][(i + 3) % 4]};
          std::sort(f.begin(), f.end());
          ++faces[f];
        }
    std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
    for (const auto& [f, count] : faces)
      if (count == 1) edges.insert({{f[0], f[1]}, {f[0], f[2]}, {f[1], f[2]}});
    return edges;
  }

  /// Moves boundary node v along the surface (each trial point projected onto it) to raise the
  /// worst quality of its elements; what the elements' volume gained goes to `volume`. A cap or
  /// needle boundary triangle bounds the altitude of the element on it (the distance of its apex
  /// to the plane through any other face holding the opposite edge is at most the triangle's
  /// height), which no interior operation changes.
  bool slide(std::uint32_t v, double& volume) {
    const double before = star_volume(v);
    if (!smooth(v, project_)) return false;
    volume += star_volume(v) - before;
    return true;
  }
  double star_volume(std::uint32_t v) const {
    double sum = 0.0;
    for (const std::uint32_t e : around_[v]) {
      const Tet& t = tets_[e];
      const Vec &a = x_[t[0]], &b = x_[t[1]], &c = x_[t[2]], &d = x_[t[3]];
      sum += (b - a).cross(c - a).dot(d - a) / 6.0;
    }
    return sum;
  }

  /// Moves node v within its elements by compass search to raise their worst quality; with
  /// `onto`, every trial point is first placed by it (a boundary node kept on the surface).
  bool smooth(std::uint32_t v, const SurfaceProjection& onto = {}) {
    const std::vector<std::uint32_t> star = around_[v];
    const Vec start = x_[v];
    double best = worst(star);
    double step = 0.25 * median_altitude_;
    for (int round = 0; round < 200 && step > 1e-3 * median_altitude_; ++round) {
      // The altitude direction of the worst element at v (growing it directly), the axes and the
      // diagonals.
      std::uint32_t worst_element = star.front();
      for (const std::uint32_t e : star)
        if (quality(e) < quality(worst_element)) worst_element = e;
      std::array<Vec, 16> directions{Vec::Zero(), Vec::Zero(), Vec::UnitX(), -Vec::UnitX(), Vec::UnitY(), -Vec::UnitY(), Vec::UnitZ(), -Vec::UnitZ()};
      for (std::size_t k = 0; k < 8; ++k)
        directions[8 + k] = Vec(k & 1 ? -1 : 1, k & 2 ? -1 : 1, k & 4 ? -1 : 1).normalized();
      {
        const Tet& t = tets_[worst_element];
        std::array<Vec, 3> face;
        std::size_t k = 0;
        for (const std::uint32_t u : t)
          if (u != v) face[k++] = x_[u];
        Vec n = (face[1] - face[0]).cross(face[2] - face[0]);
        if (n.dot(x_[v] - face[0]) < 0.0) n = -n;
        if (n.squaredNorm() > 0.0) directions[0] = n.normalized(), directions[1] = -directions[0];
      }
      bool improved = false;
      const Vec here = x_[v];
      for (const Vec& d : directions) {
        if (d.squaredNorm() == 0.0) continue;
        x_[v] = onto ? onto(here + step * d) : Vec(here + step * d);
        const double q = worst(star);
        if (q > best + 1e-9) {
          best = q, improved = true;
          break;
        }
        x_[v] = here;
      }
      if (!improved) step *= 0.5;
    }
    if (x_[v] == start) return false;
    moved_[v] = 1;
    return true;
  }

  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  /// The element across the face of e opposite its corner i, or kNone on the boundary.
  std::uint32_t across(std::uint32_t e, std::size_t i) const {
    const Tet& t = tets_[e];
    const std::uint32_t a = t[(i + 1) % 4], b = t[(i + 2) % 4], c = t[(i + 3) % 4];
    for (const std::uint32_t f : around_[a])
      if (f != e && has(tets_[f], b) && has(tets_[f], c)) return f;
    return kNone;
  }

  /// Elements on the boundary that no flip or move can lift, taken out: what the grain loses is
  /// their volume (added to `volume`), no node moves.
  /// - A cap: two faces on the boundary, over the boundary edge (a b) between two nearly coplanar
  ///   boundary triangles whose far corners c and d lie close to that edge. It has no interior node
  ///   to move, every flip keeps its two boundary faces, and their small heights bound its
  ///   altitude. Taken out when (c d) is an interior edge: the boundary edge (a b) is flipped to
  ///   (c d), its two inner faces becoming the boundary.
  /// - A spike: three faces on the boundary, its apex in no other element. The apex leaves the
  ///   mesh with it, and the inner face becomes the boundary.
  bool peel(std::uint32_t e, double& volume) {
    const Tet t = tets_[e];
    std::vector<std::size_t> open;
    for (std::size_t i = 0; i < 4; ++i)
      if (across(e, i) == kNone) open.push_back(i);
    std::vector<std::uint32_t> elements, r;
    const bool cap = open.size() == 2 && ring(t[open[0]], t[open[1]], elements, r);
    const auto apex = [&] {  // the corner whose opposite face is the inner one
      for (std::size_t i = 0; i < 4; ++i)
        if (std::find(open.begin(), open.end(), i) == open.end()) return t[i];
      return t[0];
    };
    const bool spike = open.size() == 3 && around_[apex()].size() == 1;
    if (!cap && !spike) return false;
    const Vec &a = x_[t[0]], &b = x_[t[1]], &c = x_[t[2]], &d = x_[t[3]];
    volume += (b - a).cross(c - a).dot(d - a) / 6.0;
    kill(e);
    return true;
  }

  /// 2 -> 3 flips across the interior faces of element e.
  bool flip_faces(std::uint32_t e) {
    const Tet t = tets_[e];
    for (std::size_t i = 0; i < 4; ++i) {
      // The face opposite corner d = t[i], written (a, b, c) so that (a, b, c, d) is positive:
      // (a, d, b, c) is, and moving d to the end is a 3-cycle (even).
      const std::uint32_t d = t[i], a = t[(i + 1) % 4];
      const auto [b, c] = others(e, a, d);
      const std::uint32_t neighbour = across(e, i);
      if (neighbour == kNone) continue;  // a boundary face
      std::uint32_t apex = 0;
      for (const std::uint32_t u : tets_[neighbour])
        if (u != a && u != b && u != c) apex = u;
      // (a, b, c, d) positive and (a, c, b, apex) positive: the new edge (d, apex) with ring (a, c, b).
      if (replace({e, neighbour}, {Tet{d, apex, a, c}, Tet{d, apex, c, b}, Tet{d, apex, b, a}})) return true;
    }
    return false;
  }

  /// Edge removal (n elements around an interior edge -> 2n - 4) on the edges of element e: the
  /// ring retriangulated as a fan from each of its corners, the best kept if it beats the old.
  bool remove_edges(std::uint32_t e) {
    const Tet t = tets_[e];
    std::vector<std::uint32_t> elements, r;
    for (std::size_t i = 0; i < 4; ++i)
      for (std::size_t j = i + 1; j < 4; ++j) {
        if (!ring(t[i], t[j], elements, r) || r.size() > kLargestRing) continue;
        const std::uint32_t a = t[i], b = t[j];
        const std::size_t n = r.size();
        std::vector<Tet> best;
        double best_quality = -std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < n; ++k) {
          std::vector<Tet> fan;
          double q = std::numeric_limits<double>::infinity();
          for (std::size_t s = 1; s + 1 < n; ++s) {
            const std::uint32_t p = r[k], u = r[(k + s) % n], w = r[(k + s + 1) % n];
            fan.push_back({p, w, u, a});
            fan.push_back({p, u, w, b});
            q = std::min({q, quality(fan[fan.size() - 2]), quality(fan.back())});
          }
          if (q > best_quality) best_quality = q, best = std::move(fan);
        }
        if (replace(elements, best)) return true;
      }
    return false;
  }

  /// Splits an interior edge of element e (longest first) by a node at its midpoint, moved into
  /// place; kept when it raises the worst quality of the elements around the edge.
  bool split_edges(std::uint32_t e) {
    const Tet t = tets_[e];
    std::vector<std::pair<double, std::pair<std::uint32_t, std::uint32_t>>> edges;
    for (std::size_t i = 0; i < 4; ++i)
      for (std::size_t j = i + 1; j < 4; ++j) edges.push_back({-(x_[t[i]] - x_[t[j]]).squaredNorm(), {t[i], t[j]}});
    std::sort(edges.begin(), edges.end());
    std::vector<std::uint32_t> elements, r;
    for (const auto& [length, edge] : edges) {
      const auto [a, b] = edge;
      if (!ring(a, b, elements, r)) continue;
      const double before = worst(elements);
      const auto m = static_cast<std::uint32_t>(x_.size());
      x_.push_back(0.5 * (x_[a] + x_[b]));
      fixed_.push_back(0), moved_.push_back(1), around_.emplace_back();
      std::vector<std::uint32_t> created;
      for (const std::uint32_t f : elements) {
        kill(f);
        Tet with_a = tets_[f], with_b = tets_[f];
        std::replace(with_a.begin(), with_a.end(), b, m);
        std::replace(with_b.begin(), with_b.end(), a, m);
        created.push_back(add(with_a));
        created.push_back(add(with_b));
      }
      smooth(m);
      if (worst(created) > before + 1e-9) return true;
      // Undo: the new elements and node go, the old elements come back.
      for (const std::uint32_t f : created) kill(f);
      for (const std::uint32_t f : elements) revive(f);
      x_.pop_back(), fixed_.pop_back(), moved_.pop_back(), around_.pop_back();
    }
    return false;
  }

  SliverThresholds thresholds_;
  SurfaceProjection project_;
  std::vector<Vec> x_;
  std::vector<char> fixed_, moved_;
  std::vector<Tet> tets_;
  std::vector<char> alive_;
  std::vector<std::vector<std::uint32_t>> around_;
  double median_altitude_ = 0.0;
};

}  // namespace

SliverReport remove_slivers(TetMesh& mesh, const SliverThresholds& thresholds, const SurfaceProjection& project) {
  const auto started = std::chrono::steady_clock::now();
  SliverReport report;
  if (!thresholds.any() || mesh.element_count() == 0) return report;
  CornerMesh corners(mesh, thresholds, project);
  report.before = report.after = corners.below();
  if (report.before == 0) return report;
  std::size_t splits_left = static_cast<std::size_t>(std::ceil(kSplitShare * static_cast<double>(mesh.element_count())));
  for (int pass = 0; pass < kPasses; ++pass) {
    bool changed = false;
    for (const std::uint32_t e : corners.below_worst_first())
      if (corners.alive(e) && corners.quality(e) < 1.0) changed |= corners.improve(e, report, splits_left);
    if (!changed) break;
  }
  mesh = corners.result(mesh);
  if (mesh.nodes_per_element == 10) report.straightened = pull_back_curved(mesh);
  report.after = corners.below();
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return report;
}

}  // namespace graintwin::mesh
