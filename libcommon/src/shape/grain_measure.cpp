#include "graintwin/shape/grain_measure.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <omp.h>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/statistics.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/core/volume_sample.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/shape/isosurface.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::shape {
namespace {

constexpr float kIso = 0.5f;
/// Smoothing (voxels) of the label indicator that the star-shape test reads: removes the staircase
/// (as the labels surface's default does) without closing real cavities a voxel wide.
constexpr double kStarTestSmoothVox = 0.7;
/// Variance (voxel^2) that reading an edge through the trilinear interpolant adds to its profile
/// (the tent of linear interpolation); the voxel's box adds 1/12 more.
constexpr double kTrilinearReadVariance = 1.0 / 6.0;

/// Voxel moments of one grain: exact integer sums of the voxel indices relative to the box corner.
struct Moments {
  std::uint64_t n = 0;
  std::int64_t s[3] = {0, 0, 0};                   // z, y, x
  std::int64_t ss[6] = {0, 0, 0, 0, 0, 0};         // zz, yy, xx, zy, zx, yx
  bool touches_edge = false;
};

Moments voxel_moments(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& b) {
  Moments m;
  const Shape3& s = labels.shape();
  for (std::size_t z = b[0]; z < b[3]; ++z)
    for (std::size_t y = b[1]; y < b[4]; ++y) {
      const std::uint32_t* row = &labels(z, y, 0);
      for (std::size_t x = b[2]; x < b[5]; ++x) {
        if (row[x] != label) continue;
        const std::int64_t i[3] = {static_cast<std::int64_t>(z - b[0]), static_cast<std::int64_t>(y - b[1]),
                                   static_cast<std::int64_t>(x - b[2])};
        ++m.n;
        for (int k = 0; k < 3; ++k) m.s[k] += i[k];
        m.ss[0] += i[0] * i[0], m.ss[1] += i[1] * i[1], m.ss[2] += i[2] * i[2];
        m.ss[3] += i[0] * i[1], m.ss[4] += i[0] * i[2], m.ss[5] += i[1] * i[2];
        m.touches_edge |= z == 0 || y == 0 || x == 0 || z + 1 == s[0] || y + 1 == s[1] || x + 1 == s[2];
      }
    }
  return m;
}

/// The field box: the grain's box grown by `margin` voxels on every side (it may reach beyond the
/// volume, where the field is 0), with its own origin so positions stay physical.
struct FieldBox {
  long z0, y0, x0;
  Volume<float> field;
};

FieldBox make_box(const Volume<std::uint32_t>& labels, const std::array<std::size_t, 6>& b, long margin) {
  FieldBox box{static_cast<long>(b[0]) - margin, static_cast<long>(b[1]) - margin, static_cast<long>(b[2]) - margin, {}};
  const Shape3 shape{b[3] - b[0] + 2 * static_cast<std::size_t>(margin), b[4] - b[1] + 2 * static_cast<std::size_t>(margin),
                     b[5] - b[2] + 2 * static_cast<std::size_t>(margin)};
  const Vec3& vs = labels.voxel_size();
  const Vec3& o = labels.origin();
  box.field = Volume<float>(shape, vs, {o[0] + box.z0 * vs[0], o[1] + box.y0 * vs[1], o[2] + box.x0 * vs[2]});
  return box;
}

/// Calls f(box index z, y, x, volume index z, y, x) for the box voxels that lie inside the volume.
template <class F>
void for_box_in_volume(const FieldBox& box, const Shape3& s, F&& f) {
  const Shape3& n = box.field.shape();
  for (std::size_t z = 0; z < n[0]; ++z) {
    const long vz = box.z0 + static_cast<long>(z);
    if (vz < 0 || vz >= static_cast<long>(s[0])) continue;
    for (std::size_t y = 0; y < n[1]; ++y) {
      const long vy = box.y0 + static_cast<long>(y);
      if (vy < 0 || vy >= static_cast<long>(s[1])) continue;
      for (std::size_t x = 0; x < n[2]; ++x) {
        const long vx = box.x0 + static_cast<long>(x);
        if (vx >= 0 && vx < static_cast<long>(s[2]))
          f(z, y, x, static_cast<std::size_t>(vz), static_cast<std::size_t>(vy), static_cast<std::size_t>(vx));
      }
    }
  }
}

/// The grain's indicator (1 inside, 0 elsewhere) smoothed with a Gaussian of sigma voxels.
void fill_indicator(FieldBox& box, const Volume<std::uint32_t>& labels, std::uint32_t label, double sigma) {
  for_box_in_volume(box, labels.shape(), [&](std::size_t z, std::size_t y, std::size_t x, std::size_t vz, std::size_t vy, std::size_t vx) {
    box.field(z, y, x) = labels(vz, vy, vx) == label ? 1.0f : 0.0f;
  });
  gaussian_blur(box.field, sigma);
}

template <class T>
void fill_field(FieldBox& box, const Volume<std::uint32_t>& labels, const Volume<T>* grey, std::uint32_t label,
                const MeasureOptions& o, Volume<float>& unbounded) {
  const Shape3& s = labels.shape();
  if (o.source == SurfaceSource::labels) return fill_indicator(box, labels, label, o.smooth_vox);
  // Grey levels, smoothed against noise, move the surface only between voxel centres: a voxel of
  // the grain stays inside (>= 0.5), a void voxel outside (< 0.5), deep voxels are 1 and other
  // grains 0.
  const float scale = static_cast<float>(1.0 / (o.grey_grain - o.grey_void));
  for_box_in_volume(box, s, [&](std::size_t z, std::size_t y, std::size_t x, std::size_t vz, std::size_t vy, std::size_t vx) {
    box.field(z, y, x) = (static_cast<float>((*grey)(vz, vy, vx)) - static_cast<float>(o.grey_void)) * scale;
  });
  if (o.point_spread_vox > 0.0) {
    // The scan is the point spread of all grains; the neighbours' share, from their labels, would
    // lift the grey between close grains and move this grain's 0.5 level towards them.
    FieldBox others{box.z0, box.y0, box.x0, Volume<float>(box.field.shape(), box.field.voxel_size(), box.field.origin())};
    for_box_in_volume(others, s, [&](std::size_t z, std::size_t y, std::size_t x, std::size_t vz, std::size_t vy, std::size_t vx) {
      const std::uint32_t l = labels(vz, vy, vx);
      others.field(z, y, x) = l != 0 && l != label ? 1.0f : 0.0f;
    });
    gaussian_blur(others.field, o.point_spread_vox);
    for (std::size_t i = 0; i < box.field.size(); ++i) box.field.values()[i] -= others.field.values()[i];
  }
  gaussian_blur(box.field, o.smooth_vox);
  unbounded = box.field;  // the grey edge profile, before the labels bound it, for the edge width
  constexpr float kJustOutside = kIso - 1e-4f;
  for_box_in_volume(box, s, [&](std::size_t z, std::size_t y, std::size_t x, std::size_t vz, std::size_t vy, std::size_t vx) {
    const std::uint32_t l = labels(vz, vy, vx);
    float& v = box.field(z, y, x);
    if (l == label) {
      const bool deep = vz > 0 && vy > 0 && vx > 0 && vz + 1 < s[0] && vy + 1 < s[1] && vx + 1 < s[2] &&
                        labels(vz - 1, vy, vx) == label && labels(vz + 1, vy, vx) == label &&
                        labels(vz, vy - 1, vx) == label && labels(vz, vy + 1, vx) == label &&
                        labels(vz, vy, vx - 1) == label && labels(vz, vy, vx + 1) == label;
      v = deep ? 1.0f : std::clamp(v, kIso, 1.0f);
    } else {
      v = l == 0 ? std::clamp(v, 0.0f, kJustOutside) : 0.0f;
    }
  });
  // Box voxels beyond the volume's faces got values from the blur: they are outside the grain.
  const Shape3& n = box.field.shape();
  for (std::size_t z = 0; z < n[0]; ++z)
    for (std::size_t y = 0; y < n[1]; ++y)
      for (std::size_t x = 0; x < n[2]; ++x) {
        const long vz = box.z0 + static_cast<long>(z), vy = box.y0 + static_cast<long>(y), vx = box.x0 + static_cast<long>(x);
        if (vz < 0 || vy < 0 || vx < 0 || vz >= static_cast<long>(s[0]) || vy >= static_cast<long>(s[1]) || vx >= static_cast<long>(s[2]))
          box.field(z, y, x) = 0.0f;
      }
}

bool inside_box(const Volume<float>& f, const Eigen::Vector3d& p) {
  const Shape3& s = f.shape();
  return p[0] >= 0 && p[1] >= 0 && p[2] >= 0 && p[0] <= static_cast<double>(s[0] - 1) && p[1] <= static_cast<double>(s[1] - 1) &&
         p[2] <= static_cast<double>(s[2] - 1);
}

/// What one centroid ray meets: its exits and re-entries (t in metres along the ray).
struct RayProfile {
  double first_exit = 0.0;  ///< 0 if the ray starts outside
  double last_exit = 0.0;   ///< the radius the fit uses (0 if the ray never leaves the grain)
  int exits = 0;
  bool reenters = false;    ///< some void stretch lies before the last exit
  double void_cubes = 0.0;  ///< sum over those stretches of (entry^3 - exit^3), m^3
};

/// Marches from `start` (box index coordinates z, y, x) along `per_metre` (index units per metre) in
/// steps of `ds` metres, refining every crossing of the iso-level by bisection.
RayProfile cast_ray(const Volume<float>& f, const Eigen::Vector3d& start, const Eigen::Vector3d& per_metre, double ds) {
  const auto value = [&](double t) {
    const Eigen::Vector3d p = start + t * per_metre;
    return trilinear(f, p[0], p[1], p[2]);
  };
  const auto crossing = [&](double lo, double hi, bool lo_inside) {
    for (int i = 0; i < 12; ++i) {
      const double mid = 0.5 * (lo + hi);
      ((value(mid) >= kIso) == lo_inside ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  RayProfile ray;
  bool was_inside = value(0.0) >= kIso;
  const bool starts_inside = was_inside;
  double void_start = 0.0;  // where the current void stretch began (the ray's start if it starts outside)
  for (double t = ds;; t += ds) {
    if (!inside_box(f, start + t * per_metre)) break;
    const bool inside = value(t) >= kIso;
    if (was_inside && !inside) {
      void_start = crossing(t - ds, t, true);
      if (ray.exits == 0 && starts_inside) ray.first_exit = void_start;
      ray.last_exit = void_start;
      ++ray.exits;
    } else if (!was_inside && inside) {
      const double entry = crossing(t - ds, t, false);
      ray.void_cubes += entry * entry * entry - void_start * void_start * void_start;
      ray.reenters = true;
    }
    was_inside = inside;
  }
  return ray;
}

/// Central-difference gradient of the trilinear field (index units), half a voxel either side.
Eigen::Vector3d field_gradient(const Volume<float>& f, const Eigen::Vector3d& p) {
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d a = p, b = p;
    a[k] -= 0.5, b[k] += 0.5;
    if (!inside_box(f, a) || !inside_box(f, b)) return Eigen::Vector3d::Zero();
    g[k] = trilinear(f, b[0], b[1], b[2]) - trilinear(f, a[0], a[1], a[2]);
  }
  return g;
}

/// Gaussian sigma (index units) of the edge profile through p along the unit normal n: a blurred
/// step of unit contrast drops by erf(h / (sqrt 2 sigma)) over +-h, inverted for sigma (h = 1
/// voxel, which spans the profile without reaching the far side of a small grain). NaN where the
/// profile does not fall across p.
double edge_sigma_at(const Volume<float>& f, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  constexpr double h = 1.0;
  const Eigen::Vector3d in = p - h * n, out = p + h * n;
  if (!inside_box(f, in) || !inside_box(f, out)) return std::nan("");
  const double drop = trilinear(f, in[0], in[1], in[2]) - trilinear(f, out[0], out[1], out[2]);
  if (!(drop > 0.0)) return std::nan("");
  if (drop >= std::erf(4.0)) return h / (std::numbers::sqrt2 * 4.0);
  double lo = 0.0, hi = 4.0;  // erf(x) = drop, x = h / (sqrt 2 sigma)
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::erf(mid) < drop ? lo : hi) = mid;
  }
  return h / (std::numbers::sqrt2 * 0.5 * (lo + hi));
}

/// Surface area from voxel faces, for grains too small for the isosurface to exist at all.
double voxel_face_area(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& b) {
  const Shape3& s = labels.shape();
  const Vec3& v = labels.voxel_size();
  const double area[3] = {v[1] * v[2], v[0] * v[2], v[0] * v[1]};  // faces normal to z, y, x
  double a = 0.0;
  for (std::size_t z = b[0]; z < b[3]; ++z)
    for (std::size_t y = b[1]; y < b[4]; ++y)
      for (std::size_t x = b[2]; x < b[5]; ++x) {
        if (labels(z, y, x) != label) continue;
        a += (z == 0 || labels(z - 1, y, x) != label) * area[0] + (z + 1 == s[0] || labels(z + 1, y, x) != label) * area[0];
        a += (y == 0 || labels(z, y - 1, x) != label) * area[1] + (y + 1 == s[1] || labels(z, y + 1, x) != label) * area[1];
        a += (x == 0 || labels(z, y, x - 1) != label) * area[2] + (x + 1 == s[2] || labels(z, y, x + 1) != label) * area[2];
      }
  return a;
}

}  // namespace

