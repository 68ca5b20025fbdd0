#include "graintwin/segment/edt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "graintwin/core/error.hpp"

namespace graintwin::segment {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Columns gathered per work item in the y and z passes: 16 floats = one 64-byte cache line per row,
// so the strided passes read whole lines instead of one float per line.
constexpr std::size_t kBlock = 16;

/// Workspace of the 1-D envelope for lines of up to n samples (plus two virtual border sites).
struct Envelope {
  std::vector<long> site;    // positions of the parabolas in the envelope
  std::vector<double> value; // f(site)
  std::vector<double> key;   // f(site) + a2 * site^2, reused in every intersection
  std::vector<double> left;  // left end of each parabola's interval in the envelope
  explicit Envelope(std::size_t n) : site(n + 2), value(n + 2), key(n + 2), left(n + 3) {}
};

/// d[q] = min_i a2 (q - i)^2 + f[i] over the finite f[i] (and the virtual zero sites at -1 and n
/// when the border is background). f and d may alias: f is fully read before d is written.
void envelope_1d(const float* f, float* d, long n, double a2, bool border_bg, Envelope& w, bool take_sqrt) {
  long k = -1;
  const auto add = [&](long q, double fq) {
    const double key = fq + a2 * static_cast<double>(q) * static_cast<double>(q);
    double s = -std::numeric_limits<double>::infinity();
    while (k >= 0) {
      s = (key - w.key[k]) / (2.0 * a2 * static_cast<double>(q - w.site[k]));
      if (s > w.left[k]) break;
      --k;  // parabola k is hidden below the new one and its predecessor
    }
    ++k;
    w.site[k] = q;
    w.value[k] = fq;
    w.key[k] = key;
    w.left[k] = k == 0 ? -std::numeric_limits<double>::infinity() : s;
  };
  if (border_bg) add(-1, 0.0);
  for (long q = 0; q < n; ++q)
    if (f[q] < kInf) add(q, f[q]);
  if (border_bg) add(n, 0.0);
  if (k < 0) {
    std::fill(d, d + n, kInf);
    return;
  }
  // f is no longer needed once every site's key is stored: d may now overwrite it.
  long j = 0;
  for (long q = 0; q < n; ++q) {
    while (j < k && w.left[j + 1] < static_cast<double>(q)) ++j;
    const double dq = static_cast<double>(q - w.site[j]);
    const double v = a2 * dq * dq + w.value[j];
    d[q] = static_cast<float>(take_sqrt ? std::sqrt(v) : v);
  }
}

/// First pass along x: squared distance to the nearest background voxel of the same row.
void pass_x(const std::uint8_t* mask, float* out, const Shape3& s, double a2, bool border_bg) {
  const std::size_t nx = s[2], rows = s[0] * s[1];
#pragma omp parallel for schedule(static)
  for (std::size_t r = 0; r < rows; ++r) {
    const std::uint8_t* m = mask + r * nx;
    float* o = out + r * nx;
    // Forward: distance (in voxels) to the last background voxel at or before x.
    long last = border_bg ? -1 : std::numeric_limits<long>::min() / 2;
    for (std::size_t x = 0; x < nx; ++x) {
      if (m[x] == 0) last = static_cast<long>(x);
      const long dist = static_cast<long>(x) - last;
      o[x] = dist > static_cast<long>(nx) ? kInf : static_cast<float>(dist);
    }
    // Backward: the nearer of that and the next background voxel after x.
    long next = border_bg ? static_cast<long>(nx) : std::numeric_limits<long>::max() / 2;
    for (std::size_t x = nx; x-- > 0;) {
      if (m[x] == 0) next = static_cast<long>(x);
      const long dist = next - static_cast<long>(x);
      const float fwd = o[x];
      const float best = dist > static_cast<long>(nx) ? fwd : std::min(fwd, static_cast<float>(dist));
      o[x] = best == kInf ? kInf : static_cast<float>(a2 * static_cast<double>(best) * static_cast<double>(best));
    }
  }
}

/// Pass along y (axis 1) or z (axis 0): the 1-D envelope on every line, lines gathered kBlock at a
/// time along the contiguous x axis.
void pass_strided(float* data, const Shape3& s, int axis, double a2, bool border_bg, bool take_sqrt) {
  const std::size_t n = s[axis], nx = s[2];
  const std::size_t stride = axis == 1 ? nx : s[1] * nx;
  // The remaining (outer) axis: z for the y pass, y for the z pass.
  const std::size_t outer = axis == 1 ? s[0] : s[1];
  const std::size_t outer_stride = axis == 1 ? s[1] * nx : nx;
  const std::size_t blocks = (nx + kBlock - 1) / kBlock;
  const std::size_t items = outer * blocks;
#pragma omp parallel
  {
    std::vector<float> buf(kBlock * n);
    Envelope w(n);
#pragma omp for schedule(static)
    for (std::size_t it = 0; it < items; ++it) {
      const std::size_t o = it / blocks, x0 = (it % blocks) * kBlock;
      const std::size_t bw = std::min(kBlock, nx - x0);
      float* base = data + o * outer_stride + x0;
      for (std::size_t i = 0; i < n; ++i) {
        const float* row = base + i * stride;
        for (std::size_t b = 0; b < bw; ++b) buf[b * n + i] = row[b];
      }
      for (std::size_t b = 0; b < bw; ++b) {
        float* line = buf.data() + b * n;
        envelope_1d(line, line, static_cast<long>(n), a2, border_bg, w, take_sqrt);
      }
      for (std::size_t i = 0; i < n; ++i) {
        float* row = base + i * stride;
        for (std::size_t b = 0; b < bw; ++b) row[b] = buf[b * n + i];
      }
    }
  }
}

Volume<float> transform(const Volume<std::uint8_t>& mask, const Vec3& spacing, bool border_bg, bool take_sqrt) {
  for (double a : spacing)
    if (!(a > 0.0) || !std::isfinite(a))
      throw UsageError("the distance transform needs positive voxel sizes; set the volume's voxel_size");
  Volume<float> out(mask.shape(), mask.voxel_size(), mask.origin());
  if (mask.empty()) return out;
  const Shape3& s = mask.shape();
  pass_x(mask.data(), out.data(), s, spacing[2] * spacing[2], border_bg);
  pass_strided(out.data(), s, 1, spacing[1] * spacing[1], border_bg, false);
  pass_strided(out.data(), s, 0, spacing[0] * spacing[0], border_bg, take_sqrt);
  return out;
}

}  // namespace

Volume<float> squared_distance_transform(const Volume<std::uint8_t>& mask, const Vec3& spacing,
                                         bool border_is_background) {
  return transform(mask, spacing, border_is_background, false);
}

Volume<float> distance_transform(const Volume<std::uint8_t>& mask, bool border_is_background) {
  return transform(mask, mask.voxel_size(), border_is_background, true);
}

}  // namespace graintwin::segment
