#pragma once
// Per-grain bounding-volume hierarchies over surface triangles for the FDEM narrow phase. The tree
// topology is built once from the reference configuration (median split on the longest axis, at
// most 4 triangles a leaf); each step only refits the boxes to the current node positions, which
// stays valid under any motion and costs one pass over the grain's triangles.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "graintwin/fdem/contact_geometry.hpp"
#include "graintwin/fdem/model.hpp"

namespace graintwin::fdem {

class SurfaceTrees {
 public:
  SurfaceTrees() = default;
  /// One tree per grain of `model` over its triangles [triangle_begin, triangle_end), boxes fitted
  /// to the reference node positions.
  explicit SurfaceTrees(const Model& model);

  /// Refits grain g's boxes to the node positions x (one per model node).
  void refit(std::size_t grain, std::span<const Eigen::Vector3d> x);
  /// Places grain g's boxes for a rigid motion x = rotation X + translation of its reference
  /// nodes X: each reference box turned and moved, then boxed again (centre R c + t, half-sizes
  /// |R| h). Conservative (a turned box is boxed larger), exact at no rotation, and several times
  /// cheaper than a refit, which reads every triangle's corners.
  void place(std::size_t grain, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
  /// Box of grain g's surface after the last refit (empty for a grain without triangles).
  const Aabb& bounds(std::size_t grain) const;

  struct Nearest {
    std::uint32_t triangle = 0;  ///< model triangle index
    TrianglePoint closest;
    double distance2 = 0;        ///< m^2
    std::uint32_t tested = 0;    ///< triangles whose closest point was evaluated (cost)
  };
  static constexpr std::uint32_t kNoHint = UINT32_MAX;
  /// The triangle of grain g closest to p among those closer than `radius` (ties: the first met in
  /// the tree's fixed order). False when none is that close. `hint`, a triangle of g likely to be
  /// close, only speeds the search up: its distance (plus a round-off slack) bounds the search from
  /// the start, and every triangle at least as close is still visited in the same order, so the
  /// answer is the same with any hint.
  bool nearest(std::size_t grain, const Eigen::Vector3d& p, double radius, std::span<const Eigen::Vector3d> x,
               Nearest& out, std::uint32_t hint = kNoHint) const;

 private:
  struct Node {
    Aabb box;
    std::uint32_t first = 0;  ///< leaf: first entry in order_; inner: index of the right child (left = this + 1)
    std::uint32_t count = 0;  ///< leaf: triangles; inner: 0
  };
  std::vector<Node> nodes_;                         ///< all grains' trees, depth-first
  std::vector<Aabb> reference_boxes_;               ///< nodes_' boxes fitted to the reference nodes
  std::vector<std::uint32_t> tree_begin_;           ///< grains + 1 entries into nodes_
  std::vector<std::uint32_t> order_;                ///< model triangle indices, leaf by leaf
  /// The corner nodes of order_'s triangles, in the same order: a leaf reads its triangles from one
  /// place (the searches are bound by memory latency, not arithmetic).
  std::vector<std::array<std::uint32_t, 3>> leaf_corners_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
};

}  // namespace graintwin::fdem
