#include "graintwin/segment/denoise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "graintwin/core/error.hpp"

namespace graintwin::segment {
namespace {

/// A compare-exchange of the selection network: slot a receives the minimum, slot b the maximum;
/// when only one of them is used later, only that one is computed.
struct Op {
  std::uint8_t a, b;
  bool need_min, need_max;
};

/// The median-of-27 selection network: Batcher's odd-even merge sort of 32 wires (27 values plus
/// 5 wires of +inf), with the comparators on constant wires folded away and every comparator that
/// does not influence rank 13 pruned. Evaluated on whole image rows at once, it runs as branch-free
/// min/max over arrays, which the compiler vectorises.
struct MedianNetwork {
  std::vector<Op> ops;
  std::uint8_t output = 0;  ///< slot holding the median at the end

  MedianNetwork() {
    constexpr int n = 32, values = 27, rank = 13;
    // wire -> slot holding its value, or -1 for the constant +inf.
    std::array<int, n> slot{};
    for (int w = 0; w < n; ++w) slot[w] = w < values ? w : -1;
    std::vector<std::pair<int, int>> cmp;  // real comparators on slots, in order
    for (int p = 1; p < n; p <<= 1)
      for (int k = p; k >= 1; k >>= 1)
        for (int j = k % p; j + k < n; j += 2 * k)
          for (int i = 0; i < std::min(k, n - j - k); ++i) {
            if ((i + j) / (2 * p) != (i + j + k) / (2 * p)) continue;
            const int lo = i + j, hi = i + j + k;  // lo receives the minimum
            if (slot[hi] < 0) continue;            // max(x, inf) = inf stays on hi: nothing to do
            if (slot[lo] < 0) {                    // the value moves down, the inf up
              std::swap(slot[lo], slot[hi]);
              continue;
            }
            cmp.push_back({slot[lo], slot[hi]});
          }
    output = static_cast<std::uint8_t>(slot[rank]);
    // Backwards: keep a comparator if one of its outputs is still needed; then both inputs are.
    std::array<bool, values> needed{};
    needed[output] = true;
    std::vector<Op> kept;
    for (auto it = cmp.rbegin(); it != cmp.rend(); ++it) {
      const auto [a, b] = *it;
      if (!needed[a] && !needed[b]) continue;
      kept.push_back({static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b), needed[a], needed[b]});
      needed[a] = needed[b] = true;
    }
    ops.assign(kept.rbegin(), kept.rend());
  }
};

const MedianNetwork& median_network() {
  static const MedianNetwork net;
  return net;
}

// Rows are processed in chunks of this many voxels so that the 27 slot arrays stay in L1 cache.
constexpr std::size_t kChunk = 256;

}  // namespace

template <class T>
Volume<T> median3(const Volume<T>& grey) {
  const Shape3& s = grey.shape();
  const std::size_t n = grey.size();
  const T* in = grey.data();
  if constexpr (std::is_floating_point_v<T>) {
    std::size_t nan = 0;
#pragma omp parallel for schedule(static) reduction(+ : nan)
    for (std::size_t i = 0; i < n; ++i) nan += std::isnan(in[i]);
    if (nan > 0)
      throw DataError("the volume holds " + std::to_string(nan) +
                      " NaN values, which have no median; replace them before denoising");
  }
  Volume<T> out(s, grey.voxel_size(), grey.origin());
  if (out.empty()) return out;
  T* o = out.data();
  const MedianNetwork& net = median_network();
  const long nz = static_cast<long>(s[0]), ny = static_cast<long>(s[1]), nx = static_cast<long>(s[2]);
#pragma omp parallel
  {
    std::vector<T> buffer(27 * kChunk);
    std::array<T*, 27> slot;
    for (int k = 0; k < 27; ++k) slot[k] = buffer.data() + k * kChunk;
#pragma omp for schedule(static)
    for (long z = 0; z < nz; ++z)
      for (long y = 0; y < ny; ++y) {
        // The nine rows (z-1..z+1) x (y-1..y+1) feeding output row (z, y), clamped at the faces.
        std::array<const T*, 9> rows;
        for (int dz = -1, r = 0; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy, ++r)
            rows[r] = in + (std::clamp(z + dz, 0L, nz - 1) * ny + std::clamp(y + dy, 0L, ny - 1)) * nx;
        for (long x0 = 0; x0 < nx; x0 += static_cast<long>(kChunk)) {
          const long w = std::min(static_cast<long>(kChunk), nx - x0);
          for (int r = 0; r < 9; ++r)
            for (long i = 0; i < w; ++i) {
              const long x = x0 + i;
              slot[3 * r][i] = rows[r][x > 0 ? x - 1 : 0];
              slot[3 * r + 1][i] = rows[r][x];
              slot[3 * r + 2][i] = rows[r][x + 1 < nx ? x + 1 : nx - 1];
            }
          for (const Op& op : net.ops) {
            T* __restrict a = slot[op.a];
            T* __restrict b = slot[op.b];
            if (op.need_min && op.need_max) {
              for (long i = 0; i < w; ++i) {
                const T lo = std::min(a[i], b[i]), hi = std::max(a[i], b[i]);
                a[i] = lo;
                b[i] = hi;
              }
            } else if (op.need_min) {
              for (long i = 0; i < w; ++i) a[i] = std::min(a[i], b[i]);
            } else {
              for (long i = 0; i < w; ++i) b[i] = std::max(a[i], b[i]);
            }
          }
          std::copy(slot[net.output], slot[net.output] + w, o + (z * ny + y) * nx + x0);
        }
      }
  }
  return out;
}

