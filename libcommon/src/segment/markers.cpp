#include "graintwin/segment/markers.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/flood.hpp"

namespace graintwin::segment {
namespace {

constexpr float kMinusInf = -std::numeric_limits<float>::infinity();

double smallest_voxel(const Volume<float>& v) {
  const Vec3& s = v.voxel_size();
  return std::min({s[0], s[1], s[2]});
}

/// Splits the neighbour steps into those before and those after the voxel in raster order.
std::pair<std::vector<NeighbourStep>, std::vector<NeighbourStep>> halves(const std::vector<NeighbourStep>& all) {
  const auto mid = all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2);
  return {{all.begin(), mid}, {mid, all.end()}};
}

/// One bit per voxel (the maxima flags: an eighth of a byte per voxel instead of a byte). Bits are
/// set with atomic OR, so threads may share a word at the edge of their slices.
class BitVolume {
 public:
  explicit BitVolume(std::size_t n) : words_((n + 63) / 64, 0) {}
  bool get(std::size_t i) const { return (words_[i >> 6] >> (i & 63)) & 1u; }
  void set_atomic(std::size_t i) {
    std::atomic_ref<std::uint64_t>(words_[i >> 6]).fetch_or(std::uint64_t{1} << (i & 63), std::memory_order_relaxed);
  }
  void clear(std::size_t i) { words_[i >> 6] &= ~(std::uint64_t{1} << (i & 63)); }

 private:
  std::vector<std::uint64_t> words_;
};

/// Reconstruction by dilation of (edt - h) under edt over the solid (edt > 0); background gets -inf
/// so it never raises a solid voxel. Vincent's hybrid algorithm: a raster and an anti-raster scan
/// settle most voxels (on sphere packings all of them), a FIFO finishes those that the scans'
/// directions could not reach.
Volume<float> reconstruct_h(const Volume<float>& edt, float h, Connectivity c) {
  const Shape3& s = edt.shape();
  const std::size_t n = edt.size();
  const float* f = edt.data();
  Volume<float> rec(s, edt.voxel_size(), edt.origin());
  float* r = rec.data();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) r[i] = f[i] > 0.0f ? f[i] - h : kMinusInf;
  const std::vector<NeighbourStep> all = neighbour_steps(c, s);
  const auto [before, after] = halves(all);
  std::size_t p = 0;
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x, ++p) {
        if (!(f[p] > 0.0f)) continue;
        float m = r[p];
        for_each_neighbour(before, s, z, y, x, p, [&](std::size_t q) { m = std::max(m, r[q]); });
        r[p] = std::min(m, f[p]);
      }
  std::deque<std::size_t> fifo;
  for (std::size_t z = s[0]; z-- > 0;)
    for (std::size_t y = s[1]; y-- > 0;)
      for (std::size_t x = s[2]; x-- > 0;) {
        p = rec.index(z, y, x);
        if (!(f[p] > 0.0f)) continue;
        float m = r[p];
        for_each_neighbour(after, s, z, y, x, p, [&](std::size_t q) { m = std::max(m, r[q]); });
        const float rp = r[p] = std::min(m, f[p]);
        // p must propagate further if a later solid neighbour could still be raised by it (the
        // background, -inf under a ceiling of 0, must not count: it would pass 0 on to the solid).
        bool pending = false;
        for_each_neighbour(after, s, z, y, x, p,
                           [&](std::size_t q) { pending |= (r[q] < rp) & (r[q] < f[q]) & (f[q] > 0.0f); });
        if (pending) fifo.push_back(p);
      }
  const IndexSplitter split(s);
  while (!fifo.empty()) {
    p = fifo.front();
    fifo.pop_front();
    const float rp = r[p];
    for_each_neighbour(all, s, split, p, [&](std::size_t q) {
      if (r[q] < rp && r[q] < f[q] && f[q] > 0.0f) {
        r[q] = std::min(rp, f[q]);
        fifo.push_back(q);
      }
    });
  }
  return rec;
}

