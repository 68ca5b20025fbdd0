#include "graintwin/micro/structure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "graintwin/core/enum_names.hpp"
#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/core/point_grid.hpp"
#include "graintwin/micro/clusters.hpp"

namespace graintwin::micro {

bool Region::contains(const Eigen::Vector3d& p) const {
  if (kind == Kind::box) return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  // The same expression as enclosing_region's radius, so the farthest point is inside (squaring
  // the radius can round it below that point's squared distance).
  return p.z() >= lo.z() && p.z() <= hi.z() && (p.head<2>() - axis).norm() <= radius;
}

double Region::volume() const {
  if (kind == Kind::box) return (hi - lo).prod();
  return std::numbers::pi * radius * radius * (hi.z() - lo.z());
}

double Region::depth(const Eigen::Vector3d& p) const {
  if (!contains(p)) return 0.0;
  const double axial = std::min(p.z() - lo.z(), hi.z() - p.z());
  if (kind == Kind::cylinder) return std::min(axial, radius - (p.head<2>() - axis).norm());
  return std::min({axial, p.x() - lo.x(), hi.x() - p.x(), p.y() - lo.y(), hi.y() - p.y()});
}

namespace {
constexpr std::array<EnumName<Region::Kind>, 2> kRegionKindNames{{{Region::Kind::box, "box"}, {Region::Kind::cylinder, "cylinder"}}};
}  // namespace

Region::Kind parse_region_kind(const std::string& name) { return parse_enum(kRegionKindNames, name, "region"); }

const char* region_kind_name(Region::Kind kind) { return enum_name(kRegionKindNames, kind); }

Region enclosing_region(const std::vector<Eigen::Vector3d>& points, Region::Kind kind) {
  Region r;
  r.kind = kind;
  r.lo.setConstant(std::numeric_limits<double>::infinity());
  r.hi.setConstant(-std::numeric_limits<double>::infinity());
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  std::size_t n = 0;
  for (const auto& p : points)
    if (p.allFinite()) r.lo = r.lo.cwiseMin(p), r.hi = r.hi.cwiseMax(p), sum += p.head<2>(), ++n;
  if (n == 0) throw DataError("enclosing_region: no finite point");
  if (kind == Region::Kind::cylinder) {
    r.axis = sum / double(n);
    for (const auto& p : points)
      if (p.allFinite()) r.radius = std::max(r.radius, (p.head<2>() - r.axis).norm());
  }
  return r;
}

std::vector<Eigen::Vector3d> fibonacci_directions(std::size_t n) {
  std::vector<Eigen::Vector3d> d(n);
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (std::size_t k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * double(k) + 1.0) / double(n), s = std::sqrt(1.0 - z * z);
    d[k] = Eigen::Vector3d(s * std::cos(golden * double(k)), s * std::sin(golden * double(k)), z);
  }
  return d;
}

double sphere_fraction_inside(const Region& region, const Eigen::Vector3d& p, double r,
                              const std::vector<Eigen::Vector3d>& directions) {
  if (region.depth(p) >= r) return 1.0;
  std::size_t inside = 0;
  for (const auto& d : directions) inside += region.contains(p + r * d);
  return double(inside) / double(directions.size());
}

