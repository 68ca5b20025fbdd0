#include "graintwin/segment/threshold.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/parallel.hpp"
#include "graintwin/segment/edt.hpp"

namespace graintwin::segment {
namespace {

constexpr std::size_t kFloatBins = 4096;

[[noreturn]] void throw_constant() {
  throw DataError("Otsu is undefined for a constant image; give --threshold");
}

/// Calls f(i) for the index i of every voxel whose centre lies inside `region`, from one OpenMP
/// thread per range of rows (call inside a parallel region: the rows are shared out with omp for).
template <class T, class F>
void for_each_inside(const Volume<T>& v, const Cylinder& region, F&& f) {
  const std::size_t rows = v.nz() * v.ny();
#pragma omp for schedule(static) nowait
  for (std::size_t row = 0; row < rows; ++row) {
    const std::size_t z = row / v.ny(), y = row % v.ny();
    const auto [first, last] = region.row_span(v, z, y);
    const std::size_t base = v.index(z, y, 0);
    for (std::size_t x = first; x < last; ++x) f(base + x);
  }
}

/// Histogram of the values inside `region`, summed over per-thread histograms (integer sums, so the
/// result is independent of the thread count). Integers: one bin per value. Floats: kFloatBins bins
/// between lo and lo + bins * width.
template <class T>
std::vector<std::uint64_t> region_histogram(const Volume<T>& v, const Cylinder& region, double lo = 0.0,
                                            double width = 1.0) {
  std::size_t bins = kFloatBins;
  if constexpr (std::is_integral_v<T>) bins = std::size_t{std::numeric_limits<T>::max()} + 1;
  std::vector<std::uint64_t> total(bins, 0);
  const T* d = v.data();
  // A histogram per thread: no more threads than processors (integer sums: the same for any team).
#pragma omp parallel num_threads(useful_threads(v.nz() * v.ny()))
  {
    std::vector<std::uint64_t> h(bins, 0);
    if constexpr (std::is_integral_v<T>) {
      for_each_inside(v, region, [&](std::size_t i) { ++h[d[i]]; });
    } else {
      for_each_inside(v, region, [&](std::size_t i) {
        ++h[std::min(static_cast<std::size_t>((static_cast<double>(d[i]) - lo) / width), bins - 1)];
      });
    }
#pragma omp critical
    for (std::size_t b = 0; b < bins; ++b) total[b] += h[b];
  }
  return total;
}

}  // namespace

double otsu_bin_edge(const std::vector<std::uint64_t>& histogram) {
  // Sums in long double (64-bit mantissa): the counts times bin indices of a 16-bit histogram of a
  // 10^10-voxel volume stay exact, and tied splits (same class sums) give bit-identical scores.
  long double total = 0.0L, total_moment = 0.0L;
  std::size_t nonempty = 0;
  for (std::size_t i = 0; i < histogram.size(); ++i) {
    total += static_cast<long double>(histogram[i]);
    total_moment += static_cast<long double>(histogram[i]) * static_cast<long double>(i);
    nonempty += histogram[i] > 0;
  }
  if (nonempty < 2) throw_constant();
  long double w0 = 0.0L, m0 = 0.0L, best = -1.0L;
  std::size_t first = 0, last = 0;
  bool in_tie = false;
  for (std::size_t k = 0; k + 1 < histogram.size(); ++k) {
    w0 += static_cast<long double>(histogram[k]);
    m0 += static_cast<long double>(histogram[k]) * static_cast<long double>(k);
    const long double w1 = total - w0;
    if (w0 == 0.0L || w1 == 0.0L) {
      in_tie = false;
      continue;
    }
    // Between-class variance times total^2: (total_moment * w0 - m0 * total)^2 / (w0 w1).
    const long double diff = total_moment * w0 - m0 * total;
    const long double score = diff * diff / (w0 * w1);
    if (score > best) {
      best = score;
      first = last = k;
      in_tie = true;
    } else if (in_tie && score == best) {
      last = k;
    } else {
      in_tie = false;
    }
  }
  // Split after bin k is the edge k + 1; the middle of the tied edges first+1 .. last+1.
  return 0.5 * static_cast<double>(first + last) + 1.0;
}

template <class T>
double otsu_threshold(const Volume<T>& grey) {
  return otsu_threshold(grey, Cylinder{0.0, 0.0, std::numeric_limits<double>::infinity()});
}

template <class T>
double otsu_threshold(const Volume<T>& grey, const Cylinder& region) {
  if (grey.empty()) throw DataError("cannot threshold an empty volume; check the input file");
  if constexpr (std::is_integral_v<T>) {
    // Bin i holds value i, i.e. the interval [i - 0.5, i + 0.5).
    return otsu_bin_edge(region_histogram(grey, region)) - 0.5;
  } else {
    const T* d = grey.data();
    std::size_t nan = 0, inf = 0;
    float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
#pragma omp parallel reduction(+ : nan, inf) reduction(min : lo) reduction(max : hi)
    for_each_inside(grey, region, [&](std::size_t i) {
      const float x = d[i];
      if (std::isnan(x)) {
        ++nan;
      } else if (std::isinf(x)) {
        ++inf;
      } else {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    });
    if (nan > 0)
      throw DataError("the volume holds " + std::to_string(nan) +
                      " NaN values; replace them (e.g. crop them away or cast with volconvert) before thresholding");
    if (inf > 0)
      throw DataError("the volume holds " + std::to_string(inf) +
                      " infinite values; replace them (e.g. crop them away or cast with volconvert) before thresholding");
    if (!(hi > lo)) throw_constant();
    const double width = (static_cast<double>(hi) - static_cast<double>(lo)) / kFloatBins;
    return static_cast<double>(lo) + width * otsu_bin_edge(region_histogram(grey, region, lo, width));
  }
}

template <class T>
Volume<std::uint8_t> binarise(const Volume<T>& grey, double threshold) {
  Volume<std::uint8_t> out(grey.shape(), grey.voxel_size(), grey.origin());
  const T* d = grey.data();
  std::uint8_t* o = out.data();
  const std::size_t n = grey.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) o[i] = static_cast<double>(d[i]) > threshold ? 1 : 0;
  return out;
}

void fill_holes(Volume<std::uint8_t>& mask) {
  const Shape3& s = mask.shape();
  if (mask.empty()) return;
  std::uint8_t* m = mask.data();
  constexpr std::uint8_t kReached = 2;  // background connected to the faces
  // Level-synchronous breadth-first search: only the current and the next front are stored.
  std::vector<std::size_t> front, next;
  const auto seed = [&](std::size_t z, std::size_t y, std::size_t x) {
    const std::size_t p = mask.index(z, y, x);
    if (m[p] == 0) {
      m[p] = kReached;
      front.push_back(p);
    }
  };
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x)
        if (z == 0 || y == 0 || x == 0 || z + 1 == s[0] || y + 1 == s[1] || x + 1 == s[2]) {
          seed(z, y, x);
        } else if (x == 1) {
          x = s[2] - 2;  // skip the interior of the row
        }
  // Neighbours by linear index without coordinates: a step that wraps across a row or a slice
  // lands on a face voxel, which the seeding above already settled (reached or solid), so only
  // the ends of the array need checks. This saves three integer divisions per voxel.
  const std::size_t sy = s[2], sz = s[1] * s[2], n = mask.size();
  while (!front.empty()) {
    for (std::size_t p : front) {
      const auto visit = [&](std::size_t q) {
        if (m[q] == 0) {
          m[q] = kReached;
          next.push_back(q);
        }
      };
      if (p >= 1) visit(p - 1);
      if (p + 1 < n) visit(p + 1);
      if (p >= sy) visit(p - sy);
      if (p + sy < n) visit(p + sy);
      if (p >= sz) visit(p - sz);
      if (p + sz < n) visit(p + sz);
    }
    front.swap(next);
    next.clear();
  }
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) m[i] = m[i] == kReached ? 0 : 1;
}

