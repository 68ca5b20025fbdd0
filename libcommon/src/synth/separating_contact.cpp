// The contact of two grains re-measured as their local separating direction (packing.hpp,
// separating_contact): exact for faces, edges and corners, where the packer's radial-depth kernel
// is not.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "graintwin/core/geometry.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::synth {

namespace {

// Surface points (world) of a grain's table within `reach` of the world point p: its face nodes,
// where the table holds the exact radius (a vertex or edge of an angular grain is sharpest
// there; between nodes the table is bilinear).
std::vector<Eigen::Vector3d> surface_patch(const shape::RadialTable& t, const PackedGrain& g, const Eigen::Vector3d& p,
                                           double reach) {
  const Eigen::Matrix3d rot = g.orientation.toRotationMatrix();
  const Eigen::Vector3d q = rot.transpose() * (p - g.position);
  const int n = t.nodes_per_edge();
  const double step = 2.0 / (n - 1);
  std::vector<Eigen::Vector3d> out;
  for (int face = 0; face < 6; ++face) {
    const shape::RadialTable::FaceAxes ax = shape::RadialTable::face_axes(face);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d d = Eigen::Vector3d::Zero();
        d[ax.a] = -1.0 + i * step;
        d[ax.b] = -1.0 + j * step;
        d[ax.k] = ax.sign;
        d.normalize();
        // Cheap screen: a node whose direction is far from q's cannot be within reach.
        if (d.dot(q) < q.norm() - reach - t.max_radius()) continue;
        const Eigen::Vector3d x = t.radius(d) * d;
        if ((x - q).norm() <= reach) out.push_back(g.position + rot * x);
      }
    }
  }
  return out;
}

// Pattern search on the sphere for the minimum of g from `start`, within the hemisphere n.c > 0:
// 8 directions in the tangent plane, the step halved when none improves (g is piecewise linear
// for polyhedra, so diagonals help along its ridges).
template <class G>
Eigen::Vector3d minimise_on_sphere(const G& g, Eigen::Vector3d n, const Eigen::Vector3d& c, double& best) {
  best = g(n);
  for (double step = 0.2; step > 1e-5;) {
    const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    bool moved = false;
    for (int k = 0; k < 8 && !moved; ++k) {
      const double phi = k * std::numbers::pi / 4.0;
      const Eigen::Vector3d trial = (n + step * (std::cos(phi) * t1 + std::sin(phi) * t2)).normalized();
      if (trial.dot(c) <= 0.0) continue;
      const double v = g(trial);
      if (v < best) {
        best = v;
        n = trial;
        moved = true;
      }
    }
    if (!moved) step *= 0.5;
  }
  return n;
}

}  // namespace

PairContact separating_contact(const shape::RadialTable& a, const PackedGrain& ga, const shape::RadialTable& b,
                               const PackedGrain& gb, const PairContact& first, double reach) {
  if (!(reach > 0.0)) {
    const auto radius = [](const shape::RadialTable& t) { return equivalent_radius(t.volume()); };
    reach = 0.25 * std::min(radius(a), radius(b));
  }
  const std::vector<Eigen::Vector3d> pa = surface_patch(a, ga, first.point, reach);
  const std::vector<Eigen::Vector3d> pb = surface_patch(b, gb, first.point, reach);
  const Eigen::Vector3d centre_line = gb.position - ga.position;
  if (pa.empty() || pb.empty() || !(first.normal.norm() > 0.0) || !(centre_line.norm() > 0.0)) return first;
  auto g = [&](const Eigen::Vector3d& n) {
    double ha = -HUGE_VAL, lb = HUGE_VAL;
    for (const auto& x : pa) ha = std::max(ha, n.dot(x));
    for (const auto& y : pb) lb = std::min(lb, n.dot(y));
    return ha - lb;
  };
  // Two starts: the kernel's normal and the centre line; the smaller minimum wins.
  const Eigen::Vector3d c = centre_line.normalized();
  PairContact out = first;
  out.overlap = HUGE_VAL;
  for (const Eigen::Vector3d& start : {Eigen::Vector3d(first.normal.normalized()), c}) {
    if (start.dot(c) <= 0.0) continue;
    double value = 0.0;
    const Eigen::Vector3d n = minimise_on_sphere(g, start, c, value);
    if (value < out.overlap) {
      out.overlap = value;
      out.normal = n;
    }
  }
  return out.overlap < HUGE_VAL ? out : first;
}

}  // namespace graintwin::synth