template <class T>
GrainShape measure_grain(const Volume<std::uint32_t>& labels, const Volume<T>* grey, std::uint32_t label,
                         const std::array<std::size_t, 6>& bbox, const ShFitter& fitter, const MeasureOptions& o) {
  const Vec3& vs = labels.voxel_size();  // z, y, x
  const Moments m = voxel_moments(labels, label, bbox);
  if (m.n == 0) throw DataError("grain " + std::to_string(label) + " has no voxel in its bounding box; rewrite the labels file");
  GrainShape g;
  g.label = label;
  g.voxels = m.n;
  g.volume = static_cast<double>(m.n) * vs[0] * vs[1] * vs[2];
  g.equivalent_diameter = equivalent_diameter(g.volume);

  // Centroid and covariance (x, y, z order); each voxel is a cube, which adds d^2/12 per axis.
  const double n = static_cast<double>(m.n);
  const Eigen::Vector3d mean_zyx(m.s[0] / n, m.s[1] / n, m.s[2] / n);
  const Vec3 c = labels.position_xyz(static_cast<double>(bbox[0]) + mean_zyx[0], static_cast<double>(bbox[1]) + mean_zyx[1],
                                     static_cast<double>(bbox[2]) + mean_zyx[2]);
  g.centroid = Eigen::Vector3d(c[0], c[1], c[2]);
  const auto cov_zyx = [&](int a, int b, int k) {
    return (static_cast<double>(m.ss[k]) / n - mean_zyx[a] * mean_zyx[b]) * vs[a] * vs[b];
  };
  Eigen::Matrix3d cov;  // x, y, z
  cov(2, 2) = cov_zyx(0, 0, 0) + vs[0] * vs[0] / 12.0;
  cov(1, 1) = cov_zyx(1, 1, 1) + vs[1] * vs[1] / 12.0;
  cov(0, 0) = cov_zyx(2, 2, 2) + vs[2] * vs[2] / 12.0;
  cov(2, 1) = cov(1, 2) = cov_zyx(0, 1, 3);
  cov(2, 0) = cov(0, 2) = cov_zyx(0, 2, 4);
  cov(1, 0) = cov(0, 1) = cov_zyx(1, 2, 5);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  for (int k = 0; k < 3; ++k) {  // eigenvalues ascend: a is the last
    g.semi_axes[k] = std::sqrt(5.0 * std::max(0.0, eig.eigenvalues()[2 - k]));
    g.axes.col(k) = eig.eigenvectors().col(2 - k);
  }
  if (g.axes.determinant() < 0) g.axes.col(2) = -g.axes.col(2);
  g.aspect_ratio = g.semi_axes[0] / g.semi_axes[2];
  g.elongation = g.semi_axes[1] / g.semi_axes[0];
  g.flatness = g.semi_axes[2] / g.semi_axes[1];

  // Field, isosurface and rays.
  const long margin = 2 + static_cast<long>(std::ceil(3.0 * std::max(o.smooth_vox, kStarTestSmoothVox)));
  FieldBox box = make_box(labels, bbox, margin);
  Volume<float> unbounded;
  fill_field(box, labels, grey, label, o, unbounded);
  // The star-shape test reads the segmentation's decision (the labels, smoothed against the
  // staircase), not the grey levels: those only move the surface by part of a voxel, and their
  // noise would open pockets that are not in the grain. With smoothed labels as the surface it is
  // the same field.
  const bool own_star_field = o.source != SurfaceSource::labels || o.smooth_vox != kStarTestSmoothVox;
  FieldBox star_box = own_star_field ? make_box(labels, bbox, margin) : FieldBox{};
  if (own_star_field) fill_indicator(star_box, labels, label, kStarTestSmoothVox);
  const Volume<float>& star_field = own_star_field ? star_box.field : box.field;
  g.surface_area = isosurface(box.field, kIso).area;
  if (!(g.surface_area > 0.0)) g.surface_area = voxel_face_area(labels, label, bbox);
  g.sphericity = sphericity(g.volume, g.surface_area);

  const Eigen::Vector3d start(static_cast<double>(bbox[0] - box.z0) + mean_zyx[0], static_cast<double>(bbox[1] - box.y0) + mean_zyx[1],
                              static_cast<double>(bbox[2] - box.x0) + mean_zyx[2]);
  const double voxel = std::min({vs[0], vs[1], vs[2]});
  const double ds = 0.5 * voxel;
  const Volume<float>& profile_field = o.source == SurfaceSource::grey ? unbounded : box.field;
  const auto& dirs = fitter.directions();
  Eigen::VectorXd radii(static_cast<Eigen::Index>(dirs.size()));
  std::size_t reentrant = 0, missing = 0;
  double void_cubes = 0.0;
  std::vector<double> sigmas;
  sigmas.reserve(dirs.size());
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    const Eigen::Vector3d& d = dirs[i];  // x, y, z
    const Eigen::Vector3d per_metre(d[2] / vs[0], d[1] / vs[1], d[0] / vs[2]);
    const RayProfile surface_ray = cast_ray(box.field, start, per_metre, ds);
    radii[static_cast<Eigen::Index>(i)] = surface_ray.last_exit;
    missing += surface_ray.exits == 0;
    if (surface_ray.exits == 0) continue;
    // The outward normal at the radius the fit uses: the edge profile is read across it.
    const Eigen::Vector3d unit_ray = per_metre.normalized();
    const auto outward_normal = [&](const Volume<float>& f, const Eigen::Vector3d& p) {
      const Eigen::Vector3d grad = field_gradient(f, p);
      return grad.norm() > 0.0 ? Eigen::Vector3d(-grad / grad.norm()) : unit_ray;
    };
    const Eigen::Vector3d p = start + surface_ray.last_exit * per_metre;
    const double sigma = edge_sigma_at(profile_field, p, outward_normal(profile_field, p));
    if (std::isfinite(sigma)) sigmas.push_back(sigma);
    const RayProfile ray = own_star_field ? cast_ray(star_field, start, per_metre, ds) : surface_ray;
    if (!ray.reenters || ray.exits == 0) continue;
    // The missed stretch, scaled by the slope of the radial surface, is the missed surface's
    // distance from it.
    const Eigen::Vector3d q = start + ray.last_exit * per_metre;
    const double depth = (ray.last_exit - ray.first_exit) * std::abs(outward_normal(star_field, q).dot(unit_ray));
    if (depth < o.min_reentry_depth_vox * voxel) continue;  // a voxel-noise dent, not a cavity
    ++reentrant;
    void_cubes += ray.void_cubes;
    g.reentry_depth = std::max(g.reentry_depth, depth);
  }
  g.multi_exit_fraction = static_cast<double>(reentrant) / static_cast<double>(dirs.size());
  // Each Fibonacci direction carries 4 pi / N of solid angle; a stretch [a, b] of it r^2 dr.
  g.hidden_void_fraction = 4.0 * std::numbers::pi / static_cast<double>(dirs.size()) * void_cubes / 3.0 / g.volume;
  if (!sigmas.empty()) g.edge_sigma = median(std::move(sigmas)) * voxel;
  const bool centroid_outside = trilinear(box.field, start[0], start[1], start[2]) < kIso;

  // SH fit with the per-grain degree.
  const int L = fitter.degree();
  const double r_eq = 0.5 * g.equivalent_diameter;
  g.coeffs = fitter.fit(radii);
  const Eigen::VectorXd trunc = fitter.truncation_rms(radii, g.coeffs);
  g.sh_degree = L;
  if (o.tol > 0.0)
    for (int k = 0; k <= L; ++k)
      if (trunc[k] <= o.tol * r_eq) {
        g.sh_degree = k;
        break;
      }
  g.coeffs.tail(g.coeffs.size() - sh_count(g.sh_degree)).setZero();
  g.rms_error = trunc[g.sh_degree] / r_eq;
  g.max_error = (radii - fitter.design() * g.coeffs).cwiseAbs().maxCoeff() / r_eq;
  // The edge width as read through the trilinear field: averaged over the grid's offsets the
  // interpolant is the field blurred by its tent (1/6 voxel^2), which moves its 0.5 level too.
  if (o.correct_blur && g.edge_sigma > 0.0) g.coeffs = correct_edge_blur(g.coeffs, L, g.edge_sigma, r_eq);
  g.invariants = sh_invariants(g.coeffs, L);
  g.volume_error = fitter.moments(g.coeffs).volume / g.volume - 1.0;

  if (reentrant > 0) g.flags |= shape_flag::not_star_shaped;
  if (centroid_outside) g.flags |= shape_flag::centroid_outside;
  if (centroid_outside || missing > 0 || g.hidden_void_fraction > o.max_hidden_void_fraction ||
      g.reentry_depth > o.max_reentry_depth_vox * voxel)
    g.flags |= shape_flag::unreliable_fit;
  if (m.touches_edge) g.flags |= shape_flag::touches_edge;
  if (g.equivalent_diameter < 6.0 * std::min({vs[0], vs[1], vs[2]})) g.flags |= shape_flag::small;
  if (o.tol > 0.0 && trunc[L] > o.tol * r_eq) g.flags |= shape_flag::tolerance_not_met;
  return g;
}

