#include "graintwin/mesh/tet_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"
#include "graintwin/fdem/primitives.hpp"

namespace graintwin::mesh {
namespace {

using Vec = Eigen::Vector3d;

using fdem::kTet10Edges;

std::array<Vec, 10> element_nodes(const TetMesh& m, std::size_t e) {
  std::array<Vec, 10> x;
  const std::uint32_t* n = m.element(e);
  for (int k = 0; k < 4; ++k) x[static_cast<std::size_t>(k)] = m.nodes[n[k]];
  for (int k = 0; k < 6; ++k)
    x[static_cast<std::size_t>(4 + k)] = m.nodes_per_element == 10
                                             ? m.nodes[n[4 + k]]
                                             : 0.5 * (m.nodes[n[kTet10Edges[k][0]]] + m.nodes[n[kTet10Edges[k][1]]]);
  return x;
}

/// Natural coordinates (xi, eta, zeta) of the nodes and of the 4-point Gauss rule.
const std::array<Vec, 14>& jacobian_samples() {
  static const std::array<Vec, 14> s = [] {
    const double a = 0.5854101966249685, b = 0.1381966011250105;
    std::array<Vec, 14> p{Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0, 0, 1)};
    for (int k = 0; k < 6; ++k) {
      const auto corner = [&](int c) { return p[static_cast<std::size_t>(c)]; };
      p[static_cast<std::size_t>(4 + k)] = 0.5 * (corner(kTet10Edges[k][0]) + corner(kTet10Edges[k][1]));
    }
    p[10] = Vec(b, b, b), p[11] = Vec(a, b, b), p[12] = Vec(b, a, b), p[13] = Vec(b, b, a);
    return p;
  }();
  return s;
}

}  // namespace

double tet_gamma(const Vec& a, const Vec& b, const Vec& c, const Vec& d) {
  const Vec u = b - a, v = c - a, w = d - a;
  const double six_v = u.dot(v.cross(w));
  const double faces = (v - u).cross(w - u).norm() + u.cross(v).norm() + u.cross(w).norm() + v.cross(w).norm();  // 2 x area sum
  if (faces <= 0.0) return 0.0;
  const double inradius = six_v / faces;  // 3 V / A with V = six_v / 6 and A = faces / 2
  const Vec num = u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v);
  if (six_v == 0.0) return 0.0;
  const double circumradius = num.norm() / (2.0 * std::abs(six_v));
  return 3.0 * inradius / circumradius;
}

double tet_min_altitude(const Vec& a, const Vec& b, const Vec& c, const Vec& d) {
  const double six_v = (b - a).cross(c - a).dot(d - a);
  const double twice_area = std::max({(b - a).cross(c - a).norm(), (b - a).cross(d - a).norm(), (c - a).cross(d - a).norm(),
                                      (c - b).cross(d - b).norm()});
  return twice_area > 0.0 ? six_v / twice_area : 0.0;  // 3 V / A with V = six_v / 6 and A = twice_area / 2
}

double tet_min_dihedral_degrees(const Vec& a, const Vec& b, const Vec& c, const Vec& d) {
  // Outward (area) normals of the faces opposite each corner; the interior angle at the edge two
  // faces share is pi minus the angle between their outward normals.
  const std::array<Vec, 4> p{a, b, c, d};
  std::array<Vec, 4> n;
  for (std::size_t i = 0; i < 4; ++i) {
    const Vec& u = p[(i + 1) % 4];
    n[i] = (p[(i + 2) % 4] - u).cross(p[(i + 3) % 4] - u);
    if (n[i].dot(p[i] - u) > 0.0) n[i] = -n[i];
    if (!(n[i].squaredNorm() > 0.0)) return 0.0;
  }
  double largest_cos = -1.0;
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = i + 1; j < 4; ++j) largest_cos = std::max(largest_cos, -n[i].dot(n[j]) / (n[i].norm() * n[j].norm()));
  return std::acos(std::clamp(largest_cos, -1.0, 1.0)) * 180.0 / M_PI;
}

bool meets(const SliverThresholds& t, double min_dihedral_degrees, double min_altitude, double median_altitude) {
  return min_dihedral_degrees >= t.min_dihedral_degrees && min_altitude >= t.min_altitude_ratio * median_altitude;
}

double tet10_det_jacobian(const std::array<Vec, 10>& x, double xi, double eta, double zeta) {
  const double l[4] = {1.0 - xi - eta - zeta, xi, eta, zeta};
  Eigen::Matrix3d j = Eigen::Matrix3d::Zero();
  // dN/dL_k for every node, then d/dxi_q = dN/dL_{q+1} - dN/dL_0.
  for (int node = 0; node < 10; ++node) {
    double g[4] = {0, 0, 0, 0};
    if (node < 4) {
      g[node] = 4.0 * l[node] - 1.0;
    } else {
      const int p = kTet10Edges[node - 4][0], q = kTet10Edges[node - 4][1];
      g[p] = 4.0 * l[q];
      g[q] = 4.0 * l[p];
    }
    for (int c = 0; c < 3; ++c) j.col(c) += x[static_cast<std::size_t>(node)] * (g[c + 1] - g[0]);
  }
  return j.determinant();
}

