#include "graintwin/segment/flood.hpp"

#include <algorithm>
#include <cmath>

namespace graintwin::segment::detail {

LevelMap make_level_map(const Volume<float>& edt) {
  const Vec3& vs = edt.voxel_size();
  const double unit = std::min({vs[0], vs[1], vs[2]});
  const float* f = edt.data();
  const std::size_t n = edt.size();
  float dmax = 0.0f;
#pragma omp parallel for schedule(static) reduction(max : dmax)
  for (std::size_t i = 0; i < n; ++i)
    if (f[i] < std::numeric_limits<float>::infinity()) dmax = std::max(dmax, f[i]);
  const double dmax_vox2 = std::max(1.0, std::pow(static_cast<double>(dmax) / unit, 2));
  // 8 levels per squared voxel, fewer if the deepest distance would overflow the level budget.
  const double per_unit2 = std::min(8.0, (LevelMap::kMaxLevels - 2) / dmax_vox2);
  LevelMap m;
  m.scale = per_unit2 / (unit * unit);
  // One more level than the deepest finite distance needs, for +infinity (no background at all).
  m.count = static_cast<std::uint32_t>(dmax_vox2 * per_unit2 + 0.5) + 2;
  return m;
}

}  // namespace graintwin::segment::detail