/// The voxels of the regional maxima of `relief` (plateaus with no strictly higher neighbour)
/// among the solid voxels (edt > 0). Background must be lower in `relief` than every solid voxel.
/// The result does not depend on the order of evaluation, hence not on threads.
BitVolume regional_maxima(const float* relief, const Volume<float>& edt, Connectivity c) {
  const Shape3& s = edt.shape();
  const float* f = edt.data();
  const std::vector<NeighbourStep> steps = neighbour_steps(c, s);
  BitVolume flag(edt.size());
  // A voxel with a higher neighbour is not a maximum.
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y) {
      std::size_t p = edt.index(z, y, 0);
      for (std::size_t x = 0; x < s[2]; ++x, ++p) {
        if (!(f[p] > 0.0f)) continue;
        const float v = relief[p];
        bool higher = false;
        for_each_neighbour(steps, s, z, y, x, p, [&](std::size_t q) { higher |= relief[q] > v; });
        if (!higher) flag.set_atomic(p);
      }
    }
  // Nor is any voxel of a plateau that holds such a voxel: flood those plateaus from their edges.
  std::vector<std::vector<std::size_t>> seeds_per_z(s[0]);
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y) {
      std::size_t p = edt.index(z, y, 0);
      for (std::size_t x = 0; x < s[2]; ++x, ++p) {
        if (!flag.get(p)) continue;
        bool lower_edge = false;
        for_each_neighbour(steps, s, z, y, x, p, [&](std::size_t q) {
          lower_edge |= !flag.get(q) && f[q] > 0.0f && relief[q] == relief[p];
        });
        if (lower_edge) seeds_per_z[z].push_back(p);
      }
    }
  std::vector<std::size_t> stack;
  for (const auto& seeds : seeds_per_z)
    for (std::size_t p : seeds) {
      flag.clear(p);
      stack.push_back(p);
    }
  const IndexSplitter split(s);
  while (!stack.empty()) {
    const std::size_t p = stack.back();
    stack.pop_back();
    for_each_neighbour(steps, s, split, p, [&](std::size_t q) {
      if (flag.get(q) && relief[q] == relief[p]) {
        flag.clear(q);
        stack.push_back(q);
      }
    });
  }
  return flag;
}

/// Labels the connected components of the flagged voxels 1..K in raster order of their first
/// voxel (appended to first_voxels if given). Returns K.
std::uint32_t label_flagged(const BitVolume& flag, Volume<std::uint32_t>& labels, Connectivity c,
                            std::vector<std::size_t>* first_voxels = nullptr) {
  const Shape3& s = labels.shape();
  const std::vector<NeighbourStep> steps = neighbour_steps(c, s);
  std::uint32_t* l = labels.data();
  std::uint32_t k = 0;
  std::vector<std::size_t> stack;
  const IndexSplitter split(s);
  for (std::size_t p = 0; p < labels.size(); ++p) {
    if (!flag.get(p) || l[p] != 0) continue;
    if (k == detail::kMaxLabel)
      throw DataError("more than 2147483647 markers; the volume is too noisy to segment, smooth it first");
    l[p] = ++k;
    if (first_voxels) first_voxels->push_back(p);
    stack.push_back(p);
    while (!stack.empty()) {
      const std::size_t a = stack.back();
      stack.pop_back();
      for_each_neighbour(steps, s, split, a, [&](std::size_t q) {
        if (flag.get(q) && l[q] == 0) {
          l[q] = k;
          stack.push_back(q);
        }
      });
    }
  }
  return k;
}

/// The median of inscribed radii weighted by r^3 (the grain volume they stand for), as d50 is a
/// median by mass: noise specks and membrane fragments, each a deep maximum one voxel high, may
/// outnumber the grains but hold almost none of the solid. 0 if empty.
double volume_weighted_median(std::vector<float> radii) {
  std::sort(radii.begin(), radii.end());
  double total = 0.0;
  for (float r : radii) total += std::pow(static_cast<double>(r), 3);
  double below = 0.0;
  for (float r : radii) {
    below += std::pow(static_cast<double>(r), 3);
    if (below >= 0.5 * total) return r;
  }
  return 0.0;
}

