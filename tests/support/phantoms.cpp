#include "support/phantoms.hpp"

#include "graintwin/shape/shapes_file.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "graintwin/core/filters.hpp"

namespace graintwin::test {
namespace {

/// Calls f(z, y, x) for every voxel of the bounding box of b (one voxel of margin), clipped to shape.
template <class F>
void for_box(Shape3 shape, const Ball& b, F&& f) {
  const auto lo = [](double c) { return static_cast<long>(std::max(0.0, std::floor(c - 1.0))); };
  const auto hi = [](double c, std::size_t n) { return std::min(static_cast<long>(n) - 1, static_cast<long>(std::ceil(c + 1.0))); };
  for (long z = lo(b.z - b.r); z <= hi(b.z + b.r, shape[0]); ++z)
    for (long y = lo(b.y - b.r); y <= hi(b.y + b.r, shape[1]); ++y)
      for (long x = lo(b.x - b.r); x <= hi(b.x + b.r, shape[2]); ++x) f(z, y, x);
}

}  // namespace

Volume<std::uint8_t> paint_balls(Shape3 shape, const std::vector<Ball>& balls, Vec3 voxel, Vec3 origin) {
  Volume<std::uint8_t> m(shape, voxel, origin);
  for (const Ball& b : balls)
    for_box(shape, b, [&](long z, long y, long x) {
      if (std::hypot(z - b.z, y - b.y, x - b.x) <= b.r) m(z, y, x) = 1;
    });
  return m;
}

Volume<std::uint32_t> label_balls(Shape3 shape, const std::vector<Ball>& balls, Vec3 voxel) {
  Volume<std::uint32_t> l(shape, voxel);
  for (std::size_t i = 0; i < balls.size(); ++i)
    for_box(shape, balls[i], [&](long z, long y, long x) {
      if (std::hypot(z - balls[i].z, y - balls[i].y, x - balls[i].x) <= balls[i].r)
        l(z, y, x) = static_cast<std::uint32_t>(i + 1);
    });
  return l;
}

Volume<std::uint32_t> label_hollow_grain_and_ball(std::size_t nx, Vec3 voxel) {
  Volume<std::uint32_t> l({40, 40, nx}, voxel);
  const Ball hollow{19.9, 20.2, 19.7, 15.0}, cavity{19.9, 20.2, 27.2, 5.5}, ball{20.1, 19.8, 52.3, 12.0};
  const auto inside = [](const Ball& b, long z, long y, long x) { return std::hypot(z - b.z, y - b.y, x - b.x) <= b.r; };
  for (long z = 0; z < 40; ++z)
    for (long y = 0; y < 40; ++y)
      for (long x = 0; x < static_cast<long>(nx); ++x) {
        if (inside(hollow, z, y, x) && !inside(cavity, z, y, x)) l(z, y, x) = 1;
        if (inside(ball, z, y, x)) l(z, y, x) = 2;
      }
  return l;
}

std::vector<Ball> jittered_lattice(int n, double r, double step, double first, double jitter, double radius_jitter,
                                   std::uint32_t seed) {
  std::mt19937 rng(seed);
  const auto u = [&] { return (rng() % 20001) / 10000.0 - 1.0; };
  std::vector<Ball> b;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        b.push_back({first + step * i + jitter * u(), first + step * j + jitter * u(), first + step * k + jitter * u(),
                     radius_jitter != 0.0 ? r * (1.0 + radius_jitter * u()) : r});
  return b;
}

void write_sphere_shapes(const std::filesystem::path& path, const std::vector<std::uint32_t>& labels,
                         const std::vector<Eigen::Vector3d>& centroids, double diameter, const std::string& history) {
  const double volume = std::numbers::pi / 6.0 * std::pow(diameter, 3);
  shape::ShapesFile sh;
  std::vector<double> d, v;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    shape::GrainShape g;
    g.label = labels[i];
    g.volume = volume;
    g.equivalent_diameter = diameter;
    g.centroid = centroids[i];
    g.coeffs = Eigen::VectorXd::Constant(1, diameter);
    g.invariants = g.coeffs;
    sh.grains.push_back(g);
    d.push_back(diameter), v.push_back(volume);
  }
  sh.psd = shape::size_distribution(d, v);
  sh.parameters_json = "{}";
  shape::write_shapes_file(path, sh, {history});
}

Volume<std::uint16_t> uint16_scan(const Volume<float>& f) {
  Volume<std::uint16_t> v(f.shape(), f.voxel_size(), f.origin());
  for (std::size_t i = 0; i < f.size(); ++i) v.values()[i] = static_cast<std::uint16_t>(std::lround(4000.0 * f.values()[i]));
  return v;
}

Volume<float> scan_balls(Shape3 shape, const std::vector<Ball>& balls, std::uint32_t seed, double noise, Vec3 voxel) {
  Volume<float> occ(shape, voxel);
  for (const Ball& b : balls)
    for_box(shape, b, [&](long z, long y, long x) {
      int in = 0;
      for (double a : {-0.25, 0.25})
        for (double c : {-0.25, 0.25})
          for (double d : {-0.25, 0.25}) in += std::hypot(z + a - b.z, y + c - b.y, x + d - b.x) <= b.r;
      occ(z, y, x) = std::min(1.0f, occ(z, y, x) + in / 8.0f);
    });
  for (float& v : occ.values()) v = 0.25f + 0.5f * v;
  gaussian_blur(occ, 0.8);
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, static_cast<float>(noise));
  for (float& v : occ.values()) v += gauss(rng);
  return occ;
}

std::size_t count_labels(const Volume<std::uint32_t>& labels) {
  std::set<std::uint32_t> s(labels.values().begin(), labels.values().end());
  s.erase(0);
  return s.size();
}

}  // namespace graintwin::test
