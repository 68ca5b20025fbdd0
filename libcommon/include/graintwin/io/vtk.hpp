#pragma once
// VTK XML PolyData (.vtp) files, the format ParaView opens for points with vectors (contacts,
// grain centroids with displacements), lines (branch vectors) and triangle surfaces (grains); and
// VTK XML UnstructuredGrid (.vtu) files for tetrahedral meshes (FDEM models and their frames).
// Binary "appended raw" encoding with 64-bit headers: compact and exact (float64 values).
#include <cstdint>
#include <filesystem>
#include <initializer_list>
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

/// VTK cell type codes used by the unstructured-grid writer.
inline constexpr std::uint8_t kVtkTriangle = 5, kVtkTetra = 10, kVtkQuadraticTetra = 24;

/// gmsh's 10-node tetrahedron (corners 0-3, mid-edge nodes of 01, 12, 20, 30, 32, 31) to VTK's
/// VTK_QUADRATIC_TETRA (corners, then 01, 12, 20, 03, 13, 23): VTK node k is gmsh node
/// kGmshToVtkTet10[k].
inline constexpr int kGmshToVtkTet10[10] = {0, 1, 2, 3, 4, 5, 6, 7, 9, 8};

/// An unstructured grid: cell k uses connectivity[offsets[k-1] .. offsets[k]) in VTK's node order
/// for its type (types[k]); point and cell data as for VtkPolyData.
struct VtkUnstructuredGrid {
  std::vector<double> points;  ///< 3 per point, (x, y, z) in metres
  std::vector<std::int64_t> connectivity, offsets;
  std::vector<std::uint8_t> types;
  std::vector<VtkArray> point_data;
  std::vector<VtkArray> cell_data;

  std::size_t point_count() const { return points.size() / 3; }
  std::size_t cell_count() const { return types.size(); }
  /// Appends a cell of `type` over `nodes` (already in VTK order).
  void add_cell(std::uint8_t type, std::initializer_list<std::int64_t> nodes);
};

/// Checks sizes and node counts per cell type (UsageError on mismatch) and writes `path` (.vtu).
void write_vtu(const std::filesystem::path& path, const VtkUnstructuredGrid& grid);

}  // namespace graintwin::io