void check_radius(double expected_radius_m) {
  if (!(expected_radius_m >= 0.0) || !std::isfinite(expected_radius_m))
    throw UsageError("the expected grain radius must be a finite length >= 0 (0 = estimate it)");
}

void check_h(double h_vox, const char* what) {
  if (!(h_vox >= 0.0) || !std::isfinite(h_vox))
    throw UsageError(std::string(what) + " must be a finite number of voxels >= 0; give e.g. 0.5");
}

}  // namespace

Volume<std::uint32_t> h_maxima_markers(const Volume<float>& edt, double h_vox, Connectivity c) {
  check_h(h_vox, "h");
  const auto h = static_cast<float>(h_vox * smallest_voxel(edt));
  BitVolume flag(0);
  if (h > 0.0f) {
    const Volume<float> rec = reconstruct_h(edt, h, c);
    flag = regional_maxima(rec.data(), edt, c);
  } else {
    flag = regional_maxima(edt.data(), edt, c);
  }
  // The reconstruction is released before the labels are allocated: they never coexist.
  Volume<std::uint32_t> labels(edt.shape(), edt.voxel_size(), edt.origin());
  label_flagged(flag, labels, c);
  return labels;
}

Volume<std::uint32_t> peak_markers(const Volume<float>& edt, double min_distance_vox, Connectivity c) {
  check_h(min_distance_vox, "the minimum peak distance");
  const Shape3& s = edt.shape();
  const float* f = edt.data();
  const std::vector<NeighbourStep> steps = neighbour_steps(c, s);
  std::vector<std::vector<std::size_t>> per_z(s[0]);
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y) {
      std::size_t p = edt.index(z, y, 0);
      for (std::size_t x = 0; x < s[2]; ++x, ++p) {
        if (!(f[p] > 0.0f)) continue;
        bool higher = false;
        for_each_neighbour(steps, s, z, y, x, p, [&](std::size_t q) { higher |= f[q] > f[p]; });
        if (!higher) per_z[z].push_back(p);
      }
    }
  std::vector<std::size_t> cand;
  for (auto& v : per_z) cand.insert(cand.end(), v.begin(), v.end());
  std::sort(cand.begin(), cand.end(), [&](std::size_t a, std::size_t b) { return f[a] > f[b] || (f[a] == f[b] && a < b); });

  // Accepted peaks are hashed into cells of the minimum distance, so a candidate checks 27 cells.
  const Vec3& vs = edt.voxel_size();
  const double dmin = min_distance_vox * smallest_voxel(edt);
  const double cell = std::max(dmin, smallest_voxel(edt));
  const auto cell_of = [&](std::size_t z, std::size_t y, std::size_t x) {
    return std::array<long, 3>{static_cast<long>(z * vs[0] / cell), static_cast<long>(y * vs[1] / cell),
                               static_cast<long>(x * vs[2] / cell)};
  };
  // Cells -1 .. 2^21 - 2 per axis get distinct keys; beyond that, shared keys only cost extra checks.
  const auto key = [](long a, long b, long c3) {
    const auto bits = [](long v) { return static_cast<std::uint64_t>(v + 1) & 0x1FFFFFu; };
    return bits(a) << 42 | bits(b) << 21 | bits(c3);
  };
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> grid;
  std::vector<std::size_t> accepted;
  const IndexSplitter split(s);
  for (std::size_t p : cand) {
    std::size_t z, y, x;
    split.split(p, z, y, x);
    const auto cz = cell_of(z, y, x);
    bool near = false;
    for (long a = -1; a <= 1 && !near; ++a)
      for (long b = -1; b <= 1 && !near; ++b)
        for (long d = -1; d <= 1 && !near; ++d) {
          const auto it = grid.find(key(cz[0] + a, cz[1] + b, cz[2] + d));
          if (it == grid.end()) continue;
          for (std::size_t q : it->second) {
            std::size_t qz, qy, qx;
            split.split(q, qz, qy, qx);
            const double ddz = (static_cast<double>(qz) - static_cast<double>(z)) * vs[0],
                         ddy = (static_cast<double>(qy) - static_cast<double>(y)) * vs[1],
                         ddx = (static_cast<double>(qx) - static_cast<double>(x)) * vs[2];
            if (ddz * ddz + ddy * ddy + ddx * ddx < dmin * dmin) {
              near = true;
              break;
            }
          }
        }
    if (near) continue;
    accepted.push_back(p);
    grid[key(cz[0], cz[1], cz[2])].push_back(p);
  }
  std::sort(accepted.begin(), accepted.end());
  Volume<std::uint32_t> labels(s, edt.voxel_size(), edt.origin());
  for (std::size_t i = 0; i < accepted.size(); ++i) labels.values()[accepted[i]] = static_cast<std::uint32_t>(i + 1);
  return labels;
}

