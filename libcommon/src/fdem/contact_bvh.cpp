#include "graintwin/fdem/contact_bvh.hpp"

#include <Eigen/Geometry>

#include <algorithm>

namespace graintwin::fdem {

namespace {
constexpr std::uint32_t kLeafSize = 4;
constexpr int kStackSize = 64;  // median splits: depth <= log2(triangles), far below this
/// Slack on a hint's distance, relative to the search radius: box distances and triangle
/// distances are rounded differently, and a triangle exactly as close as the hint must not be
/// pruned by round-off (ties go to the lowest index, as without a hint).
constexpr double kHintSlack = 1e-6;
}  // namespace

SurfaceTrees::SurfaceTrees(const Model& model) : reference_x_(model.nodes), triangles_(model.triangles) {
  std::vector<Eigen::Vector3d> centroid(model.triangles.size());
  for (std::size_t t = 0; t < centroid.size(); ++t) {
    const auto& tri = model.triangles[t];
    centroid[t] = (model.nodes[tri[0]] + model.nodes[tri[1]] + model.nodes[tri[2]]) / 3.0;
  }
  order_.resize(model.triangles.size());
  // Depth-first layout, left child right after its parent: children always follow their parent,
  // so a reverse sweep refits bottom-up.
  auto build = [&](auto&& self, std::uint32_t first, std::uint32_t count) -> void {
    const auto index = static_cast<std::uint32_t>(nodes_.size());
    nodes_.push_back({});
    if (count <= kLeafSize) {
      nodes_[index].first = first;
      nodes_[index].count = count;
      return;
    }
    Aabb box;
    for (std::uint32_t i = first; i < first + count; ++i) box.grow(centroid[order_[i]]);
    int axis = 0;
    (box.hi - box.lo).maxCoeff(&axis);
    const std::uint32_t half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](std::uint32_t a, std::uint32_t b) {
                       return centroid[a][axis] < centroid[b][axis] ||
                              (centroid[a][axis] == centroid[b][axis] && a < b);
                     });
    self(self, first, half);
    nodes_[index].first = static_cast<std::uint32_t>(nodes_.size());
    self(self, first + half, count - half);
  };
  tree_begin_.reserve(model.grains.size() + 1);
  for (const Grain& grain : model.grains) {
    tree_begin_.push_back(static_cast<std::uint32_t>(nodes_.size()));
    for (std::uint32_t t = grain.triangle_begin; t < grain.triangle_end; ++t) order_[t] = t;
    if (grain.triangle_end > grain.triangle_begin)
      build(build, grain.triangle_begin, grain.triangle_end - grain.triangle_begin);
  }
  tree_begin_.push_back(static_cast<std::uint32_t>(nodes_.size()));
  leaf_corners_.reserve(order_.size());
  reference_corners_.reserve(order_.size());
  for (std::uint32_t t : order_) {
    const auto& tri = triangles_[t];
    leaf_corners_.push_back(tri);
    reference_corners_.push_back({model.nodes[tri[0]], model.nodes[tri[1]], model.nodes[tri[2]]});
  }
  for (std::size_t g = 0; g < model.grains.size(); ++g) refit(g, model.nodes);
  reference_nodes_ = nodes_;
}

void SurfaceTrees::place(std::size_t grain, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  if (tree_begin_[grain] == tree_begin_[grain + 1]) return;
  const Aabb& ref = reference_nodes_[tree_begin_[grain]].box;
  const Eigen::Vector3d centre = rotation * (0.5 * (ref.lo + ref.hi)) + translation;
  const Eigen::Vector3d half = rotation.cwiseAbs() * (0.5 * (ref.hi - ref.lo));
  nodes_[tree_begin_[grain]].box = Aabb{centre - half, centre + half};
}

void SurfaceTrees::refit(std::size_t grain, std::span<const Eigen::Vector3d> x) {
  for (std::uint32_t i = tree_begin_[grain + 1]; i-- > tree_begin_[grain];) {
    Node& node = nodes_[i];
    node.box = Aabb{};
    if (node.count > 0) {
      for (std::uint32_t k = node.first; k < node.first + node.count; ++k)
        for (std::uint32_t v : leaf_corners_[k]) node.box.grow(x[v]);
    } else {
      node.box.grow(nodes_[i + 1].box);
      node.box.grow(nodes_[node.first].box);
    }
  }
}

const Aabb& SurfaceTrees::bounds(std::size_t grain) const {
  static const Aabb empty;
  return tree_begin_[grain] < tree_begin_[grain + 1] ? nodes_[tree_begin_[grain]].box : empty;
}

