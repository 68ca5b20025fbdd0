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
using Face = RadialTable::FaceAxes;
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

RadialTable::FaceAxes RadialTable::face_axes(int face) {
  if (face < 0 || face > 5) {
    throw UsageError("a cube map has faces 0..5 (got " + std::to_string(face) + ")");
  }
  return kFaces[face];
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
  t.r_.assign(radii.begin(), radii.end());
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
  const float* p = r_.data() + index(c.face, c.i + 1, c.j + 1);
  const float* q = p + stride_;
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
  // The geometry of a Gauss point (direction in face axes, solid angle) is the same on all six
  // faces, so it is computed once per row and the faces only add their radii; sums are kept per
  // cell column (so the loops over a row vectorise) and added up at the end in a fixed order.
  const double g = 0.5 / std::sqrt(3.0);
  const double gauss[2] = {0.5 - g, 0.5 + g};
  const double h = 2.0 / (n_ - 1);
  const double cell_weight = 0.25 * h * h;
  const int cells = n_ - 1;
  // Per face and cell column: volume, area, first moment (a, b, k face axes) and second moment
  // (aa, bb, kk, ab, ak, bk).
  constexpr int kSums = 11;
  std::vector<double> sums(static_cast<std::size_t>(6 * kSums * cells), 0.0);
  // Per Gauss point of the row's cells: u, weights for the volume, first and second moments, and
  // the area terms.
  constexpr int kGeo = 14;
  std::vector<double> geo(static_cast<std::size_t>(4 * kGeo * cells));
  std::vector<double> area_weight(static_cast<std::size_t>(4 * cells)), area_root(static_cast<std::size_t>(4 * cells));
  std::vector<double> inv_rho(static_cast<std::size_t>(cells));
  double worst_slope = 0.0;  // largest |q|^2 |N|^2 / cell_weight over the Gauss points
  for (int j = 0; j < cells; ++j) {
    for (int gp = 0; gp < 4; ++gp) {
      const double t = gauss[gp % 2], w = gauss[gp / 2];
      const double v = -1.0 + (j + w) * h;
      double* G = &geo[static_cast<std::size_t>(gp * kGeo * cells)];
      for (int i = 0; i < cells; ++i) {
        const double u = -1.0 + (i + t) * h;
        inv_rho[i] = 1.0 + u * u + v * v;
      }
      // 1 / |q| (Eigen's sqrt vectorises; std::sqrt keeps a scalar errno path).
      Eigen::Map<Eigen::ArrayXd>(inv_rho.data(), cells) = Eigen::Map<Eigen::ArrayXd>(inv_rho.data(), cells).rsqrt();
      for (int i = 0; i < cells; ++i) {
        const double u = -1.0 + (i + t) * h;
        const double ir = inv_rho[i], ir2 = ir * ir;
        const double d_omega = cell_weight * ir2 * ir;  // solid angle du dv / |q|^3
        const double da = u * ir, db = v * ir, dk = ir;
        G[0 * cells + i] = u;
        G[1 * cells + i] = d_omega / 3.0;
        G[2 * cells + i] = d_omega / 4.0 * da;
        G[3 * cells + i] = d_omega / 4.0 * db;
        G[4 * cells + i] = d_omega / 4.0 * dk;
        G[5 * cells + i] = d_omega / 5.0 * da * da;
        G[6 * cells + i] = d_omega / 5.0 * db * db;
        G[7 * cells + i] = d_omega / 5.0 * dk * dk;
        G[8 * cells + i] = d_omega / 5.0 * da * db;
        G[9 * cells + i] = d_omega / 5.0 * da * dk;
        G[10 * cells + i] = d_omega / 5.0 * db * dk;
        G[11 * cells + i] = u * ir2;
        G[12 * cells + i] = v * ir2;
        G[13 * cells + i] = cell_weight * ir2;
      }
    }
    for (int face = 0; face < 6; ++face) {
      const float* lo = &r_[index(face, 1, j + 1)];  // r at nodes (i, j) and (i + 1, j): lo[i], lo[i + 1]
      const float* hi = &r_[index(face, 1, j + 2)];
      double* S = &sums[static_cast<std::size_t>(face * kSums * cells)];
#pragma omp simd
      for (int i = 0; i < cells; ++i) {
        const double r00 = lo[i], r10 = lo[i + 1], r01 = hi[i], r11 = hi[i + 1];
        double add[kSums] = {};
#pragma GCC unroll 4
        for (int gp = 0; gp < 4; ++gp) {
          const double t = gauss[gp % 2], w = gauss[gp / 2];
          const double v = -1.0 + (j + w) * h;
          const double* G = &geo[static_cast<std::size_t>(gp * kGeo * cells)];
          const double r = (1.0 - w) * ((1.0 - t) * r00 + t * r10) + w * ((1.0 - t) * r01 + t * r11);
          const double r_u = ((1.0 - w) * (r10 - r00) + w * (r11 - r01)) * inv_h_;
          const double r_v = ((1.0 - t) * (r01 - r00) + t * (r11 - r10)) * inv_h_;
          const double r2 = r * r, r3 = r2 * r, r4 = r3 * r, r5 = r3 * r2;
          const double inv_r = 1.0 / r;  // the loop's only division
          add[0] += r3 * G[1 * cells + i];
#pragma GCC unroll 3
          for (int q = 2; q < 5; ++q) add[q] += r4 * G[q * cells + i];
#pragma GCC unroll 6
          for (int q = 5; q < 11; ++q) add[q] += r5 * G[q * cells + i];
          // |p_u x p_v| du dv with p = (r / |q|) q, see surface_normal(); the root is taken below.
          const double gu = r_u * inv_r - G[11 * cells + i];
          const double gv = r_v * inv_r - G[12 * cells + i];
          const double e = 1.0 + G[0 * cells + i] * gu + v * gv;
          area_weight[gp * cells + i] = r2 * G[13 * cells + i];
          area_root[gp * cells + i] = gu * gu + gv * gv + e * e;
        }
#pragma GCC unroll 11
        for (int q = 0; q < kSums; ++q) S[q * cells + i] += add[q];
      }
      Eigen::Map<Eigen::ArrayXd> area(S + cells, cells);
      for (int gp = 0; gp < 4; ++gp) {
        const Eigen::Map<const Eigen::ArrayXd> root(&area_root[gp * cells], cells);
        area += Eigen::Map<const Eigen::ArrayXd>(&area_weight[gp * cells], cells) * root.sqrt();
        // cos(normal, radial) = 1 / (|q| |N|) with |N|^2 = root (surface_normal()), and
        // |q|^2 = cell_weight / G[13].
        const Eigen::Map<const Eigen::ArrayXd> w13(&geo[static_cast<std::size_t>((gp * kGeo + 13) * cells)], cells);
        worst_slope = std::max(worst_slope, (root / w13).maxCoeff());
      }
    }
  }
  double vol = 0.0;
  double area = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (int face = 0; face < 6; ++face) {
    const Face& f = kFaces[face];
    double total[kSums] = {};
    const double* S = &sums[static_cast<std::size_t>(face * kSums * cells)];
    for (int q = 0; q < kSums; ++q) {
      for (int i = 0; i < cells; ++i) total[q] += S[q * cells + i];
    }
    // Face axes to body axes: d = d_a e_a + d_b e_b + sign d_k e_k.
    vol += total[0];
    area += total[1];
    first[f.a] += total[2];
    first[f.b] += total[3];
    first[f.k] += f.sign * total[4];
    second(f.a, f.a) += total[5];
    second(f.b, f.b) += total[6];
    second(f.k, f.k) += total[7];
    second(f.a, f.b) += total[8];
    second(f.b, f.a) += total[8];
    second(f.a, f.k) += f.sign * total[9];
    second(f.k, f.a) += f.sign * total[9];
    second(f.b, f.k) += f.sign * total[10];
    second(f.k, f.b) += f.sign * total[10];
  }
  volume_ = vol;
  surface_area_ = area;
  min_normal_cosine_ = 1.0 / std::sqrt(cell_weight * worst_slope);
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
  for (float& r : t.r_) r = static_cast<float>(r * s);
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
