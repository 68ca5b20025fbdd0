// The packer's random start: random sequential addition of the bounding spheres at a reduced
// scale (packing_start.hpp). Its cell grid takes the grains one at a time as they are placed,
// which core/point_grid (an index of a fixed set of points) does not do.
#include "packing_start.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace graintwin::synth::detail {

namespace {

constexpr double kDefaultScale = 0.55;   // initial scale for compact grains ...
constexpr double kBoundingFill = 0.25;   // ... lowered so that bounding spheres fill at most this
constexpr int kAttempts = 2000;          // random placements per grain before shrinking the start
constexpr double kShrink = 0.9;          // the start's scale shrinks by this after a failed attempt ...
constexpr double kSmallestScale = 0.15;  // ... down to this

// Uniform doubles from a 64-bit Mersenne twister, defined here (not by the standard library's
// distributions) so that the start is the same on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : g_(seed) {}
  double uniform() { return static_cast<double>(g_() >> 11) * 0x1.0p-53; }

 private:
  std::mt19937_64 g_;
};

// Uniformly random rotation (Shoemake 1992).
Eigen::Quaterniond random_rotation(Rng& rng) {
  const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  Eigen::Quaterniond q(b * std::cos(2.0 * M_PI * u3), a * std::sin(2.0 * M_PI * u2),
                       a * std::cos(2.0 * M_PI * u2), b * std::sin(2.0 * M_PI * u3));
  q.normalize();
  return q;
}

// Cells per axis of a grid over [lo, hi] whose cells are at least min_cell wide (so that
// neighbours within min_cell are in adjacent cells), widened if needed to keep the number of
// cells below about 8 per item (a sparse scene must not allocate a huge grid).
Eigen::Vector3i grid_dims(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double min_cell,
                          std::size_t items) {
  double cell = min_cell;
  Eigen::Vector3i dims;
  for (;;) {
    for (int k = 0; k < 3; ++k) {
      dims[k] = std::max(1, static_cast<int>(std::min((hi[k] - lo[k]) / cell, 1e6)));
    }
    if (static_cast<double>(dims.x()) * dims.y() * dims.z() <= 8.0 * items + 64.0) return dims;
    cell *= 1.26;
  }
}

// One attempt at scale s0: every grain, in `order`, at the first of kAttempts random positions
// where its bounding sphere overlaps none placed before it. False when some grain finds no room.
bool try_rsa(const Container& c, const std::vector<double>& rmax, double s0,
             const std::vector<std::size_t>& order, Rng& rng, std::vector<Eigen::Vector3d>& x,
             std::vector<Eigen::Quaterniond>& q) {
  const bool box = c.kind == Container::Kind::box;
  const Eigen::Vector3d lo = box ? Eigen::Vector3d::Zero() : Eigen::Vector3d(-c.radius, -c.radius, 0.0);
  const Eigen::Vector3d hi = box ? c.box_size : Eigen::Vector3d(c.radius, c.radius, c.height);
  const double rmax_max = *std::max_element(rmax.begin(), rmax.end());
  const Eigen::Vector3i dims = grid_dims(lo, hi, 2.0 * s0 * rmax_max, rmax.size());
  std::vector<std::vector<int>> grid(static_cast<std::size_t>(dims.prod()));
  auto cell_of = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3i cell;
    for (int k = 0; k < 3; ++k) {
      cell[k] = std::clamp(static_cast<int>((p[k] - lo[k]) / (hi[k] - lo[k]) * dims[k]), 0,
                           dims[k] - 1);
    }
    return cell;
  };
  for (std::size_t i : order) {
    const double r = s0 * rmax[i];
    bool placed = false;
    for (int attempt = 0; attempt < kAttempts && !placed; ++attempt) {
      Eigen::Vector3d p;
      if (c.kind == Container::Kind::cylinder) {
        const double rr = c.radius - r;
        if (rr <= 0.0 || c.height <= 2.0 * r) return false;
        const double rad = rr * std::sqrt(rng.uniform());
        const double ang = 2.0 * M_PI * rng.uniform();
        p = {rad * std::cos(ang), rad * std::sin(ang), r + (c.height - 2.0 * r) * rng.uniform()};
      } else {
        for (int k = 0; k < 3; ++k) {
          if (c.box_size[k] <= 2.0 * r) return false;
          p[k] = r + (c.box_size[k] - 2.0 * r) * rng.uniform();
        }
      }
      const Eigen::Vector3i ci = cell_of(p);
      bool free = true;
      for (int dz = -1; dz <= 1 && free; ++dz) {
        for (int dy = -1; dy <= 1 && free; ++dy) {
          for (int dx = -1; dx <= 1 && free; ++dx) {
            const Eigen::Vector3i cj = ci + Eigen::Vector3i(dx, dy, dz);
            if ((cj.array() < 0).any() || (cj.array() >= dims.array()).any()) continue;
            for (int j : grid[(cj.z() * dims.y() + cj.y()) * dims.x() + cj.x()]) {
              const double rs = r + s0 * rmax[j];
              if ((x[j] - p).squaredNorm() < rs * rs) {
                free = false;
                break;
              }
            }
          }
        }
      }
      if (free) {
        x[i] = p;
        q[i] = random_rotation(rng);
        grid[(ci.z() * dims.y() + ci.y()) * dims.x() + ci.x()].push_back(static_cast<int>(i));
        placed = true;
      }
    }
    if (!placed) return false;
  }
  return true;
}

}  // namespace

RandomStart random_start(const Container& c, const std::vector<double>& rmax, double initial_scale,
                         std::uint64_t seed, std::vector<Eigen::Vector3d>& x,
                         std::vector<Eigen::Quaterniond>& q) {
  const std::size_t n = rmax.size();
  double bounding = 0.0;
  for (std::size_t i = 0; i < n; ++i) bounding += 4.0 / 3.0 * M_PI * std::pow(rmax[i], 3);
  bounding /= c.volume();
  double s0 = initial_scale > 0.0 ? initial_scale
                                  : std::min(kDefaultScale, std::cbrt(kBoundingFill / bounding));
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return rmax[a] > rmax[b]; });
  Rng rng(seed);
  x.assign(n, Eigen::Vector3d::Zero());
  q.assign(n, Eigen::Quaterniond::Identity());
  for (;;) {
    if (try_rsa(c, rmax, s0, order, rng, x, q)) return {true, s0};
    s0 *= kShrink;
    if (s0 < kSmallestScale) return {false, s0 / kShrink};
  }
}

}  // namespace graintwin::synth::detail
