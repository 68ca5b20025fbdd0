#include "graintwin/io/vtk.hpp"

#include <fstream>

#include "graintwin/core/error.hpp"

namespace graintwin::io {
namespace {

/// Collects the binary blocks of the appended section and the offsets the XML refers to.
class Appended {
 public:
  template <class T>
  std::size_t add(const std::vector<T>& v) {
    const std::size_t at = bytes_.size();
    const std::uint64_t n = v.size() * sizeof(T);
    append(&n, sizeof n);
    append(v.data(), n);
    return at;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  void append(const void* p, std::size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  std::string bytes_;
};

std::string data_array(const std::string& type, const std::string& name, int components, std::size_t offset) {
  std::string s = "<DataArray type=\"" + type + "\"";
  if (!name.empty()) s += " Name=\"" + name + "\"";
  if (components > 1) s += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  return s + " format=\"appended\" offset=\"" + std::to_string(offset) + "\"/>\n";
}

void check_cells(const std::vector<std::int64_t>& conn, const std::vector<std::int64_t>& offsets, std::size_t points,
                 const char* what) {
  std::int64_t last = 0;
  for (std::int64_t o : offsets) {
    if (o < last || o > static_cast<std::int64_t>(conn.size()))
      throw UsageError(std::string("VTK ") + what + " offsets must rise and stay within the connectivity list");
    last = o;
  }
  if (last != static_cast<std::int64_t>(conn.size()))
    throw UsageError(std::string("VTK ") + what + " connectivity has entries beyond the last offset");
  for (std::int64_t c : conn)
    if (c < 0 || c >= static_cast<std::int64_t>(points))
      throw UsageError(std::string("VTK ") + what + " refer to a point that does not exist");
}

void check_arrays(const std::vector<VtkArray>& arrays, std::size_t tuples, const char* what) {
  for (const VtkArray& a : arrays)
    if (a.components < 1 || a.values.size() != tuples * static_cast<std::size_t>(a.components))
      throw UsageError("VTK " + std::string(what) + " array '" + a.name + "' has " + std::to_string(a.values.size()) +
                       " values for " + std::to_string(tuples) + " tuples of " + std::to_string(a.components));
}

/// The XML text and appended binary data of one VTK XML file with a single piece.
struct XmlPiece {
  explicit XmlPiece(std::string type) : type_(std::move(type)) {
    xml = "<?xml version=\"1.0\"?>\n<VTKFile type=\"" + type_ +
          "\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<" + type_ + ">\n";
  }
  void arrays(const char* tag, const std::vector<VtkArray>& list) {
    if (list.empty()) return;
    xml += std::string("<") + tag + ">\n";
    for (const VtkArray& a : list) xml += data_array("Float64", a.name, a.components, blob.add(a.values));
    xml += std::string("</") + tag + ">\n";
  }
  void points(const std::vector<double>& xyz) {
    xml += "<Points>\n" + data_array("Float64", "Points", 3, blob.add(xyz)) + "</Points>\n";
  }
  void write(const std::filesystem::path& path) {
    xml += "</Piece>\n</" + type_ + ">\n<AppendedData encoding=\"raw\">\n_";
    std::ofstream out(path, std::ios::binary);
    out << xml;
    out.write(blob.bytes().data(), static_cast<std::streamsize>(blob.bytes().size()));
    out << "\n</AppendedData>\n</VTKFile>\n";
    if (!out) throw DataError(path.string() + ": cannot write the VTK file; check that the folder is writable");
  }
  std::string xml;
  Appended blob;

 private:
  std::string type_;
};

}  // namespace

void VtkPolyData::add_vertices(std::size_t first, std::size_t last) {
  for (std::size_t p = first; p < last; ++p) {
    vert_connectivity.push_back(static_cast<std::int64_t>(p));
    vert_offsets.push_back(static_cast<std::int64_t>(vert_connectivity.size()));
  }
}

void VtkPolyData::add_line(std::int64_t a, std::int64_t b) {
  line_connectivity.insert(line_connectivity.end(), {a, b});
  line_offsets.push_back(static_cast<std::int64_t>(line_connectivity.size()));
}

void VtkPolyData::add_triangle(std::int64_t a, std::int64_t b, std::int64_t c) {
  poly_connectivity.insert(poly_connectivity.end(), {a, b, c});
  poly_offsets.push_back(static_cast<std::int64_t>(poly_connectivity.size()));
}

void write_vtp(const std::filesystem::path& path, const VtkPolyData& d) {
  if (d.points.size() % 3 != 0) throw UsageError("VTK points need 3 coordinates each");
  const std::size_t np = d.point_count();
  check_cells(d.vert_connectivity, d.vert_offsets, np, "verts");
  check_cells(d.line_connectivity, d.line_offsets, np, "lines");
  check_cells(d.poly_connectivity, d.poly_offsets, np, "polys");
  check_arrays(d.point_data, np, "point data");
  check_arrays(d.cell_data, d.cell_count(), "cell data");

  XmlPiece piece("PolyData");
  piece.xml += "<Piece NumberOfPoints=\"" + std::to_string(np) + "\" NumberOfVerts=\"" +
               std::to_string(d.vert_offsets.size()) + "\" NumberOfLines=\"" + std::to_string(d.line_offsets.size()) +
               "\" NumberOfStrips=\"0\" NumberOfPolys=\"" + std::to_string(d.poly_offsets.size()) + "\">\n";
  piece.arrays("PointData", d.point_data);
  piece.arrays("CellData", d.cell_data);
  piece.points(d.points);
  const auto cells = [&](const char* tag, const std::vector<std::int64_t>& conn, const std::vector<std::int64_t>& off) {
    piece.xml += std::string("<") + tag + ">\n" + data_array("Int64", "connectivity", 1, piece.blob.add(conn)) +
                 data_array("Int64", "offsets", 1, piece.blob.add(off)) + "</" + tag + ">\n";
  };
  cells("Verts", d.vert_connectivity, d.vert_offsets);
  cells("Lines", d.line_connectivity, d.line_offsets);
  cells("Polys", d.poly_connectivity, d.poly_offsets);
  piece.write(path);
}

void VtkUnstructuredGrid::add_cell(std::uint8_t type, std::initializer_list<std::int64_t> nodes) {
  connectivity.insert(connectivity.end(), nodes);
  offsets.push_back(static_cast<std::int64_t>(connectivity.size()));
  types.push_back(type);
}

void write_vtu(const std::filesystem::path& path, const VtkUnstructuredGrid& g) {
  if (g.points.size() % 3 != 0) throw UsageError("VTK points need 3 coordinates each");
  const std::size_t np = g.point_count();
  if (g.offsets.size() != g.types.size())
    throw UsageError("VTK unstructured grid needs one type per cell (" + std::to_string(g.types.size()) + " types for " +
                     std::to_string(g.offsets.size()) + " cells)");
  check_cells(g.connectivity, g.offsets, np, "cells");
  for (std::size_t k = 0; k < g.types.size(); ++k) {
    const std::int64_t nodes = g.offsets[k] - (k == 0 ? 0 : g.offsets[k - 1]);
    const std::int64_t want = g.types[k] == kVtkTriangle ? 3 : g.types[k] == kVtkTetra ? 4 : g.types[k] == kVtkQuadraticTetra ? 10 : -1;
    if (want < 0) throw UsageError("VTK cell type " + std::to_string(g.types[k]) + " is not one the writer supports (5, 10, 24)");
    if (nodes != want)
      throw UsageError("VTK cell " + std::to_string(k) + " of type " + std::to_string(g.types[k]) + " has " +
                       std::to_string(nodes) + " nodes instead of " + std::to_string(want));
  }
  check_arrays(g.point_data, np, "point data");
  check_arrays(g.cell_data, g.cell_count(), "cell data");

  XmlPiece piece("UnstructuredGrid");
  piece.xml += "<Piece NumberOfPoints=\"" + std::to_string(np) + "\" NumberOfCells=\"" +
               std::to_string(g.cell_count()) + "\">\n";
  piece.arrays("PointData", g.point_data);
  piece.arrays("CellData", g.cell_data);
  piece.points(g.points);
  piece.xml += "<Cells>\n" + data_array("Int64", "connectivity", 1, piece.blob.add(g.connectivity)) +
               data_array("Int64", "offsets", 1, piece.blob.add(g.offsets)) +
               data_array("UInt8", "types", 1, piece.blob.add(g.types)) + "</Cells>\n";
  piece.write(path);
}

}  // namespace graintwin::io
