#include "graintwin/fdem/primitives.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"

namespace graintwin::fdem {
namespace {

/// Outward faces of a positively oriented tetrahedron (0, 1, 2, 3), as local corner indices.
constexpr std::array<std::array<int, 3>, 4> kOutwardFaces{{{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}};

std::array<std::uint32_t, 3> sorted(std::array<std::uint32_t, 3> f) {
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace

TetMesh box_mesh(const Eigen::Vector3d& size, double element_size) {
  if (!(size.minCoeff() > 0) || !(element_size > 0))
    throw UsageError("a box needs positive sizes and a positive element size");
  Eigen::Array3i cells;
  for (int k = 0; k < 3; ++k) cells[k] = std::max(1, static_cast<int>(std::ceil(size[k] / element_size - 1e-9)));
  const Eigen::Array3i points = cells + 1;
  TetMesh m;
  for (int k = 0; k < points[2]; ++k)
    for (int j = 0; j < points[1]; ++j)
      for (int i = 0; i < points[0]; ++i)
        m.nodes.emplace_back(size[0] * (double(i) / cells[0] - 0.5), size[1] * (double(j) / cells[1] - 0.5),
                             size[2] * (double(k) / cells[2] - 0.5));
  const auto id = [&](int i, int j, int k) { return static_cast<std::uint32_t>(i + points[0] * (j + points[1] * k)); };
  // Kuhn: one tetrahedron per order in which the axes are walked from corner 000 to corner 111.
  constexpr std::array<std::array<int, 3>, 6> kOrders{{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (int k = 0; k < cells[2]; ++k)
    for (int j = 0; j < cells[1]; ++j)
      for (int i = 0; i < cells[0]; ++i)
        for (const auto& order : kOrders) {
          std::array<std::uint32_t, 4> t;
          Eigen::Array3i c(i, j, k);
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            c[order[s]] += 1;
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          const Eigen::Vector3d &p0 = m.nodes[t[0]], &p1 = m.nodes[t[1]], &p2 = m.nodes[t[2]], &p3 = m.nodes[t[3]];
          if ((p1 - p0).cross(p2 - p0).dot(p3 - p0) < 0) std::swap(t[1], t[2]);
          m.tets.push_back(t);
        }
  return m;
}

std::uint32_t add_grain(Model& model, const TetMesh& mesh, const Eigen::Vector3d& offset, GrainKind kind,
                        std::uint32_t material, std::uint32_t label) {
  if (material >= model.materials.size())
    throw UsageError("grain label " + std::to_string(label) + " names material " + std::to_string(material) +
                     " but the model has " + std::to_string(model.materials.size()));
  const auto grain_index = static_cast<std::uint32_t>(model.grains.size());
  Grain g;
  g.label = label;
  g.kind = kind;
  g.material = material;
  g.node_begin = static_cast<std::uint32_t>(model.nodes.size());
  g.element_begin = static_cast<std::uint32_t>(model.element_count());
  g.triangle_begin = static_cast<std::uint32_t>(model.triangles.size());
  for (const Eigen::Vector3d& p : mesh.nodes) model.nodes.push_back(p + offset);
  const bool quadratic = kind == GrainKind::tet10;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> edge_node;  // global corner ids, low first
  const auto mid_node = [&](std::uint32_t a, std::uint32_t b) {
    const auto key = std::minmax(a, b);
    auto [it, fresh] = edge_node.try_emplace({key.first, key.second}, static_cast<std::uint32_t>(model.nodes.size()));
    if (fresh) model.nodes.push_back(0.5 * (model.nodes[a] + model.nodes[b]));
    return it->second;
  };
  std::map<std::array<std::uint32_t, 3>, std::pair<int, std::array<std::uint32_t, 3>>> faces;  // sorted -> (uses, oriented)
  std::vector<std::array<std::uint32_t, 10>> element_nodes;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    std::array<std::uint32_t, 10> n{};
    for (int a = 0; a < 4; ++a) {
      if (mesh.tets[t][a] >= mesh.nodes.size())
        throw DataError("tetrahedron " + std::to_string(t) + " of grain label " + std::to_string(label) + " uses a missing node");
      n[a] = g.node_begin + mesh.tets[t][a];
    }
    const Eigen::Vector3d& p0 = model.nodes[n[0]];
    const double six_volume = (model.nodes[n[1]] - p0).cross(model.nodes[n[2]] - p0).dot(model.nodes[n[3]] - p0);
    if (!(six_volume > 0))
      throw DataError("tetrahedron " + std::to_string(t) + " of grain label " + std::to_string(label) +
                      " is flat or inverted; remesh the grain");
    if (quadratic)
      for (int k = 0; k < 6; ++k) n[4 + k] = mid_node(n[kTet10Edges[k][0]], n[kTet10Edges[k][1]]);
    element_nodes.push_back(n);
    for (const auto& f : kOutwardFaces) {
      const std::array<std::uint32_t, 3> oriented{n[f[0]], n[f[1]], n[f[2]]};
      auto& entry = faces[sorted(oriented)];
      ++entry.first;
      entry.second = oriented;
    }
  }
  for (const auto& n : element_nodes) {
    model.element_nodes.insert(model.element_nodes.end(), n.begin(), n.begin() + (quadratic ? 10 : 4));
    if (model.element_offset.empty()) model.element_offset.push_back(0);
    model.element_offset.push_back(static_cast<std::uint32_t>(model.element_nodes.size()));
    model.element_grain.push_back(grain_index);
  }
  for (const auto& [key, entry] : faces) {
    if (entry.first != 1) continue;
    const auto [a, b, c] = entry.second;
    if (!quadratic) {
      model.triangles.push_back({a, b, c});
    } else {
      const std::uint32_t ab = mid_node(a, b), bc = mid_node(b, c), ca = mid_node(c, a);
      for (const std::array<std::uint32_t, 3>& t : {std::array{a, ab, ca}, std::array{ab, b, bc}, std::array{ca, bc, c},
                                                    std::array{ab, bc, ca}})
        model.triangles.push_back(t);
    }
  }
  model.triangle_grain.resize(model.triangles.size(), grain_index);
  g.node_end = static_cast<std::uint32_t>(model.nodes.size());
  g.element_end = static_cast<std::uint32_t>(model.element_count());
  g.triangle_end = static_cast<std::uint32_t>(model.triangles.size());
  model.grains.push_back(g);
  return grain_index;
}

}  // namespace graintwin::fdem