const Aabb& SurfaceTrees::reference_bounds(std::size_t grain) const {
  static const Aabb empty;
  return tree_begin_[grain] < tree_begin_[grain + 1] ? reference_nodes_[tree_begin_[grain]].box : empty;
}

bool SurfaceTrees::nearest(std::size_t grain, const Eigen::Vector3d& p, double radius,
                           std::span<const Eigen::Vector3d> x, Nearest& out, std::uint32_t hint) const {
  return search(
      nodes_, grain, p, radius,
      [&](std::uint32_t k) {
        const auto& tri = leaf_corners_[k];
        return std::array<const Eigen::Vector3d*, 3>{&x[tri[0]], &x[tri[1]], &x[tri[2]]};
      },
      [&](std::uint32_t t) {
        const auto& tri = triangles_[t];
        return std::array<const Eigen::Vector3d*, 3>{&x[tri[0]], &x[tri[1]], &x[tri[2]]};
      },
      out, hint);
}

bool SurfaceTrees::nearest_in_body(std::size_t grain, const Eigen::Vector3d& p_body, double radius, Nearest& out,
                                   std::uint32_t hint) const {
  return search(
      reference_nodes_, grain, p_body, radius,
      [&](std::uint32_t k) {
        const auto& c = reference_corners_[k];
        return std::array<const Eigen::Vector3d*, 3>{&c[0], &c[1], &c[2]};
      },
      [&](std::uint32_t t) {
        const auto& tri = triangles_[t];
        return std::array<const Eigen::Vector3d*, 3>{&reference_x_[tri[0]], &reference_x_[tri[1]], &reference_x_[tri[2]]};
      },
      out, hint);
}

std::size_t SurfaceTrees::slots_within_in_body(std::size_t grain, const Eigen::Vector3d& p_body, double radius,
                                               std::span<std::uint32_t> out) const {
  std::size_t count = 0;
  if (tree_begin_[grain] == tree_begin_[grain + 1]) return count;
  const double radius2 = radius * radius;
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = tree_begin_[grain];
  while (top > 0) {
    const Node& node = reference_nodes_[stack[--top]];
    if (node.box.squared_distance(p_body) > radius2) continue;
    if (node.count == 0) {
      stack[top++] = node.first;
      stack[top++] = static_cast<std::uint32_t>(&node - reference_nodes_.data()) + 1;
      continue;
    }
    for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
      const auto& c = reference_corners_[k];
      if ((closest_point_on_triangle(p_body, c[0], c[1], c[2]).point - p_body).squaredNorm() > radius2) continue;
      if (count < out.size()) out[count] = k;
      ++count;
    }
  }
  return count;
}

template <class Corners, class HintCorners>
bool SurfaceTrees::search(const std::vector<Node>& tree, std::size_t grain, const Eigen::Vector3d& p, double radius,
                          Corners corners, HintCorners hint_corners, Nearest& out, std::uint32_t hint) const {
  if (tree_begin_[grain] == tree_begin_[grain + 1]) return false;
  double best2 = radius * radius;
  bool found = false;
  std::uint32_t tested = 0;
  if (hint != kNoHint) {
    const auto c = hint_corners(hint);
    const double bound = (closest_point_on_triangle(p, *c[0], *c[1], *c[2]).point - p).norm() + kHintSlack * radius;
    best2 = std::min(best2, bound * bound);
    ++tested;
  }
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = tree_begin_[grain];
  while (top > 0) {
    const Node& node = tree[stack[--top]];
    // A box exactly as far as the best may hold a tie with a lower index: visited.
    if (node.box.squared_distance(p) > best2) continue;
    if (node.count > 0) {
      tested += node.count;
      for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
        const auto c = corners(k);
        TrianglePoint closest = closest_point_on_triangle(p, *c[0], *c[1], *c[2]);
        const double d2 = (closest.point - p).squaredNorm();
        if (d2 < best2 || (found && d2 == best2 && order_[k] < out.triangle)) {
          best2 = d2;
          out = {order_[k], closest, d2, 0};
          found = true;
        }
      }
      continue;
    }
    // Visit the nearer child first so the radius shrinks early.
    const std::uint32_t left = static_cast<std::uint32_t>(&node - tree.data()) + 1, right = node.first;
    const bool left_first = tree[left].box.squared_distance(p) <= tree[right].box.squared_distance(p);
    stack[top++] = left_first ? right : left;
    stack[top++] = left_first ? left : right;
  }
  out.tested = tested;
  return found;
}

}  // namespace graintwin::fdem
