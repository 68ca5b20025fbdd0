#include "graintwin/fdem/primitives.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>

#include "graintwin/core/error.hpp"
#include "graintwin/fdem/element.hpp"

namespace graintwin::fdem {
namespace {

/// Outward faces of a positively oriented tetrahedron (0, 1, 2, 3), as local corner indices.
constexpr std::array<std::array<int, 3>, 4> kOutwardFaces{{{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}};

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
  std::vector<Eigen::Vector3d> nodes;
  nodes.reserve(mesh.nodes.size());
  for (const Eigen::Vector3d& p : mesh.nodes) nodes.push_back(p + offset);
  const bool quadratic = kind == GrainKind::tet10;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> edge_node;  // corner ids, low first
  std::vector<std::uint32_t> elements;
  elements.reserve(mesh.tets.size() * (quadratic ? 10 : 4));
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const auto& c = mesh.tets[t];
    for (std::uint32_t a : c)
      if (a >= mesh.nodes.size())
        throw DataError("tetrahedron " + std::to_string(t) + " of grain label " + std::to_string(label) + " uses a missing node");
    elements.insert(elements.end(), c.begin(), c.end());
    if (!quadratic) continue;
    for (const auto& [a, b] : kTet10Edges) {
      const auto key = std::minmax(c[static_cast<std::size_t>(a)], c[static_cast<std::size_t>(b)]);
      const auto [it, fresh] = edge_node.try_emplace({key.first, key.second}, static_cast<std::uint32_t>(nodes.size()));
      if (fresh) nodes.push_back(0.5 * (nodes[key.first] + nodes[key.second]));
      elements.push_back(it->second);
    }
  }
  return append_grain_elements(model, nodes, quadratic ? 10 : 4, elements, kind, material, label);
}

std::vector<std::array<std::uint32_t, 3>> boundary_triangles(int nodes_per_element, std::span<const std::uint32_t> elements) {
  if (nodes_per_element != 4 && nodes_per_element != 10)
    throw UsageError("boundary_triangles: elements of " + std::to_string(nodes_per_element) + " nodes (4 or 10 expected)");
  const auto npe = static_cast<std::size_t>(nodes_per_element);
  const std::size_t count = elements.size() / npe;
  struct FaceUse {
    std::uint32_t element;
    std::uint8_t face, uses;
  };
  std::unordered_map<std::uint64_t, FaceUse> faces;  // key: sorted corner triple, 21 bits each
  faces.reserve(2 * count);
  const auto key = [](std::array<std::uint32_t, 3> c) {
    std::sort(c.begin(), c.end());
    if (c[2] >= (1u << 21)) throw UsageError("boundary_triangles: a grain mesh of over 2 million nodes");
    return static_cast<std::uint64_t>(c[0]) << 42 | static_cast<std::uint64_t>(c[1]) << 21 | c[2];
  };
  for (std::size_t e = 0; e < count; ++e) {
    const std::uint32_t* n = elements.data() + e * npe;
    for (std::uint8_t f = 0; f < 4; ++f) {
      const auto& corner = kOutwardFaces[f];
      auto [it, fresh] = faces.try_emplace(key({n[corner[0]], n[corner[1]], n[corner[2]]}),
                                           FaceUse{static_cast<std::uint32_t>(e), f, 0});
      ++it->second.uses;
    }
  }
  std::vector<std::pair<std::uint32_t, std::uint8_t>> boundary;  // sorted, so the result is deterministic
  for (const auto& [k, use] : faces)
    if (use.uses == 1) boundary.emplace_back(use.element, use.face);
  std::sort(boundary.begin(), boundary.end());
  const auto mid_node = [](int a, int b) {
    for (int k = 0; k < 6; ++k)
      if ((kTet10Edges[k][0] == a && kTet10Edges[k][1] == b) || (kTet10Edges[k][0] == b && kTet10Edges[k][1] == a)) return 4 + k;
    return -1;
  };
  std::vector<std::array<std::uint32_t, 3>> out;
  out.reserve(boundary.size() * (npe == 10 ? 4 : 1));
  for (const auto& [e, f] : boundary) {
    const std::uint32_t* n = elements.data() + e * npe;
    const int a = kOutwardFaces[f][0], b = kOutwardFaces[f][1], c = kOutwardFaces[f][2];
    if (npe == 4) {
      out.push_back({n[a], n[b], n[c]});
      continue;
    }
    const std::uint32_t ab = n[mid_node(a, b)], bc = n[mid_node(b, c)], ca = n[mid_node(c, a)];
    out.insert(out.end(), {{n[a], ab, ca}, {ab, n[b], bc}, {ca, bc, n[c]}, {ab, bc, ca}});
  }
  return out;
}

std::uint32_t append_grain_elements(Model& model, std::span<const Eigen::Vector3d> nodes, int nodes_per_element,
                                    std::span<const std::uint32_t> elements, GrainKind kind, std::uint32_t material,
                                    std::uint32_t label) {
  if (material >= model.materials.size())
    throw UsageError("grain label " + std::to_string(label) + " names material " + std::to_string(material) +
                     " but the model has " + std::to_string(model.materials.size()));
  const auto npe = static_cast<std::size_t>(nodes_per_element);
  const std::vector<std::array<std::uint32_t, 3>> surface = boundary_triangles(nodes_per_element, elements);
  for (std::size_t e = 0; e < elements.size() / npe; ++e) {
    const std::uint32_t* n = elements.data() + e * npe;
    for (std::size_t k = 0; k < npe; ++k)
      if (n[k] >= nodes.size())
        throw DataError("element " + std::to_string(e) + " of grain label " + std::to_string(label) + " uses a missing node");
    const Eigen::Vector3d& p0 = nodes[n[0]];
    if (!((nodes[n[1]] - p0).cross(nodes[n[2]] - p0).dot(nodes[n[3]] - p0) > 0))
      throw DataError("element " + std::to_string(e) + " of grain label " + std::to_string(label) +
                      " is flat or inverted; remesh the grain");
  }
  const auto grain_index = static_cast<std::uint32_t>(model.grains.size());
  Grain g;
  g.label = label;
  g.kind = kind;
  g.material = material;
  g.node_begin = static_cast<std::uint32_t>(model.nodes.size());
  g.element_begin = static_cast<std::uint32_t>(model.element_count());
  g.triangle_begin = static_cast<std::uint32_t>(model.triangles.size());
  model.nodes.insert(model.nodes.end(), nodes.begin(), nodes.end());
  if (model.element_offset.empty()) model.element_offset.push_back(0);
  for (std::size_t e = 0; e < elements.size() / npe; ++e) {
    for (std::size_t k = 0; k < npe; ++k) model.element_nodes.push_back(g.node_begin + elements[e * npe + k]);
    model.element_offset.push_back(static_cast<std::uint32_t>(model.element_nodes.size()));
    model.element_grain.push_back(grain_index);
  }
  for (const auto& t : surface) model.triangles.push_back({g.node_begin + t[0], g.node_begin + t[1], g.node_begin + t[2]});
  model.triangle_grain.resize(model.triangles.size(), grain_index);
  g.node_end = static_cast<std::uint32_t>(model.nodes.size());
  g.element_end = static_cast<std::uint32_t>(model.element_count());
  g.triangle_end = static_cast<std::uint32_t>(model.triangles.size());
  model.grains.push_back(g);
  return grain_index;
}

namespace {

// A 10-node element's eight linear parts, as local node indices (mid-edge node 4 + k on edge
// kTet10Edges[k]: 01, 12, 20, 30, 32, 31).
constexpr std::array<std::array<int, 4>, 4> kCornerTets{{{0, 4, 6, 7}, {4, 1, 5, 9}, {6, 5, 2, 8}, {7, 9, 8, 3}}};
// The inner octahedron's three diagonals (its opposite mid-edge nodes), each with the equator of
// the other four in cyclic order (p, q, p', q' for the other two opposite pairs).
struct Diagonal {
  int a, b;
  std::array<int, 4> equator;
};
constexpr std::array<Diagonal, 3> kDiagonals{{{4, 8, {5, 6, 7, 9}}, {5, 7, {4, 6, 8, 9}}, {6, 9, {4, 5, 8, 7}}}};

double signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

/// Element e's eight positively oriented linear parts (local node indices into its 10), or nothing
/// when a corner part is inverted or no diagonal of the inner octahedron gives four valid parts.
std::optional<std::array<std::array<int, 4>, 8>> linear_parts(const Model& model, std::size_t e) {
  const std::uint32_t* n = model.element_nodes.data() + model.element_offset[e];
  const auto at = [&](int local) -> const Eigen::Vector3d& { return model.nodes[n[local]]; };
  std::array<std::array<int, 4>, 8> parts;
  for (int k = 0; k < 4; ++k) {
    const auto& t = kCornerTets[k];
    if (!(signed_volume(at(t[0]), at(t[1]), at(t[2]), at(t[3])) > 0)) return std::nullopt;
    parts[k] = t;
  }
  // The diagonal whose four parts share one orientation; the shortest if several do.
  const Diagonal* best = nullptr;
  double best_length = 0;
  bool best_positive = true;
  for (const Diagonal& d : kDiagonals) {
    int positive = 0, negative = 0;
    for (int k = 0; k < 4; ++k) {
      const double v = signed_volume(at(d.a), at(d.b), at(d.equator[k]), at(d.equator[(k + 1) % 4]));
      positive += v > 0;
      negative += v < 0;
    }
    const double length = (at(d.a) - at(d.b)).norm();
    if ((positive == 4 || negative == 4) && (!best || length < best_length)) {
      best = &d;
      best_length = length;
      best_positive = positive == 4;
    }
  }
  if (!best) return std::nullopt;
  const int a = best_positive ? best->a : best->b, b = best_positive ? best->b : best->a;
  for (int k = 0; k < 4; ++k) parts[4 + k] = {a, b, best->equator[k], best->equator[(k + 1) % 4]};
  return parts;
}

}  // namespace

std::vector<std::uint32_t> split_into_linear_grains(Model& model) {
  std::vector<std::uint32_t> element_nodes, element_offset{0}, element_grain, kept;
  element_nodes.reserve(model.element_nodes.size() * 32 / 10);
  for (std::uint32_t g = 0; g < model.grains.size(); ++g) {
    Grain& grain = model.grains[g];
    const auto begin = static_cast<std::uint32_t>(element_grain.size());
    const std::size_t nodes_at = element_nodes.size();
    bool split = true;
    for (std::uint32_t e = grain.element_begin; e < grain.element_end && split; ++e) {
      const std::uint32_t* n = model.element_nodes.data() + model.element_offset[e];
      if (model.nodes_of(e) == 4) {
        element_nodes.insert(element_nodes.end(), n, n + 4);
        continue;
      }
      const auto parts = linear_parts(model, e);
      split = parts.has_value();
      if (split)
        for (const auto& t : *parts)
          for (int k : t) element_nodes.push_back(n[k]);
    }
    element_nodes.resize(split ? element_nodes.size() : nodes_at);
    if (!split) {
      kept.push_back(g);
      for (std::uint32_t e = grain.element_begin; e < grain.element_end; ++e) {
        element_nodes.insert(element_nodes.end(), model.element_nodes.begin() + model.element_offset[e],
                             model.element_nodes.begin() + model.element_offset[e + 1]);
        element_offset.push_back(static_cast<std::uint32_t>(element_nodes.size()));
        element_grain.push_back(g);
      }
    } else {
      for (std::size_t at = nodes_at; at < element_nodes.size(); at += 4) {
        element_offset.push_back(static_cast<std::uint32_t>(at + 4));
        element_grain.push_back(g);
      }
      grain.kind = GrainKind::tet4;
    }
    grain.element_begin = begin;
    grain.element_end = static_cast<std::uint32_t>(element_grain.size());
  }
  model.element_nodes = std::move(element_nodes);
  model.element_offset = std::move(element_offset);
  model.element_grain = std::move(element_grain);
  return kept;
}

}  // namespace graintwin::fdem
