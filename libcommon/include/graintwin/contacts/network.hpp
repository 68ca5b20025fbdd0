#pragma once
// The contact network as VTK polydata (io::write_vtp makes the .vtp that ParaView opens): one
// vertex per contact at its contact point, and one line per contact between the centroids of its
// two grains (the branch vector).
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "graintwin/core/volume.hpp"
#include "graintwin/io/vtk.hpp"

namespace graintwin::contacts {

/// One entry per contact in every vector (positions in metres, (x, y, z)).
struct ContactNetwork {
  std::vector<std::array<std::uint32_t, 2>> pairs;  ///< labels (low, high)
  std::vector<Vec3> points;                         ///< contact points
  std::vector<Vec3> normals;                        ///< unit normals, low -> high
  std::vector<std::array<Vec3, 2>> centroids;       ///< grain centroids of low and high
  /// Further per-contact values written as cell arrays (e.g. "area", "confidence").
  std::vector<std::pair<std::string, std::vector<double>>> values;
};

/// Points: the M contact points, then the centroid of each grain with a contact (once per grain,
/// by increasing label). Cells: M vertices (the contacts), then M lines (the branches).
/// Point data: "normal" (zero at the centroids, so a Glyph filter scaled by it draws arrows at the
/// contacts only) and "label" (0 at the contact points). Cell data, on vertices and lines alike:
/// "pair" (2 components), "normal", "kind" (0 = contact vertex, 1 = branch line) and `values`.
/// Throws UsageError when the vectors differ in length.
io::VtkPolyData network_polydata(const ContactNetwork& network);

}  // namespace graintwin::contacts
