#pragma once
// Whole-volume operations used by volconvert and later stages: crop, block-mean downsampling,
// casting, value range.
#include <optional>
#include <string>

#include "graintwin/core/volume.hpp"

namespace graintwin {

/// Half-open index ranges [begin, end) per axis, in (z, y, x) order.
struct CropBox {
  Shape3 begin{0, 0, 0};
  Shape3 end{0, 0, 0};
};

/// Parses "z0:z1,y0:y1,x0:x1" (Python slice style; an empty bound means the volume edge, negative
/// bounds count from the end) against `shape`. Throws UsageError on a malformed or empty box.
CropBox parse_crop(const std::string& text, const Shape3& shape);

/// Copies the box out of `v`; the origin moves so that physical positions are unchanged.
template <class T>
Volume<T> crop(const Volume<T>& v, const CropBox& box);
AnyVolume crop(const AnyVolume& v, const CropBox& box);

/// Block mean over n x n x n blocks (partial blocks at the far edges are dropped, as their mean
/// would mix fewer voxels). Integer types are rounded to nearest. Voxel size grows by n and the
/// origin moves to the centre of the first block.
template <class T>
Volume<T> downsample_mean(const Volume<T>& v, std::size_t n);
AnyVolume downsample_mean(const AnyVolume& v, std::size_t n);

/// Converts to another element type: float to integer rounds to nearest and clamps to the target
/// range; `clamped` (if given) receives the number of values that had to be clamped.
AnyVolume cast(const AnyVolume& v, DType to, std::size_t* clamped = nullptr);

struct ValueRange {
  double min = 0.0;
  double max = 0.0;
  double mean = 0.0;
  std::size_t non_finite = 0;  ///< NaN or Inf values (float volumes only); excluded from min/max
};
template <class T>
ValueRange value_range(const T* values, std::size_t n);
ValueRange value_range(const AnyVolume& v);

}  // namespace graintwin
