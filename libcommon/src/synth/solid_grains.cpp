// Grains that are not star-shaped: pocketed angular grains and voxel grains, their ray exits,
// what a radial description misses of them, their star hull and their shape statistics.
#include "graintwin/synth/solid_grains.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/geometry.hpp"
#include "graintwin/core/volume_sample.hpp"
#include "graintwin/shape/isosurface.hpp"
#include "graintwin/shape/sh_basis.hpp"

namespace graintwin::synth {

double Pocket::outside_level(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d d = p - centre;
  if (half_height <= 0.0) return d.norm() - radius;
  const double along = d.dot(axis);
  return std::max(std::abs(along) - half_height, (d - along * axis).norm() - radius);
}

PocketedGrain::PocketedGrain(shape::RadialTable body, std::vector<Pocket> pockets)
    : body_(std::move(body)), pockets_(std::move(pockets)) {
  if (body_.empty()) throw UsageError("PocketedGrain needs a non-empty body table");
}

double PocketedGrain::level(const Eigen::Vector3d& p) const {
  const double dist = p.norm();
  double l = (dist > 0.0 ? body_.radius(p) : body_.min_radius()) - dist;
  for (const Pocket& k : pockets_) l = std::min(l, k.outside_level(p));
  return l;
}

bool PocketedGrain::may_differ_from_hull(const Eigen::Vector3d& p, double radius) const {
  return std::any_of(pockets_.begin(), pockets_.end(),
                     [&](const Pocket& k) { return k.outside_level(p) < radius; });
}

VoxelGrain::VoxelGrain(Volume<float> field, double iso) : field_(std::move(field)), iso_(iso) {
  const Shape3 s = field_.shape();
  if (s[0] < 2 || s[1] < 2 || s[2] < 2) throw UsageError("VoxelGrain needs a field of at least 2 voxels per axis");
  if (!(iso > 0.0 && iso < 1.0)) throw UsageError("VoxelGrain needs a level in (0, 1)");
  for (std::size_t z : {std::size_t{0}, s[0] - 1})
    for (std::size_t y : {std::size_t{0}, s[1] - 1})
      for (std::size_t x : {std::size_t{0}, s[2] - 1}) {
        const Vec3 c = field_.position_xyz(z, y, x);
        reach_ = std::max(reach_, std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]));
      }
}

double VoxelGrain::level(const Eigen::Vector3d& p) const {
  const Vec3& vs = field_.voxel_size();
  const Vec3& o = field_.origin();  // z y x of voxel (0, 0, 0)
  const double z = (p.z() - o[0]) / vs[0], y = (p.y() - o[1]) / vs[1], x = (p.x() - o[2]) / vs[2];
  const Shape3 s = field_.shape();
  if (!(z >= 0.0 && y >= 0.0 && x >= 0.0 && z <= static_cast<double>(s[0] - 1) &&
        y <= static_cast<double>(s[1] - 1) && x <= static_cast<double>(s[2] - 1)))
    return -iso_;
  return trilinear(field_, z, y, x) - iso_;
}

double volume_preserving_level(const Volume<float>& field, double voxels) {
  constexpr int kPerAxis = 4;  // samples per voxel edge
  const Shape3 s = field.shape();
  std::vector<float> samples;
  samples.reserve(kPerAxis * kPerAxis * kPerAxis * field.size());
  const auto at = [](std::size_t i, int k, std::size_t n) {
    return std::clamp(static_cast<double>(i) + (k + 0.5) / kPerAxis - 0.5, 0.0, static_cast<double>(n - 1));
  };
  for (std::size_t z = 0; z < s[0]; ++z)
    for (int kz = 0; kz < kPerAxis; ++kz)
      for (std::size_t y = 0; y < s[1]; ++y)
        for (int ky = 0; ky < kPerAxis; ++ky)
          for (std::size_t x = 0; x < s[2]; ++x)
            for (int kx = 0; kx < kPerAxis; ++kx)
              samples.push_back(trilinear(field, at(z, kz, s[0]), at(y, ky, s[1]), at(x, kx, s[2])));
  const auto inside = static_cast<std::size_t>(std::llround(kPerAxis * kPerAxis * kPerAxis * voxels));
  if (inside == 0 || inside >= samples.size())
    throw UsageError("volume_preserving_level: the voxel count must be positive and below the field's");
  // The level that `inside` samples exceed: midway between the inside-th largest and the next.
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(inside - 1), samples.end(), std::greater<>());
  const float last_in = samples[inside - 1];
  const float first_out = *std::max_element(samples.begin() + static_cast<std::ptrdiff_t>(inside), samples.end());
  return 0.5 * (static_cast<double>(last_in) + static_cast<double>(first_out));
}

