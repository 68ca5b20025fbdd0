#include "graintwin/core/volume_ops.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/core/strings.hpp"

namespace graintwin {

namespace {
long parse_bound(const std::string& s, long fallback, std::size_t n, const std::string& text) {
  const std::string t = trim(s);
  if (t.empty()) return fallback;
  std::size_t used = 0;
  long v = 0;
  try {
    v = std::stol(t, &used);
  } catch (...) {
    used = 0;
  }
  if (used != t.size())
    throw UsageError("--crop '" + text + "': '" + s + "' is not an integer index; use z0:z1,y0:y1,x0:x1");
  if (v < 0) v += static_cast<long>(n);
  return std::clamp(v, 0L, static_cast<long>(n));
}
}  // namespace

CropBox parse_crop(const std::string& text, const Shape3& shape) {
  const auto axes = split(text, ',');
  if (axes.size() != 3)
    throw UsageError("--crop '" + text + "' needs three ranges z0:z1,y0:y1,x0:x1 (empty bounds allowed)");
  CropBox box;
  static const char* names[3] = {"z", "y", "x"};
  for (int a = 0; a < 3; ++a) {
    const auto lim = split(axes[a], ':');
    if (lim.size() != 2)
      throw UsageError("--crop '" + text + "': range '" + axes[a] + "' must look like begin:end");
    box.begin[a] = static_cast<std::size_t>(parse_bound(lim[0], 0, shape[a], text));
    box.end[a] = static_cast<std::size_t>(parse_bound(lim[1], static_cast<long>(shape[a]), shape[a], text));
    if (box.end[a] <= box.begin[a])
      throw UsageError("--crop '" + text + "' selects nothing along " + names[a] + " (size " +
                       std::to_string(shape[a]) + ")");
  }
  return box;
}

template <class T>
Volume<T> crop(const Volume<T>& v, const CropBox& box) {
  const Shape3 s{box.end[0] - box.begin[0], box.end[1] - box.begin[1], box.end[2] - box.begin[2]};
  Vec3 origin = v.origin();
  for (int a = 0; a < 3; ++a) origin[a] += static_cast<double>(box.begin[a]) * v.voxel_size()[a];
  Volume<T> out(s, v.voxel_size(), origin);
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y) {
      const T* src = &v(z + box.begin[0], y + box.begin[1], box.begin[2]);
      std::copy(src, src + s[2], &out(z, y, 0));
    }
  return out;
}

AnyVolume crop(const AnyVolume& v, const CropBox& box) {
  return std::visit([&](const auto& vol) -> AnyVolume { return crop(vol, box); }, v);
}

template <class T>
Volume<T> downsample_mean(const Volume<T>& v, std::size_t n) {
  if (n == 0) throw UsageError("--downsample must be at least 1");
  const Shape3 s{v.nz() / n, v.ny() / n, v.nx() / n};
  if (s[0] == 0 || s[1] == 0 || s[2] == 0)
    throw UsageError("--downsample " + std::to_string(n) + " is larger than the volume (" +
                     std::to_string(v.nz()) + " x " + std::to_string(v.ny()) + " x " +
                     std::to_string(v.nx()) + ")");
  Vec3 vs = v.voxel_size(), origin = v.origin();
  for (int a = 0; a < 3; ++a) {
    origin[a] += 0.5 * static_cast<double>(n - 1) * vs[a];
    vs[a] *= static_cast<double>(n);
  }
  Volume<T> out(s, vs, origin);
  const double inv = 1.0 / static_cast<double>(n * n * n);
#pragma omp parallel for schedule(static)
  for (std::size_t z = 0; z < s[0]; ++z)
    for (std::size_t y = 0; y < s[1]; ++y)
      for (std::size_t x = 0; x < s[2]; ++x) {
        double sum = 0.0;
        for (std::size_t dz = 0; dz < n; ++dz)
          for (std::size_t dy = 0; dy < n; ++dy) {
            const T* row = &v(z * n + dz, y * n + dy, x * n);
            for (std::size_t dx = 0; dx < n; ++dx) sum += static_cast<double>(row[dx]);
          }
        const double mean = sum * inv;
        if constexpr (std::is_floating_point_v<T>)
          out(z, y, x) = static_cast<T>(mean);
        else
          out(z, y, x) = static_cast<T>(std::llround(mean));
      }
  return out;
}

AnyVolume downsample_mean(const AnyVolume& v, std::size_t n) {
  return std::visit([&](const auto& vol) -> AnyVolume { return downsample_mean(vol, n); }, v);
}

namespace {
template <class To, class From>
Volume<To> cast_to(const Volume<From>& v, std::size_t& clamped) {
  Volume<To> out(v.shape(), v.voxel_size(), v.origin());
  std::size_t count = 0;
  const From* src = v.data();
  To* dst = out.data();
  const std::size_t n = v.size();
  for (std::size_t i = 0; i < n; ++i) {
    if constexpr (std::is_floating_point_v<To>) {
      dst[i] = static_cast<To>(src[i]);
    } else {
      const double x = static_cast<double>(src[i]);
      constexpr double lo = static_cast<double>(std::numeric_limits<To>::lowest());
      constexpr double hi = static_cast<double>(std::numeric_limits<To>::max());
      if (std::isnan(x)) {
        dst[i] = To{0};
        ++count;
      } else if (x < lo || x > hi) {
        dst[i] = static_cast<To>(x < lo ? lo : hi);
        ++count;
      } else {
        dst[i] = static_cast<To>(std::nearbyint(x));
      }
    }
  }
  clamped = count;
  return out;
}
}  // namespace

AnyVolume cast(const AnyVolume& v, DType to, std::size_t* clamped) {
  std::size_t count = 0;
  AnyVolume out = std::visit(
      [&](const auto& vol) -> AnyVolume {
        switch (to) {
          case DType::uint8: return cast_to<std::uint8_t>(vol, count);
          case DType::uint16: return cast_to<std::uint16_t>(vol, count);
          case DType::uint32: return cast_to<std::uint32_t>(vol, count);
          case DType::float32: return cast_to<float>(vol, count);
        }
        return cast_to<float>(vol, count);
      },
      v);
  if (clamped) *clamped = count;
  return out;
}

template <class T>
ValueRange value_range(const T* values, std::size_t n) {
  ValueRange r;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
  std::size_t bad = 0;
#pragma omp parallel for reduction(min : lo) reduction(max : hi) reduction(+ : sum, bad)
  for (std::size_t i = 0; i < n; ++i) {
    const double x = static_cast<double>(values[i]);
    if (!std::isfinite(x)) {
      ++bad;
      continue;
    }
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    sum += x;
  }
  r.non_finite = bad;
  if (n > bad) {
    r.min = lo;
    r.max = hi;
    r.mean = sum / static_cast<double>(n - bad);
  }
  return r;
}

ValueRange value_range(const AnyVolume& v) {
  return std::visit([](const auto& vol) { return value_range(vol.data(), vol.size()); }, v);
}

#define GRAINTWIN_INSTANTIATE(T)                                     \
  template Volume<T> crop(const Volume<T>&, const CropBox&);         \
  template Volume<T> downsample_mean(const Volume<T>&, std::size_t); \
  template ValueRange value_range(const T*, std::size_t);
GRAINTWIN_INSTANTIATE(std::uint8_t)
GRAINTWIN_INSTANTIATE(std::uint16_t)
GRAINTWIN_INSTANTIATE(std::uint32_t)
GRAINTWIN_INSTANTIATE(float)
#undef GRAINTWIN_INSTANTIATE

}  // namespace graintwin
