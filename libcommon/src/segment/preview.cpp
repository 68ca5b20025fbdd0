#include "graintwin/segment/preview.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "graintwin/core/error.hpp"

namespace graintwin::segment {
namespace {

/// A saturated colour for label l: the golden-ratio walk around the hue circle spreads consecutive
/// labels (which are spatial neighbours in raster order) far apart.
std::array<double, 3> label_colour(std::uint32_t l) {
  const double hue = std::fmod(static_cast<double>(l) * 0.618033988749895, 1.0) * 6.0;
  const double f = hue - std::floor(hue);
  const double v = 1.0, s = 0.85;
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (static_cast<int>(hue)) {
    case 0: return {v, t, p};
    case 1: return {q, v, p};
    case 2: return {p, v, t};
    case 3: return {p, q, v};
    case 4: return {t, p, v};
    default: return {v, p, q};
  }
}

}  // namespace

RgbImage overlay_labels(const std::vector<float>& grey, const std::vector<std::uint32_t>& labels, std::size_t height,
                        std::size_t width, double grey_lo, double grey_hi) {
  if (grey.size() != height * width || labels.size() != height * width)
    throw UsageError("overlay_labels: the grey and label slices must both hold height x width values");
  RgbImage out{width, height, std::vector<std::uint8_t>(3 * width * height)};
  const double span = grey_hi > grey_lo ? grey_hi - grey_lo : 1.0;
  for (std::size_t y = 0; y < height; ++y)
    for (std::size_t x = 0; x < width; ++x) {
      const std::size_t i = y * width + x;
      const double g = std::clamp((static_cast<double>(grey[i]) - grey_lo) / span, 0.0, 1.0);
      const std::uint32_t l = labels[i];
      const bool edge = (x + 1 < width && labels[i + 1] != l) || (y + 1 < height && labels[i + width] != l);
      std::array<double, 3> c{g, g, g};
      if (l != 0) {
        const auto lc = label_colour(l);
        const double a = edge ? 1.0 : 0.4;
        for (int k = 0; k < 3; ++k) c[k] = (1 - a) * g + a * lc[k];
      } else if (edge) {
        c = {1.0, 1.0, 1.0};  // the outline of a grain against the void
      }
      for (int k = 0; k < 3; ++k) out.rgb[3 * i + k] = static_cast<std::uint8_t>(std::lround(255.0 * c[k]));
    }
  return out;
}

RgbImage side_by_side(const std::vector<RgbImage>& images, std::size_t gap) {
  RgbImage out;
  for (const RgbImage& im : images) {
    out.width += im.width;
    out.height = std::max(out.height, im.height);
  }
  if (!images.empty()) out.width += gap * (images.size() - 1);
  out.rgb.assign(3 * out.width * out.height, 255);
  std::size_t x0 = 0;
  for (const RgbImage& im : images) {
    for (std::size_t y = 0; y < im.height; ++y)
      std::copy_n(im.rgb.begin() + static_cast<std::ptrdiff_t>(3 * y * im.width), 3 * im.width,
                  out.rgb.begin() + static_cast<std::ptrdiff_t>(3 * (y * out.width + x0)));
    x0 += im.width + gap;
  }
  return out;
}

}  // namespace graintwin::segment
