#pragma once
// VTK XML PolyData (.vtp) files, the format ParaView opens for points with vectors (contacts,
// grain centroids with displacements), lines (branch vectors) and triangle surfaces (grains).
// Binary "appended raw" encoding with 64-bit headers: compact and exact (float64 values).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace graintwin::io {

/// A named data array: `components` values per point or cell, row-major.
struct VtkArray {
  std::string name;
  int components = 1;
  std::vector<double> values;
};

/// Cells are given as flat connectivity lists with end offsets (VTK's own layout): cell k uses
/// connectivity[offsets[k-1] .. offsets[k]) (offsets[-1] = 0). Cell data arrays hold one tuple per
/// cell in VTK's order: all verts, then all lines, then all polys.
struct VtkPolyData {
  std::vector<double> points;  ///< 3 per point, (x, y, z) in metres
  std::vector<std::int64_t> vert_connectivity, vert_offsets;
  std::vector<std::int64_t> line_connectivity, line_offsets;
  std::vector<std::int64_t> poly_connectivity, poly_offsets;
  std::vector<VtkArray> point_data;
  std::vector<VtkArray> cell_data;

  std::size_t point_count() const { return points.size() / 3; }
  std::size_t cell_count() const { return vert_offsets.size() + line_offsets.size() + poly_offsets.size(); }
  /// Appends a vertex cell per point in [first, last).
  void add_vertices(std::size_t first, std::size_t last);
  /// Appends a two-point line cell.
  void add_line(std::int64_t a, std::int64_t b);
  /// Appends a triangle cell.
  void add_triangle(std::int64_t a, std::int64_t b, std::int64_t c);
};

/// Checks the array sizes (UsageError on mismatch) and writes `path`.
void write_vtp(const std::filesystem::path& path, const VtkPolyData& data);

}  // namespace graintwin::io