MaximaDynamics maxima_dynamics(const Volume<float>& edt, Connectivity c, Volume<std::uint32_t>* basins) {
  MaximaDynamics out;
  out.unit = smallest_voxel(edt);
  Volume<std::uint32_t> labels(edt.shape(), edt.voxel_size(), edt.origin());
  const std::uint32_t k = label_flagged(regional_maxima(edt.data(), edt, c), labels, c, &out.first_voxel);
  const float* f = edt.data();
  out.peak.resize(k);
  for (std::uint32_t i = 0; i < k; ++i) out.peak[i] = f[out.first_voxel[i]];
  out.saddle.assign(k, kMinusInf);
  out.absorbed_by.assign(k, 0);

  // Saddles by union-find over the maxima while flooding down from all of them: when two basins
  // first touch, the one with the lower peak dies there (ties: the larger label dies). A contact
  // counts only once both voxels are at or above the flood level: labels are handed out when a
  // voxel enters the queue, so a labelled neighbour may still lie far below the flood, and its
  // value would understate the saddle (and overstate the dynamic); that pair is seen again when
  // the lower voxel leaves the queue.
  std::vector<std::uint32_t> parent(k + 1);
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  const detail::LevelMap levels = detail::make_level_map(edt);
  const auto meet = [&](std::size_t p, std::size_t q, std::uint32_t lp, std::uint32_t lq, std::uint32_t level) {
    std::uint32_t a = find(lp), b = find(lq);  // the small union-find tables first: mostly a == b
    if (a == b || levels(f[q]) < level) return;
    const auto peak_of = [&](std::uint32_t l) { return out.peak[l - 1]; };
    if (peak_of(a) > peak_of(b) || (peak_of(a) == peak_of(b) && a < b)) std::swap(a, b);  // a is the loser
    out.saddle[a - 1] = std::min(f[p], f[q]);
    out.absorbed_by[a - 1] = b;
    parent[a] = b;
  };
  if (edt.size() < (std::size_t{1} << 32))
    detail::priority_flood<std::uint32_t>(edt, labels.data(), c, levels, meet);
  else
    detail::priority_flood<std::uint64_t>(edt, labels.data(), c, levels, meet);
  if (basins) *basins = std::move(labels);
  return out;
}

Volume<std::uint32_t> watershed_from_dynamics(Volume<std::uint32_t> basins, const MaximaDynamics& d, double h_vox) {
  check_h(h_vox, "h");
  const auto h = static_cast<float>(h_vox * d.unit);
  const std::size_t k = d.peak.size();
  // Absorbers have higher peaks (ties: smaller labels), so in that order each absorber's final
  // label is known before the basins it absorbed ask for it.
  std::vector<std::uint32_t> order(k);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return d.peak[a] > d.peak[b] || (d.peak[a] == d.peak[b] && a < b);
  });
  std::vector<std::uint32_t> joins(k + 1, 0);  // the marker maximum each basin ends in; 0 -> 0
  for (std::uint32_t i : order) {
    // The same float arithmetic as the reconstruction (edt - h), so both find the same markers.
    const bool marker = d.saddle[i] < d.peak[i] - h;
    joins[i + 1] = marker ? i + 1 : joins[d.absorbed_by[i]];
  }
  // Markers numbered in the order of their maxima (raster order of their first voxels).
  std::vector<std::uint32_t> number(k + 1, 0);
  std::uint32_t markers = 0;
  for (std::uint32_t l = 1; l <= k; ++l)
    if (joins[l] == l) number[l] = ++markers;
  std::vector<std::uint32_t> final_label(k + 1, 0);
  for (std::uint32_t l = 1; l <= k; ++l) final_label[l] = number[joins[l]];
  std::uint32_t* b = basins.data();
  const std::size_t n = basins.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) b[i] = final_label[b[i]];
  return basins;
}