Eigen::VectorXd correct_edge_blur(const Eigen::VectorXd& coeffs, int degree, double sigma, double radius) {
  if (coeffs.size() != sh_count(degree)) throw UsageError("correct_edge_blur needs sh_count(degree) coefficients");
  if (!(sigma >= 0.0 && radius > 0.0)) throw UsageError("correct_edge_blur needs sigma >= 0 and a radius > 0");
  constexpr double kMaxGain = 1.5;
  const double s2 = sigma * sigma / (radius * radius);
  Eigen::VectorXd c = coeffs;
  c[0] += sigma * sigma / radius * std::sqrt(4.0 * std::numbers::pi);
  for (int n = 2; n <= degree; ++n) {
    const double gain = std::min(kMaxGain, 1.0 + s2 * (n * (n + 1) - 2) / 2.0);
    c.segment(n * n, 2 * n + 1) *= gain;
  }
  return c;
}

template <class T>
std::vector<GrainShape> measure_grains(const Volume<std::uint32_t>& labels, const Volume<T>* grey,
                                       const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>& grains,
                                       const ShFitter& fitter, const MeasureOptions& options,
                                       const std::function<void(double)>& progress) {
  if (options.source == SurfaceSource::grey) {
    if (!grey) throw UsageError("grey-level surfaces need the grey volume");
    if (grey->shape() != labels.shape())
      throw UsageError("the grey volume and the labels differ in shape; pass the scan that was segmented");
    if (!(options.grey_grain > options.grey_void)) throw DataError("the grain grey level must exceed the void grey level");
  }
  if (!(options.smooth_vox >= 0.0 && std::isfinite(options.smooth_vox)))
    throw UsageError("the smoothing sigma must be a finite number of voxels >= 0");
  if (!(options.point_spread_vox >= 0.0 && std::isfinite(options.point_spread_vox)))
    throw UsageError("the point spread must be a finite number of voxels >= 0");
  std::vector<GrainShape> out(grains.size());
  std::atomic<std::size_t> done{0};
  std::exception_ptr error;
#pragma omp parallel for schedule(dynamic, 4) num_threads(useful_threads(grains.size()))
  for (std::size_t i = 0; i < grains.size(); ++i) {
    try {
      out[i] = measure_grain(labels, grey, grains[i].first, grains[i].second, fitter, options);
    } catch (...) {
#pragma omp critical
      if (!error) error = std::current_exception();
    }
    const std::size_t d = ++done;
    if (progress && omp_get_thread_num() == 0) progress(static_cast<double>(d) / static_cast<double>(grains.size()));
  }
  if (error) std::rethrow_exception(error);
  if (progress) progress(1.0);
  return out;
}

