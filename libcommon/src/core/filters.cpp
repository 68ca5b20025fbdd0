#include "graintwin/core/filters.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "graintwin/core/error.hpp"

namespace graintwin {

void gaussian_blur(Volume<float>& v, double sigma_vox) {
  // NaN would make the kernel radius an undefined conversion (a crash, not an error).
  if (!std::isfinite(sigma_vox)) throw UsageError("the blur sigma must be a finite number of voxels");
  if (sigma_vox <= 0.0) return;
  const int radius = static_cast<int>(std::ceil(3.0 * sigma_vox));
  std::vector<double> w(2 * radius + 1);
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k) sum += w[k + radius] = std::exp(-0.5 * k * k / (sigma_vox * sigma_vox));
  for (auto& x : w) x /= sum;
  const Shape3 s = v.shape();
  const std::size_t strides[3] = {s[1] * s[2], s[2], 1};
  for (int axis = 0; axis < 3; ++axis) {
    const std::size_t n = s[axis];
    if (n < 2) continue;
    const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;
    const std::size_t lines = s[a1] * s[a2];
#pragma omp parallel
    {
      std::vector<float> line(n), blurred(n);
#pragma omp for schedule(static)
      for (std::size_t l = 0; l < lines; ++l) {
        const std::size_t base = (l / s[a2]) * strides[a1] + (l % s[a2]) * strides[a2];
        for (std::size_t i = 0; i < n; ++i) line[i] = v.values()[base + i * strides[axis]];
        for (std::size_t i = 0; i < n; ++i) {
          double acc = 0.0;
          for (int k = -radius; k <= radius; ++k) {
            const long j = std::clamp(static_cast<long>(i) + k, 0L, static_cast<long>(n) - 1);
            acc += w[k + radius] * line[static_cast<std::size_t>(j)];
          }
          blurred[i] = static_cast<float>(acc);
        }
        for (std::size_t i = 0; i < n; ++i) v.values()[base + i * strides[axis]] = blurred[i];
      }
    }
  }
}

}  // namespace graintwin
