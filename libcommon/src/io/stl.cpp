#include "graintwin/io/stl.hpp"

#include <Eigen/Geometry>
#include <cstring>
#include <fstream>

#include "graintwin/core/error.hpp"

namespace graintwin::io {

void write_stl(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& v,
               const std::vector<std::array<int, 3>>& triangles) {
  std::ofstream out(path, std::ios::binary);
  char header[80] = {};
  std::strncpy(header, "graintwin binary STL, metres", sizeof header - 1);
  out.write(header, sizeof header);
  const auto count = static_cast<std::uint32_t>(triangles.size());
  out.write(reinterpret_cast<const char*>(&count), 4);
  for (const auto& t : triangles) {
    for (int k : t)
      if (k < 0 || static_cast<std::size_t>(k) >= v.size()) throw UsageError("write_stl: a triangle refers to a missing vertex");
    const Eigen::Vector3d& a = v[static_cast<std::size_t>(t[0])];
    const Eigen::Vector3d& b = v[static_cast<std::size_t>(t[1])];
    const Eigen::Vector3d& c = v[static_cast<std::size_t>(t[2])];
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    float rec[12];
    for (int k = 0; k < 3; ++k) {
      rec[k] = static_cast<float>(n[k]);
      rec[3 + k] = static_cast<float>(a[k]);
      rec[6 + k] = static_cast<float>(b[k]);
      rec[9 + k] = static_cast<float>(c[k]);
    }
    const std::uint16_t attr = 0;
    out.write(reinterpret_cast<const char*>(rec), sizeof rec);
    out.write(reinterpret_cast<const char*>(&attr), 2);
  }
  if (!out) throw DataError(path.string() + ": cannot write the STL file; check that the folder is writable");
}

}  // namespace graintwin::io
