#pragma once
// Geometry of FDEM contact detection: axis-aligned boxes and the closest point of a triangle.
// Positions in m, (x, y, z).
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <limits>

namespace graintwin::fdem {

/// An axis-aligned box; empty (lo > hi) by default so `grow` can build it up.
struct Aabb {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  void grow(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  Aabb inflated(double margin) const { return {lo.array() - margin, hi.array() + margin}; }
  bool overlaps(const Aabb& b) const { return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all(); }
  bool contains(const Eigen::Vector3d& p) const { return (lo.array() <= p.array()).all() && (p.array() <= hi.array()).all(); }
  /// Squared distance from p to the box (0 inside).
  double squared_distance(const Eigen::Vector3d& p) const {
    return ((lo - p).cwiseMax(p - hi)).cwiseMax(0.0).squaredNorm();
  }
};

/// Which part of a triangle (a, b, c) holds the closest point: its interior, an edge (ab, bc, ca)
/// or a corner.
enum class TriangleFeature : std::uint8_t { face, edge_ab, edge_bc, edge_ca, vertex_a, vertex_b, vertex_c };

struct TrianglePoint {
  Eigen::Vector3d point;     ///< closest point, m
  Eigen::Vector3d weights;   ///< barycentric weights of a, b, c (sum 1, all >= 0)
  TriangleFeature feature = TriangleFeature::face;
};

/// Closest point of the triangle (a, b, c) to p, by the Voronoi regions of its corners and edges.
/// A degenerate triangle (zero area) still yields its closest edge or corner point.
TrianglePoint closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                        const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace graintwin::fdem
