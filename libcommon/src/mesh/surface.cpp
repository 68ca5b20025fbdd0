#include "graintwin/mesh/surface.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/Geometry>

namespace graintwin::mesh {
namespace {

using Vec = Eigen::Vector3d;

std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
  return lo << 32 | hi;
}

/// Signed volume (x6) of the tetrahedron (a, b, c, d).
double orient(const Vec& a, const Vec& b, const Vec& c, const Vec& d) { return (b - a).cross(c - a).dot(d - a); }

/// True when the segment (p, q) passes through the interior of triangle (a, b, c): p and q strictly
/// on opposite sides of its plane and the crossing strictly inside all three edges. `eps` is the
/// volume below which a sign counts as zero (touching is not crossing).
bool segment_crosses(const Vec& p, const Vec& q, const Vec& a, const Vec& b, const Vec& c, double eps) {
  const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if (!((sp > eps && sq < -eps) || (sp < -eps && sq > eps))) return false;
  const double s1 = orient(p, q, a, b), s2 = orient(p, q, b, c), s3 = orient(p, q, c, a);
  return (s1 > eps && s2 > eps && s3 > eps) || (s1 < -eps && s2 < -eps && s3 < -eps);
}

int shared_vertices(const std::array<int, 3>& s, const std::array<int, 3>& t) {
  int n = 0;
  for (int a : s)
    for (int b : t) n += a == b;
  return n;
}

bool triangles_cross(const TriangleSurface& m, std::size_t i, std::size_t j, double eps) {
  const auto& s = m.triangles[i];
  const auto& t = m.triangles[j];
  const auto v = [&](int k) -> const Vec& { return m.vertices[static_cast<std::size_t>(k)]; };
  const Vec ns = (v(s[1]) - v(s[0])).cross(v(s[2]) - v(s[0])), nt = (v(t[1]) - v(t[0])).cross(v(t[2]) - v(t[0]));
  switch (shared_vertices(s, t)) {
    case 2:  // a fold: the two triangles lie back to back
      return ns.dot(nt) < -std::cos(5.0 * M_PI / 180.0) * ns.norm() * nt.norm();
    case 1: {  // the edge opposite the shared vertex
      const auto opposite = [](const std::array<int, 3>& a, const std::array<int, 3>& b) {
        for (int k = 0; k < 3; ++k)
          if (std::find(b.begin(), b.end(), a[static_cast<std::size_t>(k)]) != b.end())
            return std::array<int, 2>{a[static_cast<std::size_t>((k + 1) % 3)], a[static_cast<std::size_t>((k + 2) % 3)]};
        return std::array<int, 2>{a[0], a[1]};
      };
      const auto es = opposite(s, t), et = opposite(t, s);
      return segment_crosses(v(es[0]), v(es[1]), v(t[0]), v(t[1]), v(t[2]), eps) ||
             segment_crosses(v(et[0]), v(et[1]), v(s[0]), v(s[1]), v(s[2]), eps);
    }
    case 0:
      for (int k = 0; k < 3; ++k) {
        if (segment_crosses(v(s[static_cast<std::size_t>(k)]), v(s[static_cast<std::size_t>((k + 1) % 3)]), v(t[0]), v(t[1]), v(t[2]), eps) ||
            segment_crosses(v(t[static_cast<std::size_t>(k)]), v(t[static_cast<std::size_t>((k + 1) % 3)]), v(s[0]), v(s[1]), v(s[2]), eps))
          return true;
      }
      return false;
    default:
      return false;  // duplicate triangles are reported as non-manifold edges
  }
}

std::size_t count_intersections(const TriangleSurface& m) {
  const std::size_t nt = m.triangles.size();
  if (nt == 0) return 0;
  std::vector<Eigen::AlignedBox3d> box(nt);
  double edge = 0.0;
  for (std::size_t i = 0; i < nt; ++i) {
    for (int k : m.triangles[i]) box[i].extend(m.vertices[static_cast<std::size_t>(k)]);
    edge += box[i].diagonal().norm();
  }
  const double cell = std::max(2.0 * edge / static_cast<double>(nt), 1e-300);
  Eigen::AlignedBox3d all;
  for (const auto& b : box) all.extend(b);
  const double eps = 1e-12 * std::pow(all.diagonal().norm(), 3);
  const auto index = [&](const Vec& p) { return ((p - all.min()) / cell).array().floor().cast<long>().eval(); };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  const auto key = [](long x, long y, long z) {
    return (static_cast<std::uint64_t>(x) & 0x1FFFFF) << 42 | (static_cast<std::uint64_t>(y) & 0x1FFFFF) << 21 |
           (static_cast<std::uint64_t>(z) & 0x1FFFFF);
  };
  for (std::size_t i = 0; i < nt; ++i) {
    const auto lo = index(box[i].min()), hi = index(box[i].max());
    for (long z = lo[2]; z <= hi[2]; ++z)
      for (long y = lo[1]; y <= hi[1]; ++y)
        for (long x = lo[0]; x <= hi[0]; ++x) grid[key(x, y, z)].push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<std::uint64_t> crossing;
  for (const auto& [cell_key, list] : grid)
    for (std::size_t a = 0; a < list.size(); ++a)
      for (std::size_t b = a + 1; b < list.size(); ++b) {
        const std::uint32_t i = list[a], j = list[b];
        if (box[i].intersects(box[j]) && triangles_cross(m, i, j, eps))
          crossing.push_back(static_cast<std::uint64_t>(std::min(i, j)) << 32 | std::max(i, j));
      }
  std::sort(crossing.begin(), crossing.end());  // a pair found in several cells counts once
  return static_cast<std::size_t>(std::unique(crossing.begin(), crossing.end()) - crossing.begin());
}

}  // namespace

double enclosed_volume(const TriangleSurface& m) {
  double v = 0.0;
  for (const auto& t : m.triangles)
    v += m.vertices[static_cast<std::size_t>(t[0])].dot(
        m.vertices[static_cast<std::size_t>(t[1])].cross(m.vertices[static_cast<std::size_t>(t[2])]));
  return v / 6.0;
}

double surface_area(const TriangleSurface& m) {
  double a = 0.0;
  for (const auto& t : m.triangles) {
    const Vec& p = m.vertices[static_cast<std::size_t>(t[0])];
    a += (m.vertices[static_cast<std::size_t>(t[1])] - p).cross(m.vertices[static_cast<std::size_t>(t[2])] - p).norm();
  }
  return a / 2.0;
}

double total_mean_curvature(const TriangleSurface& m) {
  std::unordered_map<std::uint64_t, std::size_t> first;  // edge -> the first triangle seen with it
  first.reserve(2 * m.triangles.size());
  const auto v = [&](int k) -> const Vec& { return m.vertices[static_cast<std::size_t>(k)]; };
  const auto normal = [&](const std::array<int, 3>& t) { return (v(t[1]) - v(t[0])).cross(v(t[2]) - v(t[0])).normalized().eval(); };
  double sum = 0.0;
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    for (int k = 0; k < 3; ++k) {
      const int a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      const auto [it, fresh] = first.try_emplace(edge_key(a, b), i);
      if (fresh) continue;
      const auto& s = m.triangles[it->second];
      const Vec n1 = normal(s), n2 = normal(t);
      const double angle = std::atan2(n1.cross(n2).norm(), n1.dot(n2));
      // Convex where this triangle's far corner lies behind the other triangle's plane.
      const int far = t[static_cast<std::size_t>((k + 2) % 3)];
      const double sign = n1.dot(v(far) - v(a)) < 0.0 ? 1.0 : -1.0;
      sum += sign * angle * (v(b) - v(a)).norm();
    }
  }
  return 0.5 * sum;
}