template <class T>
double estimate_point_spread(const Volume<std::uint32_t>& labels, const Volume<T>& grey,
                             const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>& grains,
                             const ShFitter& fitter, MeasureOptions options, std::size_t sample) {
  if (grains.empty() || sample == 0) return 0.0;
  options.source = SurfaceSource::grey;
  options.point_spread_vox = 0.0;
  const std::size_t n = std::min(sample, grains.size());
  std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>> picked;
  for (std::size_t k = 0; k < n; ++k) picked.push_back(grains[k * grains.size() / n]);
  std::vector<double> sigma2;
  const double voxel = std::min({labels.voxel_size()[0], labels.voxel_size()[1], labels.voxel_size()[2]});
  for (const GrainShape& g : measure_grains(labels, &grey, picked, fitter, options))
    if (g.edge_sigma > 0.0) sigma2.push_back(std::pow(g.edge_sigma / voxel, 2));
  if (sigma2.empty()) return 0.0;
  // The edge read through trilinear interpolation of a voxelised step: box 1/12, tent 1/6 (the
  // ellipsoid benchmark reads sqrt(sigma^2 + 1/4) within 0.02 voxel for sigma 0 to 1.6).
  return std::sqrt(std::max(0.0, median(std::move(sigma2)) - kTrilinearReadVariance - 1.0 / 12.0));
}

