#pragma once
// Binary STL (triangle soup with facet normals), read by gmsh, MeshLab and every CAD tool.
// Coordinates are written as given (GrainTwin writes metres; say so to tools that assume mm).
#include <array>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

namespace graintwin::io {

void write_stl(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& vertices,
               const std::vector<std::array<int, 3>>& triangles);

}  // namespace graintwin::io
