#pragma once
// Symmetric sparse matrices over mesh nodes of three unknowns each (unknown 3 i + k is component k
// of node i), stored as dense 3 x 3 blocks: the product with a vector and an LDL^T solve, both block
// by block. What an implicit grain does every step (fdem::ImplicitGrain).
//
// Why blocks: a scalar sparse format stores an index with every number and updates one unknown at a
// time; a 3 x 3 block shares one index among nine numbers and updates a node's three unknowns at
// once. On the pipeline twins' grains the LDL^T solve runs 2.5-2.8 times faster than Eigen's
// SimplicialLDLT (fdem_implicit_grain bench; docs/fdemrun.md, implicit grains).
#include <Eigen/SparseCore>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace graintwin::fdem {

/// A symmetric matrix of `nodes` x `nodes` blocks, from the triplets of its lower triangle (row >=
/// column, unknown indices; repeated entries add up). Only blocks that hold an entry are stored.
class SymmetricNodeBlocks {
 public:
  SymmetricNodeBlocks() = default;
  SymmetricNodeBlocks(std::size_t nodes, std::span<const Eigen::Triplet<double>> lower);
  /// y = A x (3 nodes() numbers each; x and y must not overlap).
  void multiply(std::span<const double> x, std::span<double> y) const;
  std::size_t nodes() const { return diagonal_.size(); }

 private:
  std::vector<std::array<double, 9>> diagonal_;  ///< per node, its full 3 x 3 block, column-major
  /// Off-diagonal blocks (I, J) with I > J, by row I: row_start_[I] .. row_start_[I + 1], column J
  /// in column_ and the block, column-major, in value_.
  std::vector<std::uint32_t> row_start_, column_;
  std::vector<std::array<double, 9>> value_;
};

/// The LDL^T factorisation of a symmetric positive definite matrix of `nodes` x `nodes` blocks, given
/// by the triplets of its lower triangle, in the node order that AMD (approximate minimum degree) finds
/// on the nodes' graph: L unit lower triangular, D diagonal, both stored as 3 x 3 blocks of a node's
/// three unknowns. The numeric factorisation is Eigen's SimplicialLDLT in that order; the solve is
/// our own.
class NodeBlockLdlt {
 public:
  NodeBlockLdlt() = default;
  NodeBlockLdlt(std::size_t nodes, std::span<const Eigen::Triplet<double>> lower);
  /// Whether the factorisation succeeded with every pivot of D positive.
  bool positive_definite() const { return positive_definite_; }
  /// x = A^-1 b (3 nodes() numbers each; they may be the same span). Keeps its own workspace, so one
  /// factorisation solves for one caller at a time.
  void solve(std::span<const double> b, std::span<double> x) const;
  std::size_t nodes() const { return order_.size(); }

 private:
  std::vector<std::uint32_t> order_;  ///< order_[k]: the node eliminated k-th
  /// Per eliminated node k: L's three entries below its diagonal inside the node's own block (rows
  /// 1, 0; 2, 0; 2, 1) and the inverses of its three pivots.
  std::vector<std::array<double, 3>> inside_, pivot_inverse_;
  /// L's blocks below the node's own, by eliminated node k: column_start_[k] .. column_start_[k + 1],
  /// the row's eliminated index in row_ and the block, column-major, in value_.
  std::vector<std::uint32_t> column_start_, row_;
  std::vector<std::array<double, 9>> value_;
  bool positive_definite_ = false;
  mutable std::vector<double> work_;  ///< the solve's unknowns in elimination order
};

}  // namespace graintwin::fdem
