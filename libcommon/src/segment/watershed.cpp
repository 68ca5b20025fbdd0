#include "graintwin/segment/watershed.hpp"

#include <algorithm>

#include "graintwin/core/error.hpp"
#include "graintwin/segment/flood.hpp"

namespace graintwin::segment {

Volume<std::uint32_t> watershed(const Volume<float>& edt, Volume<std::uint32_t> markers, Connectivity c) {
  if (markers.shape() != edt.shape())
    throw UsageError("the markers and the distance map differ in shape; compute both from the same mask");
  const std::uint32_t* m = markers.data();
  const std::size_t n = markers.size();
  std::uint32_t largest = 0;
#pragma omp parallel for schedule(static) reduction(max : largest)
  for (std::size_t i = 0; i < n; ++i) largest = std::max(largest, m[i]);
  if (largest > detail::kMaxLabel)
    throw UsageError("marker labels above 2147483647 are not supported; relabel the markers sequentially from 1");
  const detail::LevelMap levels = detail::make_level_map(edt);
  const auto no_meet = [](std::size_t, std::size_t, std::uint32_t, std::uint32_t, std::uint32_t) {};
  if (edt.size() < (std::size_t{1} << 32))
    detail::priority_flood<std::uint32_t>(edt, markers.data(), c, levels, no_meet);
  else
    detail::priority_flood<std::uint64_t>(edt, markers.data(), c, levels, no_meet);
  markers.set_voxel_size(edt.voxel_size());
  markers.set_origin(edt.origin());
  return markers;
}

}  // namespace graintwin::segment
