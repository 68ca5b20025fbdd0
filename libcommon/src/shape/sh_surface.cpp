#include "graintwin/shape/sh_surface.hpp"

#include <Eigen/Geometry>
#include <map>

#include "graintwin/core/error.hpp"

namespace graintwin::shape {

SphereMesh icosphere(int subdivisions) {
  if (subdivisions < 0 || subdivisions > 8) throw UsageError("icosphere subdivisions must be 0..8");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  SphereMesh m;
  for (const auto& v : std::vector<Eigen::Vector3d>{{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}})
    m.directions.push_back(v.normalized());
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    const auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      m.directions.push_back((m.directions[static_cast<std::size_t>(a)] + m.directions[static_cast<std::size_t>(b)]).normalized());
      return midpoint[key] = static_cast<int>(m.directions.size() - 1);
    };
    std::vector<std::array<int, 3>> next;
    next.reserve(4 * m.triangles.size());
    for (const auto& [a, b, c] : m.triangles) {
      const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      next.push_back({a, ab, ca});
      next.push_back({b, bc, ab});
      next.push_back({c, ca, bc});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  return m;
}

std::vector<Eigen::Vector3d> displaced_vertices(const SphereMesh& mesh, const Eigen::VectorXd& radii,
                                                const Eigen::Vector3d& centre) {
  if (radii.size() != static_cast<Eigen::Index>(mesh.directions.size()))
    throw UsageError("displaced_vertices needs one radius per mesh direction");
  std::vector<Eigen::Vector3d> v(mesh.directions.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = centre + radii[static_cast<Eigen::Index>(i)] * mesh.directions[i];
  return v;
}

}  // namespace graintwin::shape