template <class T>
GreyLevels grey_levels(const Volume<std::uint32_t>& labels, const Volume<T>& grey) {
  if (grey.shape() != labels.shape())
    throw UsageError("the grey volume and the labels differ in shape; pass the scan that was segmented");
  const Shape3& s = labels.shape();
  const std::size_t stride = std::max<std::size_t>(1, labels.size() / (8u << 20));
  std::vector<float> void_values, grain_values;
  for (std::size_t p = 0; p < labels.size(); p += stride) {
    const std::size_t x = p % s[2], y = (p / s[2]) % s[1], z = p / (s[1] * s[2]);
    if (x == 0 || y == 0 || z == 0 || x + 1 == s[2] || y + 1 == s[1] || z + 1 == s[0]) continue;
    const std::uint32_t l = labels.values()[p];
    const std::size_t sy = s[2], sz = s[1] * s[2];
    const auto* L = labels.data();
    if (L[p - 1] != l || L[p + 1] != l || L[p - sy] != l || L[p + sy] != l || L[p - sz] != l || L[p + sz] != l) continue;
    (l == 0 ? void_values : grain_values).push_back(static_cast<float>(grey.values()[p]));
  }
  if (void_values.empty() || grain_values.empty())
    throw DataError("the scan has no interior void or no interior grain voxel, so its grey levels are unknown; "
                    "give them (--grey-void, --grey-grain) or use --surface labels");
  GreyLevels g{median(std::move(void_values)), median(std::move(grain_values))};
  if (!(g.grain_level > g.void_level))
    throw DataError("grains are not brighter than the void in this scan; give --grey-void and --grey-grain or use --surface labels");
  return g;
}

