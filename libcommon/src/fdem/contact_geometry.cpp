#include "graintwin/fdem/contact_geometry.hpp"

namespace graintwin::fdem {

namespace {
TrianglePoint on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, int ia,
                         int ib, TriangleFeature edge) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  TrianglePoint r;
  r.point = a + t * ab;
  r.weights.setZero();
  r.weights[ia] = 1 - t;
  r.weights[ib] = t;
  r.feature = t == 0 ? TriangleFeature(static_cast<int>(TriangleFeature::vertex_a) + ia)
              : t == 1 ? TriangleFeature(static_cast<int>(TriangleFeature::vertex_a) + ib)
                       : edge;
  return r;
}
}  // namespace

TrianglePoint closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                        const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {a, {1, 0, 0}, TriangleFeature::vertex_a};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {b, {0, 1, 0}, TriangleFeature::vertex_b};
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {c, {0, 0, 1}, TriangleFeature::vertex_c};
  // Signed areas (times 2 |n|^2 / |n|) of the sub-triangles opposite each corner; the sign tells
  // on which side of an edge's inward normal plane p projects.
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return on_segment(p, a, b, 0, 1, TriangleFeature::edge_ab);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return on_segment(p, a, c, 0, 2, TriangleFeature::edge_ca);
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return on_segment(p, b, c, 1, 2, TriangleFeature::edge_bc);
  const double sum = va + vb + vc;
  if (!(sum > 0)) {  // degenerate triangle: the best of its three edges
    TrianglePoint best = on_segment(p, a, b, 0, 1, TriangleFeature::edge_ab);
    for (const TrianglePoint& e : {on_segment(p, b, c, 1, 2, TriangleFeature::edge_bc),
                                   on_segment(p, a, c, 0, 2, TriangleFeature::edge_ca)})
      if ((e.point - p).squaredNorm() < (best.point - p).squaredNorm()) best = e;
    return best;
  }
  const double v = vb / sum, w = vc / sum;
  return {a + v * ab + w * ac, {1 - v - w, v, w}, TriangleFeature::face};
}

}  // namespace graintwin::fdem