double jacobian_ratio(const TetMesh& m, std::size_t e) {
  const auto x = element_nodes(m, e);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec& s : jacobian_samples()) {
    const double d = tet10_det_jacobian(x, s.x(), s.y(), s.z());
    lo = std::min(lo, d), hi = std::max(hi, d);
  }
  return hi > 0.0 ? lo / hi : -1.0;
}

double mesh_volume(const TetMesh& m) {
  // Keast's 5-point rule is exact for det J of a 10-node element (a cubic).
  const double sixth = 1.0 / 6.0;
  const std::array<std::pair<Vec, double>, 5> rule{{{Vec(0.25, 0.25, 0.25), -0.8},
                                                     {Vec(sixth, sixth, sixth), 0.45},
                                                     {Vec(0.5, sixth, sixth), 0.45},
                                                     {Vec(sixth, 0.5, sixth), 0.45},
                                                     {Vec(sixth, sixth, 0.5), 0.45}}};
  double v = 0.0;
  for (std::size_t e = 0; e < m.element_count(); ++e) {
    const auto x = element_nodes(m, e);
    for (const auto& [p, w] : rule) v += w * tet10_det_jacobian(x, p.x(), p.y(), p.z()) / 6.0;
  }
  return v;
}

std::vector<std::array<std::uint32_t, 3>> boundary_triangles(const TetMesh& m) {
  return fdem::boundary_triangles(m.nodes_per_element, m.elements);
}

TriangleSurface boundary_surface(const TetMesh& m) {
  TriangleSurface s;
  std::vector<int> index(m.nodes.size(), -1);
  for (const auto& t : boundary_triangles(m)) {
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) {
      int& i = index[t[static_cast<std::size_t>(k)]];
      if (i < 0) {
        i = static_cast<int>(s.vertices.size());
        s.vertices.push_back(m.nodes[t[static_cast<std::size_t>(k)]]);
      }
      tri[static_cast<std::size_t>(k)] = i;
    }
    s.triangles.push_back(tri);
  }
  return s;
}

double median_altitude(const TetMesh& m) {
  std::vector<double> h(m.element_count());
  for (std::size_t e = 0; e < h.size(); ++e) {
    const std::uint32_t* n = m.element(e);
    h[e] = tet_min_altitude(m.nodes[n[0]], m.nodes[n[1]], m.nodes[n[2]], m.nodes[n[3]]);
  }
  if (h.empty()) return 0.0;
  std::nth_element(h.begin(), h.begin() + static_cast<std::ptrdiff_t>(h.size() / 2), h.end());
  return h[h.size() / 2];
}

std::size_t straighten_distorted(TetMesh& m, double min_ratio, double fraction, int passes) {
  std::size_t moved = 0;
  for (int pass = 0; pass < passes; ++pass) {
    bool any = false;
    for (std::size_t e = 0; e < m.element_count(); ++e) {
      if (jacobian_ratio(m, e) >= min_ratio) continue;
      any = true;
      const std::uint32_t* n = m.element(e);
      for (int k = 0; k < 6; ++k) {
        const Vec mid = 0.5 * (m.nodes[n[kTet10Edges[k][0]]] + m.nodes[n[kTet10Edges[k][1]]]);
        Vec& p = m.nodes[n[4 + k]];
        if (p != mid) p += fraction * (mid - p), ++moved;
      }
    }
    if (!any) break;
  }
  return moved;
}

std::size_t pull_back_curved(TetMesh& m) {
  return straighten_distorted(m, kMinCurvedJacobianRatio, 0.5, 4) + straighten_distorted(m, kMinCurvedJacobianRatio, 1.0, 2);
}

MeshQuality mesh_quality(const TetMesh& m, double gamma_floor, const SliverThresholds& slivers) {
  MeshQuality q;
  q.elements = m.element_count();
  q.nodes = m.nodes.size();
  q.min_gamma = q.min_jacobian_ratio = q.min_dihedral = q.min_altitude = std::numeric_limits<double>::infinity();
  q.median_altitude = median_altitude(m);
  double sum = 0.0;
  for (std::size_t e = 0; e < q.elements; ++e) {
    const std::uint32_t* n = m.element(e);
    const Vec &a = m.nodes[n[0]], &b = m.nodes[n[1]], &c = m.nodes[n[2]], &d = m.nodes[n[3]];
    const double g = tet_gamma(a, b, c, d);
    const double dihedral = tet_min_dihedral_degrees(a, b, c, d), altitude = tet_min_altitude(a, b, c, d);
    q.min_dihedral = std::min(q.min_dihedral, dihedral);
    if (altitude < q.min_altitude) q.min_altitude = altitude, q.worst_element = e;
    q.below_thresholds += !meets(slivers, dihedral, altitude, q.median_altitude);
    const double r = jacobian_ratio(m, e);
    q.min_gamma = std::min(q.min_gamma, g);
    q.min_jacobian_ratio = std::min(q.min_jacobian_ratio, r);
    q.inverted += r <= 0.0;
    q.below_floor += g < gamma_floor;
    sum += g;
  }
  q.mean_gamma = q.elements ? sum / static_cast<double>(q.elements) : 0.0;
  if (q.elements == 0) q.min_gamma = q.min_jacobian_ratio = q.min_dihedral = q.min_altitude = 0.0;
  const TriangleSurface b = boundary_surface(m);
  q.surface_nodes = b.vertices.size();
  q.surface_area = surface_area(b);
  q.volume = mesh_volume(m);
  return q;
}