SizeDistribution size_distribution(const std::vector<double>& diameters, const std::vector<double>& volumes) {
  if (diameters.size() != volumes.size()) throw UsageError("size_distribution needs one volume per diameter");
  std::vector<std::size_t> order(diameters.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return diameters[a] < diameters[b]; });
  SizeDistribution psd;
  double total = 0.0;
  for (double v : volumes) total += v;
  if (!(total > 0.0)) return psd;
  double cum = 0.0;
  for (std::size_t i : order) {
    cum += volumes[i];
    psd.diameter.push_back(diameters[i]);
    psd.percent_passing.push_back(100.0 * cum / total);
  }
  psd.d50 = d50_of_curve(psd.diameter, psd.percent_passing);
  return psd;
}

void set_form(GrainShape& g, const ShapeStats& stats) {
  g.volume = stats.volume;
  g.surface_area = stats.surface_area;
  g.equivalent_diameter = stats.equivalent_diameter;
  g.sphericity = stats.sphericity;
  g.semi_axes = stats.semi_axes;
  g.axes = stats.axes;
  g.aspect_ratio = stats.aspect_ratio;
  g.elongation = stats.semi_axes[1] / stats.semi_axes[0];
  g.flatness = stats.semi_axes[2] / stats.semi_axes[1];
}