void binary_open(Volume<std::uint8_t>& mask, double radius_vox) {
  if (!(radius_vox > 0.0) || mask.empty()) return;
  const Vec3 unit{1.0, 1.0, 1.0};
  const auto r2 = static_cast<float>(radius_vox * radius_vox);
  std::uint8_t* m = mask.data();
  const std::size_t n = mask.size();
  // Erosion: p stays solid iff no background voxel lies within the ball, i.e. d^2(p, bg) > r^2.
  // Squared distances in voxel units are integers, exact in float up to 2^24.
  {
    const Volume<float> d2 = squared_distance_transform(mask, unit, false);
    const float* d = d2.data();
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i) m[i] = d[i] > r2 ? 0 : 1;  // 0 marks the eroded set
  }
  // Dilation of the eroded set: the transform above gives each voxel its distance to the nearest
  // eroded voxel (the eroded set is now the "background" of the mask).
  const Volume<float> d2 = squared_distance_transform(mask, unit, false);
  const float* d = d2.data();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) m[i] = d[i] <= r2 ? 1 : 0;
}

template double otsu_threshold(const Volume<std::uint8_t>&);
template double otsu_threshold(const Volume<std::uint16_t>&);
template double otsu_threshold(const Volume<float>&);
template double otsu_threshold(const Volume<std::uint8_t>&, const Cylinder&);
template double otsu_threshold(const Volume<std::uint16_t>&, const Cylinder&);
template double otsu_threshold(const Volume<float>&, const Cylinder&);
template Volume<std::uint8_t> binarise(const Volume<std::uint8_t>&, double);
template Volume<std::uint8_t> binarise(const Volume<std::uint16_t>&, double);
template Volume<std::uint8_t> binarise(const Volume<float>&, double);

}  // namespace graintwin::segment
