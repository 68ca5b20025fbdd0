// Measures of a finished packing (packing.hpp): its solid fraction by distance from the walls, and
// in the core away from them, from quasi-random points tested against the grains.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/synth/packing.hpp"

namespace graintwin::synth {

namespace {
constexpr double kWallBandPointsPerGrain = 512.0;  // points per mean grain volume

// A point is inside grain i if it lies within the grain's radius along its body-frame direction.
bool inside_grain(const shape::RadialTable& t, const PackedGrain& g, const Eigen::Matrix3d& Rt,
                  const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = Rt * (p - g.position);
  const double rho = q.norm();
  return rho == 0.0 || rho < t.radius(q / rho);
}
}  // namespace

std::vector<double> solid_fraction_by_wall_distance(
    const std::vector<const shape::RadialTable*>& shapes, const std::vector<PackedGrain>& grains,
    const Container& c, const std::vector<double>& edges) {
  if (shapes.size() != grains.size()) {
    throw UsageError("solid_fraction_by_wall_distance: " + std::to_string(shapes.size()) +
                     " shapes but " + std::to_string(grains.size()) +
                     " grains; pass one shape per grain");
  }
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    if (shapes[i] == nullptr || shapes[i]->empty()) {
      throw UsageError("solid_fraction_by_wall_distance: shape " + std::to_string(i) +
                       " is null or empty");
    }
  }
  if (edges.size() < 2 || !(edges.front() >= 0.0) ||
      std::adjacent_find(edges.begin(), edges.end(), std::greater_equal<double>()) != edges.end()) {
    throw UsageError("solid_fraction_by_wall_distance: the band edges must be at least two "
                     "increasing distances >= 0 (metres)");
  }
  const std::size_t bands = edges.size() - 1;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Points only where they can count: farther than the first edge from every wall.
  const bool cyl = c.kind == Container::Kind::cylinder;
  const double skip = edges.front();
  Eigen::Vector3d lo, hi;
  if (cyl) {
    const double r = c.radius - skip;
    lo = {-r, -r, skip};
    hi = {r, r, c.height - skip};
  } else {
    lo = Eigen::Vector3d::Constant(skip);
    hi = c.box_size - Eigen::Vector3d::Constant(skip);
  }
  if (grains.empty() || (hi - lo).minCoeff() <= 0.0) return std::vector<double>(bands, nan);
  auto wall_distance = [&](const Eigen::Vector3d& p) {
    if (cyl) return std::min({c.radius - std::hypot(p.x(), p.y()), p.z(), c.height - p.z()});
    return std::min(p.minCoeff(), (c.box_size - p).minCoeff());
  };
  // Quasi-random points (the R3 low-discrepancy sequence of Roberts, 2018: x_k = frac(0.5 + k a),
  // a = (1/g, 1/g^2, 1/g^3), g^4 = g + 1) in the sampled box, kWallBandPointsPerGrain
  // per mean grain volume and 4 million at most. Unlike a lattice they cannot alias with a
  // regular arrangement of grains.
  double vmean = 0.0, rmax = 0.0;
  for (const shape::RadialTable* s : shapes) {
    vmean += s->volume();
    rmax = std::max(rmax, s->max_radius());
  }
  vmean /= static_cast<double>(shapes.size());
  const double box_volume = (hi - lo).prod();
  const long long count = static_cast<long long>(
      std::clamp(box_volume / vmean * kWallBandPointsPerGrain, 1e5, 4e6));
  const double g3 = 1.2207440846057594;
  const Eigen::Vector3d step(1.0 / g3, 1.0 / (g3 * g3), 1.0 / (g3 * g3 * g3));
  // The grain origins in a grid of cells twice the largest bounding radius: the grains that may
  // hold a point are those whose origin lies within that radius of it.
  std::vector<Eigen::Vector3d> origins(grains.size());
  std::vector<Eigen::Matrix3d> rt(grains.size());
  for (std::size_t i = 0; i < grains.size(); ++i) {
    origins[i] = grains[i].position;
    rt[i] = grains[i].orientation.normalized().toRotationMatrix().transpose();
  }
  const PointGrid grid(origins, 2.0 * rmax);
  auto solid_at = [&](const Eigen::Vector3d& p) {
    bool solid = false;
    grid.for_each_within(p, rmax, [&](std::size_t i, double d2) {
      const double r = shapes[i]->max_radius();
      if (!solid && d2 < r * r) solid = inside_grain(*shapes[i], grains[i], rt[i], p);
    });
    return solid;
  };
  const long long chunk = 4096;
  const long long chunks = (count + chunk - 1) / chunk;
  // Per chunk and band: points inside a grain, points in all (summed in chunk order).
  std::vector<long long> solid(chunks * bands, 0), total(chunks * bands, 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (long long ch = 0; ch < chunks; ++ch) {
    for (long long k = ch * chunk; k < std::min(count, (ch + 1) * chunk); ++k) {
      Eigen::Vector3d f = Eigen::Vector3d::Constant(0.5) + static_cast<double>(k) * step;
      f = f.array() - f.array().floor();
      const Eigen::Vector3d p = lo.array() + f.array() * (hi - lo).array();
      const double d = wall_distance(p);
      if (!(d >= edges.front() && d < edges.back())) continue;  // also outside the cylinder
      const std::size_t b =
          static_cast<std::size_t>(std::upper_bound(edges.begin(), edges.end(), d) - edges.begin()) - 1;
      ++total[ch * bands + b];
      if (solid_at(p)) ++solid[ch * bands + b];
    }
  }
  std::vector<double> out(bands, nan);
  for (std::size_t b = 0; b < bands; ++b) {
    long long sb = 0, tb = 0;
    for (long long ch = 0; ch < chunks; ++ch) {
      sb += solid[ch * bands + b];
      tb += total[ch * bands + b];
    }
    if (tb > 0) out[b] = static_cast<double>(sb) / static_cast<double>(tb);
  }
  return out;
}

double core_solid_fraction(const std::vector<const shape::RadialTable*>& shapes,
                           const std::vector<PackedGrain>& grains, const Container& c,
                           double margin) {
  if (!(margin >= 0.0)) {
    if (shapes.size() != grains.size()) {
      throw UsageError("core_solid_fraction: " + std::to_string(shapes.size()) + " shapes but " +
                       std::to_string(grains.size()) + " grains; pass one shape per grain");
    }
    return std::numeric_limits<double>::quiet_NaN();
  }
  return solid_fraction_by_wall_distance(shapes, grains, c, {margin, HUGE_VAL})[0];
}

}  // namespace graintwin::synth
