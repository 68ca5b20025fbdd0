#include "graintwin/mesh/grain_surface.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <map>

#include "graintwin/core/error.hpp"
#include "graintwin/core/filters.hpp"
#include "graintwin/shape/isosurface.hpp"

namespace graintwin::mesh {

TriangleSurface sh_surface(const shape::SphereMesh& sphere, const Eigen::MatrixXd& basis, const Eigen::VectorXd& coeffs,
                           const Eigen::Vector3d& centroid) {
  const Eigen::VectorXd r = basis * coeffs;
  TriangleSurface s;
  s.vertices = shape::displaced_vertices(sphere, r, centroid);
  s.triangles = sphere.triangles;
  return s;
}

TriangleSurface voxel_surface(const Volume<std::uint32_t>& labels, std::uint32_t label, const std::array<std::size_t, 6>& bbox,
                              double smooth_vox, int stride, bool preserve_volume) {
  if (stride < 1) throw UsageError("voxel_surface: the stride must be at least 1 voxel (got " + std::to_string(stride) + ")");
  // Zero all around, on the coarse grid too.
  const auto pad = static_cast<std::size_t>(std::max(2.0 + std::ceil(3.0 * smooth_vox), static_cast<double>(stride) + 1.0));
  Shape3 shape;
  std::array<long, 3> start;
  for (int a = 0; a < 3; ++a) {
    shape[static_cast<std::size_t>(a)] = bbox[static_cast<std::size_t>(a + 3)] - bbox[static_cast<std::size_t>(a)] + 2 * pad;
    start[static_cast<std::size_t>(a)] = static_cast<long>(bbox[static_cast<std::size_t>(a)]) - static_cast<long>(pad);
  }
  const Vec3& h = labels.voxel_size();
  Vec3 origin;
  for (int a = 0; a < 3; ++a)
    origin[static_cast<std::size_t>(a)] = labels.origin()[static_cast<std::size_t>(a)] +
                                          static_cast<double>(start[static_cast<std::size_t>(a)]) * h[static_cast<std::size_t>(a)];
  Volume<float> field(shape, h, origin, 0.0f);
  std::size_t voxels = 0;
  for (std::size_t z = pad; z + pad < shape[0]; ++z)
    for (std::size_t y = pad; y + pad < shape[1]; ++y)
      for (std::size_t x = pad; x + pad < shape[2]; ++x)
        if (labels(static_cast<std::size_t>(start[0]) + z, static_cast<std::size_t>(start[1]) + y,
                   static_cast<std::size_t>(start[2]) + x) == label)
          field(z, y, x) = 1.0f, ++voxels;
  if (smooth_vox > 0.0) gaussian_blur(field, smooth_vox);
  if (stride > 1) {  // every stride-th sample: the same field on a coarser grid, from the same origin
    const auto s = static_cast<std::size_t>(stride);
    Shape3 coarse_shape;
    for (std::size_t a = 0; a < 3; ++a) coarse_shape[a] = (shape[a] - 1) / s + 1;
    Volume<float> coarse(coarse_shape, {h[0] * double(s), h[1] * double(s), h[2] * double(s)}, origin, 0.0f);
    for (std::size_t z = 0; z < coarse_shape[0]; ++z)
      for (std::size_t y = 0; y < coarse_shape[1]; ++y)
        for (std::size_t x = 0; x < coarse_shape[2]; ++x) coarse(z, y, x) = field(z * s, y * s, x * s);
    field = std::move(coarse);
  }

  float iso = 0.5f;
  if (preserve_volume && voxels > 0) {
    // The enclosed volume falls as the level rises: bisect for the voxels' volume (to 0.1 %).
    const double target = static_cast<double>(voxels) * h[0] * h[1] * h[2];
    float lo = 0.05f, hi = 0.95f;
    for (int i = 0; i < 20; ++i) {
      const double v = shape::isosurface(field, iso).volume;
      if (std::abs(v / target - 1.0) < 1e-3) break;
      (v > target ? lo : hi) = iso;
      iso = 0.5f * (lo + hi);
    }
  }
  TriangleSurface s;
  std::map<std::array<double, 3>, int> index;  // exact positions: each crossing is computed identically
  const auto vertex = [&](const Eigen::Vector3d& p) {
    const auto [it, fresh] = index.try_emplace({p.x(), p.y(), p.z()}, static_cast<int>(s.vertices.size()));
    if (fresh) s.vertices.push_back(p);
    return it->second;
  };
  shape::isosurface(field, iso, [&](const shape::Triangle& t) {
    const int a = vertex(t[0]), b = vertex(t[1]), c = vertex(t[2]);
    if (a != b && b != c && c != a) s.triangles.push_back({a, b, c});
  });
  return s;
}

}  // namespace graintwin::mesh
