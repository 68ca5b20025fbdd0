#include "graintwin/contacts/network.hpp"

#include <map>

#include "graintwin/core/error.hpp"

namespace graintwin::contacts {

io::VtkPolyData network_polydata(const ContactNetwork& net) {
  const std::size_t m = net.pairs.size();
  bool same = net.points.size() == m && net.normals.size() == m && net.centroids.size() == m;
  for (const auto& [name, v] : net.values) same = same && v.size() == m;
  if (!same) throw UsageError("network_polydata: every per-contact array must have one entry per contact");

  io::VtkPolyData d;
  io::VtkArray point_normal{"normal", 3, {}}, point_label{"label", 1, {}};
  for (std::size_t k = 0; k < m; ++k) {
    d.points.insert(d.points.end(), net.points[k].begin(), net.points[k].end());
    point_normal.values.insert(point_normal.values.end(), net.normals[k].begin(), net.normals[k].end());
    point_label.values.push_back(0.0);
  }
  d.add_vertices(0, m);
  // Each grain's centroid once, after the contact points.
  std::map<std::uint32_t, Vec3> centroid_of;
  for (std::size_t k = 0; k < m; ++k)
    for (int side = 0; side < 2; ++side) centroid_of.try_emplace(net.pairs[k][side], net.centroids[k][side]);
  std::map<std::uint32_t, std::int64_t> point_of;
  for (const auto& [label, c] : centroid_of) {
    point_of[label] = static_cast<std::int64_t>(d.point_count());
    d.points.insert(d.points.end(), c.begin(), c.end());
    point_normal.values.insert(point_normal.values.end(), 3, 0.0);
    point_label.values.push_back(label);
  }
  for (std::size_t k = 0; k < m; ++k) d.add_line(point_of.at(net.pairs[k][0]), point_of.at(net.pairs[k][1]));
  d.point_data = {point_normal, point_label};

  // Cell data in VTK's order: the vertices, then the lines; both carry the contact's values.
  io::VtkArray pair{"pair", 2, {}}, normal{"normal", 3, {}}, kind{"kind", 1, {}};
  std::vector<io::VtkArray> values;
  for (const auto& [name, v] : net.values) values.push_back({name, 1, {}});
  for (int cell_kind = 0; cell_kind < 2; ++cell_kind)
    for (std::size_t k = 0; k < m; ++k) {
      pair.values.insert(pair.values.end(), {static_cast<double>(net.pairs[k][0]), static_cast<double>(net.pairs[k][1])});
      normal.values.insert(normal.values.end(), net.normals[k].begin(), net.normals[k].end());
      kind.values.push_back(cell_kind);
      for (std::size_t a = 0; a < values.size(); ++a) values[a].values.push_back(net.values[a].second[k]);
    }
  d.cell_data = {pair, normal, kind};
  d.cell_data.insert(d.cell_data.end(), values.begin(), values.end());
  return d;
}

}  // namespace graintwin::contacts
