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

}  // namespace graintwin::segment