namespace {

// The root of the level between a (inside or outside) and b (the other), along the ray.
double bisect(const GrainSolid& solid, const Eigen::Vector3d& u, double a, double b, double tol) {
  const bool a_inside = solid.contains(a * u);
  while (std::abs(b - a) > tol) {
    const double m = 0.5 * (a + b);
    if (solid.contains(m * u) == a_inside) a = m;
    else b = m;
  }
  return 0.5 * (a + b);
}

// Outward unit normal of the solid at body point p: the level's gradient, by central differences.
Eigen::Vector3d level_normal(const GrainSolid& solid, const Eigen::Vector3d& p, double h) {
  Eigen::Vector3d g;
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[a] = h;
    g[a] = solid.level(p - e) - solid.level(p + e);
  }
  const double n = g.norm();
  return n > 0.0 ? Eigen::Vector3d(g / n) : Eigen::Vector3d(p.normalized());
}

// The exits along unit u, the origin known to be inside (ray_exits).
RayExits march(const GrainSolid& solid, const Eigen::Vector3d& u, double step) {
  RayExits out;
  bool inside = true, first_found = false;
  const double reach = solid.reach();
  for (double t = 0.0; t < reach; t += step) {
    const double next = std::min(t + step, reach);
    const bool next_inside = solid.contains(next * u);
    if (inside && !next_inside) {
      const double exit = bisect(solid, u, t, next, 1e-4 * step);
      if (!first_found) out.first = exit, first_found = true;
      out.last = exit;
    }
    inside = next_inside;
  }
  if (inside) {  // still inside at the reach, the solid's bound
    if (!first_found) out.first = reach;
    out.last = reach;
  }
  return out;
}

void require_origin_inside(const GrainSolid& solid, double step) {
  if (!(step > 0.0)) throw UsageError("a grain's rays need a marching step > 0");
  if (!solid.contains(Eigen::Vector3d::Zero()))
    throw DataError("a grain's origin lies outside it, so its rays cannot be followed from there");
}

}  // namespace

RayExits ray_exits(const GrainSolid& solid, const Eigen::Vector3d& unit, double step) {
  require_origin_inside(solid, step);
  return march(solid, unit, step);
}

NonStarMeasures non_star_measures(const GrainSolid& solid, double volume, double step, int directions) {
  if (!(volume > 0.0)) throw UsageError("non_star_measures needs the solid's volume > 0");
  require_origin_inside(solid, step);
  const std::vector<Eigen::Vector3d> dirs = shape::fibonacci_directions(directions);
  const double solid_angle = 4.0 * std::numbers::pi / static_cast<double>(dirs.size());
  double multi = 0.0, hidden = 0.0, depth = 0.0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : multi, hidden) reduction(max : depth)
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    const Eigen::Vector3d& u = dirs[i];
    const RayExits e = march(solid, u, step);
    if (e.last - e.first < 1e-3 * step) continue;
    multi += 1.0;
    // Void between the first exit and the last re-entry: the ray's length outside the solid there.
    const int samples = std::max(8, static_cast<int>(std::ceil((e.last - e.first) / (0.05 * step))));
    const double dt = (e.last - e.first) / samples;
    double v = 0.0;
    for (int k = 0; k < samples; ++k) {
      const double t = e.first + (k + 0.5) * dt;
      if (!solid.contains(t * u)) v += t * t * dt;
    }
    hidden += v * solid_angle;
    const Eigen::Vector3d n = level_normal(solid, e.last * u, 0.25 * step);
    depth = std::max(depth, (e.last - e.first) * std::abs(n.dot(u)));
  }
  return {multi / static_cast<double>(dirs.size()), hidden / volume, depth};
}