PairCorrelation pair_correlation(const std::vector<Eigen::Vector3d>& points, const Region& region, double r_max,
                                 std::size_t bins, std::size_t directions) {
  if (!(r_max > 0.0) || bins == 0 || directions == 0) throw UsageError("pair_correlation: needs r_max > 0, bins and directions");
  std::vector<Eigen::Vector3d> in;
  for (const auto& p : points)
    if (p.allFinite() && region.contains(p)) in.push_back(p);
  PairCorrelation g;
  g.points = in.size();
  const double volume = region.volume();
  g.density = volume > 0.0 ? double(in.size()) / volume : 0.0;
  const double width = r_max / double(bins);
  for (std::size_t b = 0; b <= bins; ++b) g.edges.push_back(width * double(b));
  for (std::size_t b = 0; b < bins; ++b) g.r.push_back(width * (double(b) + 0.5));
  g.g.assign(bins, 0.0);
  if (in.size() < 2 || !(volume > 0.0)) return g;
  const auto dirs = fibonacci_directions(directions);
  const PointGrid grid(in, r_max);
  // Each block of points fills its own row of bins, and the rows are summed in block order: the
  // sums, and so g(r), are the same bit for bit whatever the threads and their schedule.
  constexpr std::size_t kBlock = 64;
  const std::size_t blocks = (in.size() + kBlock - 1) / kBlock;
  std::vector<double> partial(blocks * bins, 0.0);
#pragma omp parallel num_threads(useful_threads(in.size()))
  {
    std::vector<double> weight(bins);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t block = 0; block < std::ptrdiff_t(blocks); ++block) {
      double* local = &partial[std::size_t(block) * bins];
      const std::size_t end = std::min(in.size(), (std::size_t(block) + 1) * kBlock);
      for (std::size_t i = std::size_t(block) * kBlock; i < end; ++i) {
        // Weights per bin, computed only where the sphere can leave the region.
        const double depth = region.depth(in[i]);
        for (std::size_t b = 0; b < bins; ++b) {
          if (g.r[b] <= depth) {
            weight[b] = 1.0;
            continue;
          }
          const double f = sphere_fraction_inside(region, in[i], g.r[b], dirs);
          weight[b] = f > 0.0 ? 1.0 / f : 0.0;
        }
        grid.for_each_within(in[i], r_max, [&](std::size_t j, double d2) {
          if (j == i || d2 <= 0.0) return;
          const std::size_t b = std::min(bins - 1, std::size_t(std::sqrt(d2) / width));
          local[b] += weight[b];
        });
      }
    }
  }
  std::vector<double> sum(bins, 0.0);
  for (std::size_t block = 0; block < blocks; ++block)
    for (std::size_t b = 0; b < bins; ++b) sum[b] += partial[block * bins + b];
  const double n = double(in.size());
  for (std::size_t b = 0; b < bins; ++b) {
    const double shell = 4.0 / 3.0 * std::numbers::pi * (std::pow(g.edges[b + 1], 3) - std::pow(g.edges[b], 3));
    g.g[b] = volume * sum[b] / (n * (n - 1.0) * shell);
  }
  return g;
}

std::vector<std::uint32_t> coordination_from_pairs(std::size_t n, const std::vector<std::pair<std::size_t, std::size_t>>& pairs) {
  std::vector<std::uint32_t> z(n, 0);
  for (auto [a, b] : pairs) {
    if (a >= n || b >= n) throw UsageError("coordination_from_pairs: a pair names a grain out of range");
    ++z[a], ++z[b];
  }
  return z;
}

std::vector<std::uint32_t> coordination_by_distance(const std::vector<Eigen::Vector3d>& positions,
                                                    const std::vector<double>& radii, double factor) {
  std::vector<std::size_t> all;
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (positions[i].allFinite()) all.push_back(i);
  return coordination_from_pairs(positions.size(), contact_links(positions, radii, all, factor));
}

CoordinationDistribution coordination_distribution(const std::vector<std::uint32_t>& z) {
  CoordinationDistribution d;
  if (z.empty()) return d;
  d.count.assign(*std::max_element(z.begin(), z.end()) + 1, 0);
  for (std::uint32_t v : z) ++d.count[v], d.mean += v;
  d.grains = z.size();
  d.mean /= double(z.size());
  return d;
}

DisplacementDistributions displacement_distributions(const std::vector<Eigen::Vector3d>& increments, double d50,
                                                     double range_d50, std::size_t bins) {
  if (!(d50 > 0.0) || !(range_d50 > 0.0)) throw UsageError("displacement_distributions: d50 and the range must be positive");
  std::vector<double> c[3], m;
  for (const auto& u : increments) {
    if (!u.allFinite()) continue;
    for (int k = 0; k < 3; ++k) c[k].push_back(u[k] / d50);
    m.push_back(u.norm() / d50);
  }
  DisplacementDistributions d;
  for (int k = 0; k < 3; ++k) d.component[k] = linear_histogram(c[k], -range_d50, range_d50, bins);
  d.magnitude = linear_histogram(m, 0.0, range_d50, bins);
  return d;
}

}  // namespace graintwin::micro