template Volume<std::uint8_t> median3(const Volume<std::uint8_t>&);
template Volume<std::uint16_t> median3(const Volume<std::uint16_t>&);
template Volume<float> median3(const Volume<float>&);

namespace {

std::vector<float> gaussian_weights(double sigma_vox) {
  const int radius = static_cast<int>(std::ceil(3.0 * sigma_vox));
  std::vector<double> w(2 * static_cast<std::size_t>(radius) + 1);
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k) sum += w[k + radius] = std::exp(-0.5 * k * k / (sigma_vox * sigma_vox));
  std::vector<float> out;
  for (double x : w) out.push_back(static_cast<float>(x / sum));
  return out;
}

/// out[x] = sum_k w[k] rows[clamp(i + k - r)][x] for the rows of one line of rows (a plane's rows
/// along y, or a column of rows along z): every term is a whole row, so the loop vectorises.
void blur_rows(const float* rows, std::size_t count, std::size_t width, std::size_t i, const std::vector<float>& w,
               float* out) {
  const long r = static_cast<long>(w.size() / 2);
  std::fill(out, out + width, 0.0f);
  for (long k = -r; k <= r; ++k) {
    const auto j = static_cast<std::size_t>(std::clamp(static_cast<long>(i) + k, 0L, static_cast<long>(count) - 1));
    const float wk = w[static_cast<std::size_t>(k + r)];
    const float* row = rows + j * width;
    for (std::size_t x = 0; x < width; ++x) out[x] += wk * row[x];
  }
}

}  // namespace

template <class T>
Volume<T> gaussian_smooth(Volume<T> grey, double sigma_vox) {
  if (!(sigma_vox > 0.0) || grey.empty()) return grey;
  const std::vector<float> w = gaussian_weights(sigma_vox);
  const long r = static_cast<long>(w.size() / 2);
  const std::size_t nz = grey.nz(), ny = grey.ny(), nx = grey.nx(), plane = ny * nx;
  // Float work volume: the scan itself when it is float, else a float copy filled by the x pass.
  Volume<float> copy;
  if constexpr (!std::is_same_v<T, float>) copy = Volume<float>(grey.shape(), grey.voxel_size(), grey.origin());
  float* f = nullptr;
  if constexpr (std::is_same_v<T, float>) f = grey.data();
  else f = copy.data();
  const T* g = grey.data();
#pragma omp parallel
  {
    // x: each row padded by its edge values on both sides, then a dot product per voxel.
    std::vector<float> padded(nx + 2 * static_cast<std::size_t>(r));
#pragma omp for schedule(static)
    for (std::size_t row = 0; row < nz * ny; ++row) {
      const T* in = g + row * nx;
      for (long x = -r; x < static_cast<long>(nx) + r; ++x)
        padded[static_cast<std::size_t>(x + r)] = static_cast<float>(in[std::clamp(x, 0L, static_cast<long>(nx) - 1)]);
      float* out = f + row * nx;
      for (std::size_t x = 0; x < nx; ++x) {
        float acc = 0.0f;
        for (std::size_t k = 0; k < w.size(); ++k) acc += w[k] * padded[x + k];
        out[x] = acc;
      }
    }
    // y: a copy of each plane, its rows combined whole.
    std::vector<float> buffer(std::max(plane, nz * nx));
#pragma omp for schedule(static)
    for (std::size_t z = 0; z < nz; ++z) {
      float* p = f + z * plane;
      std::copy(p, p + plane, buffer.begin());
      for (std::size_t y = 0; y < ny; ++y) blur_rows(buffer.data(), ny, nx, y, w, p + y * nx);
    }
    // z: for each y, the rows (z, y) of all planes gathered, then combined whole.
#pragma omp for schedule(static)
    for (std::size_t y = 0; y < ny; ++y) {
      for (std::size_t z = 0; z < nz; ++z) std::copy_n(f + z * plane + y * nx, nx, buffer.begin() + z * nx);
      for (std::size_t z = 0; z < nz; ++z) blur_rows(buffer.data(), nz, nx, z, w, f + z * plane + y * nx);
    }
    if constexpr (!std::is_same_v<T, float>) {
      T* o = grey.data();
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < grey.size(); ++i) o[i] = static_cast<T>(std::lround(f[i]));  // within the input range
    }
  }
  return grey;
}

template Volume<std::uint8_t> gaussian_smooth(Volume<std::uint8_t>, double);
template Volume<std::uint16_t> gaussian_smooth(Volume<std::uint16_t>, double);
template Volume<float> gaussian_smooth(Volume<float>, double);

}  // namespace graintwin::segment