HProposal propose_h(const MaximaDynamics& d, double expected_radius_m) {
  check_radius(expected_radius_m);
  const double unit = d.unit;
  const std::size_t k = d.peak.size();
  HProposal out;
  out.regional_maxima = k;
  if (expected_radius_m > 0.0) {
    out.reference_radius_m = expected_radius_m;
  } else {
    out.radius_estimated = true;
    // Finite peaks only: a solid region without any background has an infinite distance.
    std::vector<float> deep, finite;
    for (std::size_t i = 0; i < k; ++i)
      if (std::isfinite(d.peak[i])) {
        finite.push_back(d.peak[i]);
        if (d.dynamic(i) > unit) deep.push_back(d.peak[i]);
      }
    if (deep.empty()) deep = std::move(finite);
    out.reference_radius_m = volume_weighted_median(std::move(deep));
  }

  // A maximum whose inscribed ball is smaller than a fragment cannot stand for a grain (its basin
  // is merged or removed with the fragments), so it does not count: noise specks and membrane
  // pieces, isolated and hence of infinite dynamic, would otherwise inflate N(h) at every h and
  // with it the 1 % tolerance of the plateau.
  const double smallest_peak = std::cbrt(kFragmentVolumeShare) * out.reference_radius_m;
  std::vector<double> dyn_vox;
  dyn_vox.reserve(k);
  for (std::size_t i = 0; i < k; ++i)
    if (d.peak[i] >= smallest_peak) dyn_vox.push_back(d.dynamic(i) / unit);
  std::sort(dyn_vox.begin(), dyn_vox.end());
  const auto count_above = [&](double h) {
    return static_cast<std::size_t>(dyn_vox.end() - std::upper_bound(dyn_vox.begin(), dyn_vox.end(), h));
  };
  constexpr double kLowest = 0.5, kStep = 1.0905077326652577;  // 2^(1/8)
  const double hi = std::max(kLowest, 0.5 * out.reference_radius_m / unit);
  std::vector<double> grid{kLowest};
  while (grid.back() * kStep <= hi) grid.push_back(grid.back() * kStep);
  std::vector<std::size_t> count(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) count[i] = count_above(grid[i]);
  // Widest window [a, b] of the grid with count[a] - count[b] <= 1 % of count[a] (counts fall with
  // h, so the window condition only needs its two ends); two pointers, ties to the smaller a.
  std::size_t best_a = 0, best_b = 0;
  for (std::size_t a = 0, b = 0; a < grid.size(); ++a) {
    b = std::max(a, b);
    while (b + 1 < grid.size() && static_cast<double>(count[a] - count[b + 1]) <= 0.01 * static_cast<double>(count[a])) ++b;
    if (b - a > best_b - best_a) {
      best_a = a;
      best_b = b;
    }
  }
  // A window narrower than a quarter octave is no plateau (a count that keeps falling still has
  // steps where it pauses, most often where few markers are left): h stays at the floor, where the
  // fragment merge can still join what is split, while nothing joins what is merged.
  out.plateau_found = best_b - best_a >= 2;
  if (!out.plateau_found) best_b = best_a = 0;
  out.plateau_lo_vox = grid[best_a];
  out.plateau_hi_vox = grid[best_b];
  out.markers_at_lo = count[best_a];
  out.markers_at_hi = count[best_b];
  out.h_vox = std::sqrt(grid[best_a] * grid[best_b]);
  out.markers = count_above(out.h_vox);
  return out;
}

HProposal propose_h(const Volume<float>& edt, double expected_radius_m, Connectivity c) {
  check_radius(expected_radius_m);
  return propose_h(maxima_dynamics(edt, c), expected_radius_m);
}

}  // namespace graintwin::segment
