// Cube-map tabulation of a star-shaped body r(direction): lookup, normals and the integrals
// (volume, centroid, area, inertia) of the bilinear body.
#include "graintwin/shape/radial_table.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::shape {

namespace {

// Per face: major axis k, its sign, and the axes (a, b) carrying u and v, chosen so that
// (e_a, e_b, sign * e_k) is right-handed; the outward-normal formula relies on that handedness.
struct Face {
  int k;
  double sign;
  int a;
  int b;
};
constexpr Face kFaces[6] = {{0, +1.0, 1, 2}, {0, -1.0, 2, 1}, {1, +1.0, 2, 0},
                            {1, -1.0, 0, 2}, {2, +1.0, 0, 1}, {2, -1.0, 1, 0}};

// Unit direction of face coordinates (u, v) on `face`; valid beyond [-1, 1] for the ghost ring.
Eigen::Vector3d face_direction(int face, double u, double v) {
  const Face& f = kFaces[face];
  Eigen::Vector3d d;
  d[f.k] = f.sign;
  d[f.a] = u;
  d[f.b] = v;
  return d.normalized();
}

void require_nodes(int n) {
  if (n < 2) {
    throw UsageError("a RadialTable needs at least 2 nodes per cube-face edge (got " +
                     std::to_string(n) + "); pass n >= 2, typically 32-128");
  }
}

}  // namespace

void RadialTable::locate(const Eigen::Vector3d& d, int& face, double& u, double& v) const {
  const double ax = std::abs(d.x());
  const double ay = std::abs(d.y());
  const double az = std::abs(d.z());
  int k;
  if (ax >= ay && ax >= az) {
    k = 0;
  } else if (ay >= az) {
    k = 1;
  } else {
    k = 2;
  }
  face = 2 * k + (d[k] < 0.0 ? 1 : 0);
  const Face& f = kFaces[face];
  // |d[a]| <= |d[k]|, so the quotient is within [-1, 1] exactly in floating point.
  const double inv = 1.0 / std::abs(d[k]);
  u = d[f.a] * inv;
  v = d[f.b] * inv;
}

std::vector<Eigen::Vector3d> RadialTable::node_directions(int n) {
  require_nodes(n);
  const int stride = n + 2;
  const double h = 2.0 / (n - 1);
  std::vector<Eigen::Vector3d> dirs;
  dirs.reserve(static_cast<std::size_t>(6) * stride * stride);
  for (int face = 0; face < 6; ++face) {
    for (int j = 0; j < stride; ++j) {
      for (int i = 0; i < stride; ++i) {
        dirs.push_back(face_direction(face, -1.0 + (i - 1) * h, -1.0 + (j - 1) * h));
      }
    }
  }
  return dirs;
}

RadialTable RadialTable::from_function(
    const std::function<double(const Eigen::Vector3d&)>& radius, int n) {
  const std::vector<Eigen::Vector3d> dirs = node_directions(n);
  std::vector<double> radii(dirs.size());
  for (std::size_t q = 0; q < dirs.size(); ++q) radii[q] = radius(dirs[q]);
  return from_node_radii(n, std::move(radii));
}

RadialTable RadialTable::from_node_radii(int n, std::vector<double> radii) {
  require_nodes(n);
  RadialTable t;
  t.n_ = n;
  t.stride_ = n + 2;
  t.inv_h_ = 0.5 * (n - 1);
  if (radii.size() != static_cast<std::size_t>(6) * t.stride_ * t.stride_) {
    throw UsageError("RadialTable::from_node_radii got " + std::to_string(radii.size()) +
                     " radii for n = " + std::to_string(n) +
                     "; pass one radius per entry of node_directions(n)");
  }
  for (double r : radii) {
    if (!std::isfinite(r) || r <= 0.0) {
      throw DataError("a RadialTable radius is " + std::to_string(r) +
                      "; the body must be star-shaped about its origin with finite r > 0 in "
                      "every direction (re-centre it or choose another shape)");
    }
  }
  t.r_ = std::move(radii);
  t.min_radius_ = t.r_[t.index(0, 1, 1)];
  t.max_radius_ = t.min_radius_;
  for (int face = 0; face < 6; ++face) {
    for (int j = 1; j <= n; ++j) {
      for (int i = 1; i <= n; ++i) {
        const double r = t.r_[t.index(face, i, j)];
        t.min_radius_ = std::min(t.min_radius_, r);
        t.max_radius_ = std::max(t.max_radius_, r);
      }
    }
  }
  t.integrate();
  return t;
}

RadialTable::Cell RadialTable::cell_of(const Eigen::Vector3d& d) const {
  Cell c;
  locate(d, c.face, c.u, c.v);
  const double su = (c.u + 1.0) * inv_h_;
  const double sv = (c.v + 1.0) * inv_h_;
  c.i = std::min(static_cast<int>(su), n_ - 2);
  c.j = std::min(static_cast<int>(sv), n_ - 2);
  c.t = su - c.i;
  c.w = sv - c.j;
  return c;
}

double RadialTable::radius(const Eigen::Vector3d& unit_dir) const {
  const Cell c = cell_of(unit_dir);
  const double t = c.t, w = c.w;
  const double* p = r_.data() + index(c.face, c.i + 1, c.j + 1);
  const double* q = p + stride_;
  return (1.0 - w) * ((1.0 - t) * p[0] + t * p[1]) + w * ((1.0 - t) * q[0] + t * q[1]);
}

