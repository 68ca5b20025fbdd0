#pragma once
// Per-grain bounding-volume hierarchies over surface triangles for the FDEM narrow phase. The tree
// topology is built once from the reference configuration (median split on the longest axis, at
// most 4 triangles a leaf); each step a deformable grain's boxes are refitted to the current node
// positions (valid under any motion, one pass over its triangles), and a rigid grain is searched in
// its body frame on its reference tree, which never changes.
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
  /// Places grain g's bounds for a rigid motion x = rotation X + translation of its reference
  /// nodes X: the reference root box turned and moved, then boxed again (centre R c + t,
  /// half-sizes |R| h). Conservative (a turned box is boxed larger), exact at no rotation. Only the
  /// root moves: a placed grain is searched in its body frame (nearest_in_body), on boxes and
  /// corners that never change, so a step costs no pass over its tree.
  void place(std::size_t grain, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
  /// Box of grain g's surface after the last refit or placement (empty for a grain without triangles).
  const Aabb& bounds(std::size_t grain) const;
  /// Box of grain g's surface in the reference configuration (its body frame).
  const Aabb& reference_bounds(std::size_t grain) const;
  /// The model's reference node positions, m.
  std::span<const Eigen::Vector3d> reference_positions() const { return reference_x_; }

  struct Nearest {
    std::uint32_t triangle = 0;  ///< model triangle index
    TrianglePoint closest;
    double distance2 = 0;        ///< m^2
    std::uint32_t tested = 0;    ///< triangles whose closest point was evaluated (cost)
  };
  static constexpr std::uint32_t kNoHint = UINT32_MAX;
  /// The triangle of grain g closest to p among those closer than `radius` (ties: the lowest
  /// triangle index, so any search over a set of triangles that holds the closest one gives the
  /// same answer). False when none is that close. `hint`, a triangle of g likely to be
  /// close, only speeds the search up: its distance (plus a round-off slack) bounds the search from
  /// the start, and every triangle at least as close is still visited in the same order, so the
  /// answer is the same with any hint.
  bool nearest(std::size_t grain, const Eigen::Vector3d& p, double radius, std::span<const Eigen::Vector3d> x,
               Nearest& out, std::uint32_t hint = kNoHint) const;
  /// nearest() in the reference configuration: p_body = R^T (p - t) for a grain placed by a rigid
  /// motion (R, t); out.closest.point is in that frame too (distances, weights and features are the
  /// same in both).
  bool nearest_in_body(std::size_t grain, const Eigen::Vector3d& p_body, double radius, Nearest& out,
                       std::uint32_t hint = kNoHint) const;
  /// The triangles of grain g no farther than `radius` from p_body in the reference configuration,
  /// as slots of the trees' leaf order (slot_triangle() gives the model triangle; a slot's corners
  /// are stored together, so testing it is one read), written to `out` while it has room; returns
  /// how many there are (which may exceed out.size()).
  std::size_t slots_within_in_body(std::size_t grain, const Eigen::Vector3d& p_body, double radius,
                                   std::span<std::uint32_t> out) const;
  /// The closest point to p_body on the triangle in leaf slot `slot`, in the reference
  /// configuration, evaluated exactly as the searches evaluate it.
  TrianglePoint closest_in_slot(std::uint32_t slot, const Eigen::Vector3d& p_body) const {
    const auto& c = reference_corners_[slot];
    return closest_point_on_triangle(p_body, c[0], c[1], c[2]);
  }
  std::uint32_t slot_triangle(std::uint32_t slot) const { return order_[slot]; }

 private:
  struct Node {
    Aabb box;
    std::uint32_t first = 0;  ///< leaf: first entry in order_; inner: index of the right child (left = this + 1)
    std::uint32_t count = 0;  ///< leaf: triangles; inner: 0
  };
  template <class Corners, class HintCorners>
  bool search(const std::vector<Node>& tree, std::size_t grain, const Eigen::Vector3d& p, double radius,
              Corners corners, HintCorners hint_corners, Nearest& out, std::uint32_t hint) const;

  std::vector<Node> nodes_;                         ///< all grains' trees, depth-first
  std::vector<Node> reference_nodes_;               ///< nodes_ fitted to the reference nodes
  std::vector<std::uint32_t> tree_begin_;           ///< grains + 1 entries into nodes_
  std::vector<std::uint32_t> order_;                ///< model triangle indices, leaf by leaf
  /// The corner nodes of order_'s triangles, in the same order: a leaf reads its triangles from one
  /// place (the searches are bound by memory latency, not arithmetic).
  std::vector<std::array<std::uint32_t, 3>> leaf_corners_;
  /// The reference positions of leaf_corners_, for body-frame searches: no indirection at all.
  std::vector<std::array<Eigen::Vector3d, 3>> reference_corners_;
  std::vector<Eigen::Vector3d> reference_x_;  ///< the model's reference node positions (hints)
  std::vector<std::array<std::uint32_t, 3>> triangles_;
};

}  // namespace graintwin::fdem