TriangleSurface largest_piece(const TriangleSurface& m) {
  // Union-find over vertices joined by the triangles.
  std::vector<int> parent(m.vertices.size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
  const auto root = [&](int v) {
    while (parent[static_cast<std::size_t>(v)] != v) v = parent[static_cast<std::size_t>(v)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(v)])];
    return v;
  };
  for (const auto& t : m.triangles)
    for (int k = 1; k < 3; ++k) parent[static_cast<std::size_t>(root(t[static_cast<std::size_t>(k)]))] = root(t[0]);
  std::unordered_map<int, double> volume;  // per piece root, x6
  for (const auto& t : m.triangles)
    volume[root(t[0])] += m.vertices[static_cast<std::size_t>(t[0])].dot(
        m.vertices[static_cast<std::size_t>(t[1])].cross(m.vertices[static_cast<std::size_t>(t[2])]));
  if (volume.size() <= 1) return m;
  int best = -1;
  for (const auto& [r, v] : volume)
    if (best < 0 || v > volume[best] || (v == volume[best] && r < best)) best = r;
  TriangleSurface out;
  std::vector<int> renumber(m.vertices.size(), -1);  // the piece's vertices in their order
  for (const auto& t : m.triangles)
    if (root(t[0]) == best)
      for (int v : t) renumber[static_cast<std::size_t>(v)] = 0;
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (renumber[v] == 0) renumber[v] = static_cast<int>(out.vertices.size()), out.vertices.push_back(m.vertices[v]);
  for (const auto& t : m.triangles)
    if (root(t[0]) == best)
      out.triangles.push_back({renumber[static_cast<std::size_t>(t[0])], renumber[static_cast<std::size_t>(t[1])], renumber[static_cast<std::size_t>(t[2])]});
  return out;
}