Eigen::Vector3d RadialTable::surface_normal(const Eigen::Vector3d& unit_dir) const {
  const Cell c = cell_of(unit_dir);
  const int face = c.face, i = c.i, j = c.j;
  const double u = c.u, v = c.v, t = c.t, w = c.w;
  // r and its face-coordinate derivatives at the four cell corners (padded indices i+1..i+2),
  // derivatives by central differences over neighbours that may lie in the ghost ring.
  double r[2][2], ru[2][2], rv[2][2];
  const double half_inv_h = 0.5 * inv_h_;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const std::size_t c = index(face, i + 1 + di, j + 1 + dj);
      r[dj][di] = r_[c];
      ru[dj][di] = (r_[c + 1] - r_[c - 1]) * half_inv_h;
      rv[dj][di] = (r_[c + stride_] - r_[c - stride_]) * half_inv_h;
    }
  }
  auto lerp2 = [t, w](const double a[2][2]) {
    return (1.0 - w) * ((1.0 - t) * a[0][0] + t * a[0][1]) +
           w * ((1.0 - t) * a[1][0] + t * a[1][1]);
  };
  const double rr = lerp2(r);
  const double rho2 = 1.0 + u * u + v * v;
  // Surface p(u, v) = f q with q = (u, v, 1) in the face frame and f = r / |q|; p_u x p_v is
  // proportional to (-g_u, -g_v, 1 + u g_u + v g_v) with g = f_u / f = r_u / r - u / |q|^2.
  const double gu = lerp2(ru) / rr - u / rho2;
  const double gv = lerp2(rv) / rr - v / rho2;
  const Face& f = kFaces[face];
  Eigen::Vector3d normal;
  normal[f.a] = -gu;
  normal[f.b] = -gv;
  normal[f.k] = f.sign * (1.0 + u * gu + v * gv);
  return normal.normalized();
}

void RadialTable::integrate() {
  // Each cell is integrated with 2 x 2 Gauss points: the integrands are smooth inside a cell
  // (the kinks of the bilinear body are on cell edges), so this is accurate to O(h^4) per cell
  // and a constant-radius table reproduces the sphere's volume and area to ~1e-9.
  const double g = 0.5 / std::sqrt(3.0);
  const double gauss[2] = {0.5 - g, 0.5 + g};
  const double h = 2.0 / (n_ - 1);
  const double cell_weight = 0.25 * h * h;
  double vol = 0.0;
  double area = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (int face = 0; face < 6; ++face) {
    const Face& f = kFaces[face];
    for (int j = 0; j < n_ - 1; ++j) {
      for (int i = 0; i < n_ - 1; ++i) {
        const double r00 = r_[index(face, i + 1, j + 1)];
        const double r10 = r_[index(face, i + 2, j + 1)];
        const double r01 = r_[index(face, i + 1, j + 2)];
        const double r11 = r_[index(face, i + 2, j + 2)];
        for (double w : gauss) {
          for (double t : gauss) {
            const double u = -1.0 + (i + t) * h;
            const double v = -1.0 + (j + w) * h;
            const double r =
                (1.0 - w) * ((1.0 - t) * r00 + t * r10) + w * ((1.0 - t) * r01 + t * r11);
            const double r_u = ((1.0 - w) * (r10 - r00) + w * (r11 - r01)) / h;
            const double r_v = ((1.0 - t) * (r01 - r00) + t * (r11 - r10)) / h;
            const double rho2 = 1.0 + u * u + v * v;
            const double rho = std::sqrt(rho2);
            const double d_omega = cell_weight / (rho2 * rho);  // solid angle du dv / |q|^3
            Eigen::Vector3d d;
            d[f.k] = f.sign / rho;
            d[f.a] = u / rho;
            d[f.b] = v / rho;
            const double r2 = r * r;
            const double r3 = r2 * r;
            vol += r3 / 3.0 * d_omega;
            first += (r3 * r / 4.0 * d_omega) * d;
            second += (r3 * r2 / 5.0 * d_omega) * (d * d.transpose());
            // |p_u x p_v| du dv with p = (r / |q|) q, see surface_normal().
            const double gu = r_u / r - u / rho2;
            const double gv = r_v / r - v / rho2;
            const double e = 1.0 + u * gu + v * gv;
            area += r2 / rho2 * std::sqrt(gu * gu + gv * gv + e * e) * cell_weight;
          }
        }
      }
    }
  }
  volume_ = vol;
  surface_area_ = area;
  centroid_ = first / vol;
  // Inertia about the origin from the second moment M = integral of x x^T dV, then moved to the
  // centroid with the parallel-axis theorem.
  const Eigen::Matrix3d eye = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d j_origin = second.trace() * eye - second;
  inertia_ = j_origin - vol * (centroid_.squaredNorm() * eye - centroid_ * centroid_.transpose());
}

RadialTable RadialTable::scaled(double s) const {
  if (!std::isfinite(s) || s <= 0.0) {
    throw UsageError("RadialTable::scaled needs a finite scale factor > 0 (got " +
                     std::to_string(s) + ")");
  }
  RadialTable t = *this;
  for (double& r : t.r_) r *= s;
  t.min_radius_ *= s;
  t.max_radius_ *= s;
  const double s2 = s * s;
  t.volume_ *= s2 * s;
  t.centroid_ *= s;
  t.surface_area_ *= s2;
  t.inertia_ *= s2 * s2 * s;
  return t;
}

}  // namespace graintwin::shape