shape::RadialTable last_exit_table(const GrainSolid& solid, int n, double step) {
  require_origin_inside(solid, step);
  const std::vector<Eigen::Vector3d> dirs = shape::RadialTable::node_directions(n);
  std::vector<double> exits(dirs.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (std::size_t i = 0; i < dirs.size(); ++i) exits[i] = march(solid, dirs[i], step).last;
  // Dilation over each face's padded (n + 2)^2 grid, whose ghost ring holds the neighbouring faces'
  // directions (the ghost ring itself keeps its own values), at the nodes where a neighbour's exit
  // lies more than 4 steps farther (a jump, not a slope) and the solid may differ from its hull
  // within the dilation's reach: elsewhere the table stays the exits themselves.
  const std::size_t stride = static_cast<std::size_t>(n) + 2, face = stride * stride;
  const double cells = 1.5 * 2.0 / (n - 1);  // the 3 x 3 neighbourhood's angular half-width, roughly
  const double jump = 4.0 * step;
  std::vector<double> radii = exits;
  for (std::size_t f = 0; f < 6; ++f)
    for (std::size_t j = 1; j + 1 < stride; ++j)
      for (std::size_t i = 1; i + 1 < stride; ++i) {
        const std::size_t node = f * face + j * stride + i;
        double r = 0.0;
        for (std::size_t dj = j - 1; dj <= j + 1; ++dj)
          for (std::size_t di = i - 1; di <= i + 1; ++di) r = std::max(r, exits[f * face + dj * stride + di]);
        if (r - exits[node] > jump && solid.may_differ_from_hull(exits[node] * dirs[node], r * cells)) radii[node] = r;
      }
  return shape::RadialTable::from_node_radii(n, std::move(radii));
}

shape::ShapeStats solid_stats(const GrainSolid& solid, double h) {
  if (!(h > 0.0)) throw UsageError("solid_stats needs a grid spacing > 0");
  const double reach = solid.reach();
  const auto n = static_cast<std::size_t>(2.0 * std::ceil(reach / h) + 3.0);  // a ring of outside cells
  const double lo = -0.5 * static_cast<double>(n - 1) * h;
  Volume<float> level({n, n, n}, {h, h, h}, {lo, lo, lo});
#pragma omp parallel for schedule(dynamic)
  for (std::size_t z = 0; z < n; ++z)
    for (std::size_t y = 0; y < n; ++y)
      for (std::size_t x = 0; x < n; ++x) {
        const Vec3 c = level.position_xyz(z, y, x);
        level(z, y, x) = static_cast<float>(solid.level(Eigen::Vector3d(c[0], c[1], c[2])));
      }
  const shape::IsoMeasures iso = shape::isosurface(level, 0.0f);
  // Centroidal second moments from the cells inside.
  double cells = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (std::size_t z = 0; z < n; ++z)
    for (std::size_t y = 0; y < n; ++y)
      for (std::size_t x = 0; x < n; ++x) {
        if (!(level(z, y, x) > 0.0f)) continue;
        const Vec3 c = level.position_xyz(z, y, x);
        const Eigen::Vector3d p(c[0], c[1], c[2]);
        cells += 1.0;
        first += p;
        second += p * p.transpose();
      }
  if (cells == 0.0 || !(iso.volume > 0.0))
    throw DataError("a grain solid holds no grid point at spacing " + std::to_string(h) + " m; give a finer spacing");
  const Eigen::Vector3d mean = first / cells;
  const Eigen::Matrix3d m = second / cells - mean * mean.transpose();  // per unit volume
  shape::ShapeStats s;
  s.volume = iso.volume;
  s.surface_area = iso.area;
  s.equivalent_diameter = equivalent_diameter(s.volume);
  s.sphericity = sphericity(s.volume, s.surface_area);
  shape::set_equivalent_ellipsoid(s, m);
  return s;
}

}  // namespace graintwin::synth