SizeDistribution size_distribution(const std::vector<GrainShape>& grains) {
  std::vector<double> d(grains.size()), v(grains.size());
  for (std::size_t i = 0; i < grains.size(); ++i) d[i] = grains[i].equivalent_diameter, v[i] = grains[i].volume;
  return size_distribution(d, v);
}

#define GRAINTWIN_MEASURE_INSTANTIATE(T)                                                                        \
  template GrainShape measure_grain(const Volume<std::uint32_t>&, const Volume<T>*, std::uint32_t,                \
                                    const std::array<std::size_t, 6>&, const ShFitter&, const MeasureOptions&);  \
  template std::vector<GrainShape> measure_grains(                                                              \
      const Volume<std::uint32_t>&, const Volume<T>*,                                                           \
      const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>&, const ShFitter&,                \
      const MeasureOptions&, const std::function<void(double)>&);                                               \
  template GreyLevels grey_levels(const Volume<std::uint32_t>&, const Volume<T>&);                              \
  template double estimate_point_spread(const Volume<std::uint32_t>&, const Volume<T>&,                         \
                                        const std::vector<std::pair<std::uint32_t, std::array<std::size_t, 6>>>&, \
                                        const ShFitter&, MeasureOptions, std::size_t);
GRAINTWIN_MEASURE_INSTANTIATE(std::uint8_t)
GRAINTWIN_MEASURE_INSTANTIATE(std::uint16_t)
GRAINTWIN_MEASURE_INSTANTIATE(float)
#undef GRAINTWIN_MEASURE_INSTANTIATE

}  // namespace graintwin::shape
