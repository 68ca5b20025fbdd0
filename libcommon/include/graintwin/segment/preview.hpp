#pragma once
// Overlay pictures of a segmentation: a grey slice with each grain tinted and the boundaries
// between labels drawn, for ct2labels --preview and the docs.
#include <cstdint>
#include <vector>

namespace graintwin::segment {

/// 8-bit RGB picture, rows top to bottom, (r, g, b) interleaved.
struct RgbImage {
  std::size_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};

/// One slice, `height` rows of `width` values each (row-major), grey mapped linearly from
/// [grey_lo, grey_hi] to black..white; a pixel of label l > 0 is blended 40 % with a colour fixed
/// by l (neighbouring labels get unrelated colours), and a pixel whose right or lower neighbour has
/// another label is drawn in that colour fully, so grains show their outlines.
RgbImage overlay_labels(const std::vector<float>& grey, const std::vector<std::uint32_t>& labels, std::size_t height,
                        std::size_t width, double grey_lo, double grey_hi);

/// Pictures side by side, top-aligned, `gap` white columns apart; the height is the tallest's.
RgbImage side_by_side(const std::vector<RgbImage>& images, std::size_t gap);

}  // namespace graintwin::segment