void append_grain(fdem::Model& model, const TetMesh& mesh, std::uint32_t label, fdem::GrainKind kind, std::uint32_t material) {
  const int want = kind == fdem::GrainKind::tet10 ? 10 : kind == fdem::GrainKind::tet4 ? 4 : mesh.nodes_per_element;
  if (mesh.nodes_per_element != want || mesh.element_count() == 0)
    throw UsageError(fmt::format("append_grain: grain {} has {} elements of {} nodes, which do not fit its kind", label,
                                 mesh.element_count(), mesh.nodes_per_element));
  fdem::append_grain_elements(model, mesh.nodes, mesh.nodes_per_element, mesh.elements, kind, material, label);
}

fdem::SampleCylinder enclosing_cylinder(const fdem::Model& model, double membrane_thickness) {
  if (model.nodes.empty()) throw DataError("enclosing_cylinder: the model has no nodes");
  fdem::SampleCylinder c;
  c.membrane_thickness = membrane_thickness;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  c.z_min = std::numeric_limits<double>::infinity(), c.z_max = -c.z_min;
  for (const Vec& p : model.nodes) {
    sum += p.head<2>();
    c.z_min = std::min(c.z_min, p.z()), c.z_max = std::max(c.z_max, p.z());
  }
  c.axis_xy = sum / static_cast<double>(model.nodes.size());
  for (const Vec& p : model.nodes) c.radius = std::max(c.radius, (p.head<2>() - c.axis_xy).norm());
  return c;
}

fdem::SampleCylinder inscribed_cylinder(const Volume<std::uint32_t>& labels, double membrane_thickness) {
  if (labels.empty()) throw DataError("inscribed_cylinder: the labels volume is empty");
  const Vec3 first = labels.position_xyz(0, 0, 0);
  const Vec3 last = labels.position_xyz(double(labels.nz() - 1), double(labels.ny() - 1), double(labels.nx() - 1));
  const Vec3& h = labels.voxel_size();  // (dz, dy, dx)
  const double x0 = std::min(first[0], last[0]) - 0.5 * h[2], x1 = std::max(first[0], last[0]) + 0.5 * h[2];
  const double y0 = std::min(first[1], last[1]) - 0.5 * h[1], y1 = std::max(first[1], last[1]) + 0.5 * h[1];
  fdem::SampleCylinder c;
  c.membrane_thickness = membrane_thickness;
  c.axis_xy = {0.5 * (x0 + x1), 0.5 * (y0 + y1)};
  c.radius = 0.5 * std::min(x1 - x0, y1 - y0);
  c.z_min = std::min(first[2], last[2]) - 0.5 * h[0];
  c.z_max = std::max(first[2], last[2]) + 0.5 * h[0];
  return c;
}

std::unordered_set<std::uint32_t> labels_within(const Volume<std::uint32_t>& labels, const Eigen::Vector2d& axis_xy, double radius,
                                                double margin) {
  // A voxel's farthest corner from the axis is at most half its x-y diagonal beyond its centre.
  const Vec3& h = labels.voxel_size();
  const double reach = radius - margin - 0.5 * std::hypot(h[1], h[2]);
  std::unordered_set<std::uint32_t> outside;
  for (std::size_t z = 0; z < labels.nz(); ++z)
    for (std::size_t y = 0; y < labels.ny(); ++y)
      for (std::size_t x = 0; x < labels.nx(); ++x) {
        const std::uint32_t l = labels(z, y, x);
        if (l == 0 || outside.count(l)) continue;
        const Vec3 p = labels.position_xyz(double(z), double(y), double(x));
        if (std::hypot(p[0] - axis_xy.x(), p[1] - axis_xy.y()) > reach) outside.insert(l);
      }
  std::unordered_set<std::uint32_t> inside;
  for (const std::uint32_t l : labels.values())
    if (l != 0 && !outside.count(l)) inside.insert(l);
  return inside;
}

std::vector<fdem::Platen> end_platens(const fdem::SampleCylinder& s, double friction) {
  const Vec centre(s.axis_xy.x(), s.axis_xy.y(), 0.0);
  return {fdem::Platen{fdem::kBottomPlaten, centre + Vec(0, 0, s.z_min), Vec::UnitZ(), friction},
          fdem::Platen{fdem::kTopPlaten, centre + Vec(0, 0, s.z_max), -Vec::UnitZ(), friction}};
}

}  // namespace graintwin::mesh