std::string SurfaceCheck::problems() const {
  std::vector<std::string> p;
  if (open_edges) p.push_back(std::to_string(open_edges) + " open edges");
  if (nonmanifold_edges) p.push_back(std::to_string(nonmanifold_edges) + " edges shared by more than two triangles");
  if (misoriented_edges) p.push_back(std::to_string(misoriented_edges) + " edges between inconsistently oriented triangles");
  if (nonmanifold_vertices) p.push_back(std::to_string(nonmanifold_vertices) + " vertices where separate sheets meet");
  if (euler_characteristic != 2) p.push_back("Euler characteristic " + std::to_string(euler_characteristic) + " instead of 2 (not one sphere-like piece)");
  if (intersecting_pairs) p.push_back(std::to_string(intersecting_pairs) + " pairs of triangles that cross each other");
  if (!(volume > 0.0)) p.push_back("a non-positive enclosed volume (triangles facing inwards)");
  std::string s;
  for (std::size_t i = 0; i < p.size(); ++i) s += (i ? ", " : "") + p[i];
  return s;
}

SurfaceCheck check_surface(const TriangleSurface& m) {
  SurfaceCheck c;
  // Per undirected edge: how many triangles use it and the sum of directions (+1 low->high, -1 back).
  struct EdgeUse {
    int count = 0, direction = 0;
  };
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(m.triangles.size() * 2);
  std::vector<std::vector<int>> around(m.vertices.size());  // triangles around each vertex
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const int a = tri[static_cast<std::size_t>(k)], b = tri[static_cast<std::size_t>((k + 1) % 3)];
      EdgeUse& e = edges[edge_key(a, b)];
      ++e.count;
      e.direction += a < b ? 1 : -1;
      around[static_cast<std::size_t>(a)].push_back(static_cast<int>(t));
    }
  }
  for (const auto& [key, e] : edges) {
    if (e.count == 1) ++c.open_edges;
    else if (e.count > 2) ++c.nonmanifold_edges;
    else if (e.direction != 0) ++c.misoriented_edges;
  }
  // A vertex is manifold when walking across shared edges from one of its triangles reaches all.
  std::size_t used = 0;
  for (std::size_t v = 0; v < around.size(); ++v) {
    const auto& list = around[v];
    if (list.empty()) continue;
    ++used;
    std::vector<char> seen(list.size(), 0);
    std::vector<std::size_t> stack{0};
    seen[0] = 1;
    std::size_t reached = 1;
    while (!stack.empty()) {
      const auto& s = m.triangles[static_cast<std::size_t>(list[stack.back()])];
      stack.pop_back();
      for (std::size_t k = 0; k < list.size(); ++k)
        if (!seen[k] && shared_vertices(s, m.triangles[static_cast<std::size_t>(list[k])]) >= 2) {
          seen[k] = 1;
          ++reached;
          stack.push_back(k);
        }
    }
    if (reached != list.size()) ++c.nonmanifold_vertices;
  }
  c.euler_characteristic = static_cast<long>(used) - static_cast<long>(edges.size()) + static_cast<long>(m.triangles.size());
  c.volume = enclosed_volume(m);
  c.intersecting_pairs = count_intersections(m);
  return c;
}

}  // namespace graintwin::mesh
