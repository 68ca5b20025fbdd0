#include "graintwin/fdem/node_blocks.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <limits>
#include <tuple>

#include "graintwin/core/error.hpp"

namespace graintwin::fdem {
namespace {

using Triplet = Eigen::Triplet<double>;

void check_triplets(std::size_t nodes, std::span<const Triplet> lower, const char* who) {
  for (const Triplet& t : lower)
    if (t.row() < t.col() || t.col() < 0 || static_cast<std::size_t>(t.row()) >= 3 * nodes)
      throw UsageError(std::string(who) + ": entry (" + std::to_string(t.row()) + ", " + std::to_string(t.col()) +
                       ") is not in the lower triangle of a matrix of " + std::to_string(nodes) + " nodes");
}

}  // namespace

SymmetricNodeBlocks::SymmetricNodeBlocks(std::size_t nodes, std::span<const Triplet> lower) : diagonal_(nodes) {
  check_triplets(nodes, lower, "SymmetricNodeBlocks");
  for (auto& d : diagonal_) d.fill(0);
  struct Entry {
    std::uint32_t row_node, column_node;
    int at;  ///< column-major place in the block
    double value;
  };
  std::vector<Entry> off;
  for (const Triplet& t : lower) {
    const auto I = static_cast<std::uint32_t>(t.row() / 3), J = static_cast<std::uint32_t>(t.col() / 3);
    const int r = t.row() % 3, c = t.col() % 3;
    if (I == J) {
      diagonal_[I][3 * c + r] += t.value();
      if (r != c) diagonal_[I][3 * r + c] += t.value();
    } else {
      off.push_back({I, J, 3 * c + r, t.value()});
    }
  }
  std::sort(off.begin(), off.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.row_node, a.column_node) < std::tie(b.row_node, b.column_node);
  });
  row_start_.assign(nodes + 1, 0);
  for (std::size_t k = 0; k < off.size(); ++k) {
    const bool fresh = k == 0 || off[k].row_node != off[k - 1].row_node || off[k].column_node != off[k - 1].column_node;
    if (fresh) {
      column_.push_back(off[k].column_node);
      value_.emplace_back().fill(0);
      ++row_start_[off[k].row_node + 1];
    }
    value_.back()[static_cast<std::size_t>(off[k].at)] += off[k].value;
  }
  for (std::size_t I = 0; I < nodes; ++I) row_start_[I + 1] += row_start_[I];
}

void SymmetricNodeBlocks::multiply(std::span<const double> x, std::span<double> y) const {
  const std::size_t n = nodes();
  for (std::size_t I = 0; I < n; ++I) {
    const double* d = diagonal_[I].data();
    const double* xi = x.data() + 3 * I;
    double* yi = y.data() + 3 * I;
    yi[0] = d[0] * xi[0] + d[3] * xi[1] + d[6] * xi[2];
    yi[1] = d[1] * xi[0] + d[4] * xi[1] + d[7] * xi[2];
    yi[2] = d[2] * xi[0] + d[5] * xi[1] + d[8] * xi[2];
  }
  for (std::size_t I = 0; I < n; ++I) {
    const double* xi = x.data() + 3 * I;
    double* yi = y.data() + 3 * I;
    double s0 = 0, s1 = 0, s2 = 0;
    for (std::uint32_t q = row_start_[I]; q < row_start_[I + 1]; ++q) {
      const double* b = value_[q].data();
      const double* xj = x.data() + 3 * column_[q];
      double* yj = y.data() + 3 * column_[q];
      s0 += b[0] * xj[0] + b[3] * xj[1] + b[6] * xj[2];
      s1 += b[1] * xj[0] + b[4] * xj[1] + b[7] * xj[2];
      s2 += b[2] * xj[0] + b[5] * xj[1] + b[8] * xj[2];
      yj[0] += b[0] * xi[0] + b[1] * xi[1] + b[2] * xi[2];  // the block's transpose, above the diagonal
      yj[1] += b[3] * xi[0] + b[4] * xi[1] + b[5] * xi[2];
      yj[2] += b[6] * xi[0] + b[7] * xi[1] + b[8] * xi[2];
    }
    yi[0] += s0;
    yi[1] += s1;
    yi[2] += s2;
  }
}

NodeBlockLdlt::NodeBlockLdlt(std::size_t nodes, std::span<const Triplet> lower) : work_(3 * nodes) {
  check_triplets(nodes, lower, "NodeBlockLdlt");
  const auto n = static_cast<Eigen::Index>(nodes);
  // AMD on the nodes' graph; eliminating a node's three unknowns together keeps L in blocks.
  std::vector<Triplet> graph;
  graph.reserve(lower.size() / 9 + nodes);
  for (std::size_t i = 0; i < nodes; ++i) graph.emplace_back(static_cast<int>(i), static_cast<int>(i), 1.0);
  for (const Triplet& t : lower) graph.emplace_back(t.row() / 3, t.col() / 3, 1.0);
  Eigen::SparseMatrix<double> pattern(n, n);
  pattern.setFromTriplets(graph.begin(), graph.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
  Eigen::AMDOrdering<int>()(pattern, inverse);
  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> place = inverse.inverse();  // node -> its elimination index
  order_.resize(nodes);
  for (std::size_t i = 0; i < nodes; ++i) order_[static_cast<std::size_t>(place.indices()[static_cast<Eigen::Index>(i)])] = static_cast<std::uint32_t>(i);

  std::vector<Triplet> ordered;
  ordered.reserve(lower.size());
  for (const Triplet& t : lower) {
    int r = 3 * place.indices()[t.row() / 3] + t.row() % 3, c = 3 * place.indices()[t.col() / 3] + t.col() % 3;
    if (r < c) std::swap(r, c);
    ordered.emplace_back(r, c, t.value());
  }
  Eigen::SparseMatrix<double> A(3 * n, 3 * n);
  A.setFromTriplets(ordered.begin(), ordered.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> factor(A);
  positive_definite_ = factor.info() == Eigen::Success && factor.vectorD().allFinite() && factor.vectorD().minCoeff() > 0;
  if (!positive_definite_) return;

  inside_.assign(nodes, {0, 0, 0});
  pivot_inverse_.resize(nodes);
  for (std::size_t k = 0; k < nodes; ++k)
    for (int j = 0; j < 3; ++j) pivot_inverse_[k][j] = 1.0 / factor.vectorD()[static_cast<Eigen::Index>(3 * k + j)];
  const auto& L = factor.matrixL().nestedExpression();  // strictly lower, column-major
  column_start_.assign(nodes + 1, 0);
  std::vector<std::uint32_t> slot(nodes, 0), slot_owner(nodes, std::numeric_limits<std::uint32_t>::max());
  for (std::size_t K = 0; K < nodes; ++K) {
    for (int c = 0; c < 3; ++c)
      for (Eigen::SparseMatrix<double>::InnerIterator it(L, static_cast<Eigen::Index>(3 * K + c)); it; ++it) {
        const auto I = static_cast<std::size_t>(it.row() / 3);
        const int r = static_cast<int>(it.row() % 3);
        if (I == K) {
          if (r > c) inside_[K][static_cast<std::size_t>(r + c - 1)] = it.value();  // (1, 0), (2, 0), (2, 1)
          continue;
        }
        if (slot_owner[I] != K) {
          slot_owner[I] = static_cast<std::uint32_t>(K);
          slot[I] = static_cast<std::uint32_t>(row_.size());
          row_.push_back(static_cast<std::uint32_t>(I));
          value_.emplace_back().fill(0);
        }
        value_[slot[I]][static_cast<std::size_t>(3 * c + r)] = it.value();
      }
    column_start_[K + 1] = static_cast<std::uint32_t>(row_.size());
  }
}

void NodeBlockLdlt::solve(std::span<const double> b, std::span<double> x) const {
  const std::size_t n = nodes();
  double* w = work_.data();
  for (std::size_t k = 0; k < n; ++k)
    for (int j = 0; j < 3; ++j) w[3 * k + j] = b[3 * order_[k] + j];
  for (std::size_t k = 0; k < n; ++k) {  // L z = b
    const auto& l = inside_[k];
    const double z0 = w[3 * k], z1 = w[3 * k + 1] - l[0] * z0, z2 = w[3 * k + 2] - l[1] * z0 - l[2] * z1;
    w[3 * k + 1] = z1;
    w[3 * k + 2] = z2;
    for (std::uint32_t q = column_start_[k]; q < column_start_[k + 1]; ++q) {
      const double* B = value_[q].data();
      double* y = w + 3 * row_[q];
      y[0] -= B[0] * z0 + B[3] * z1 + B[6] * z2;
      y[1] -= B[1] * z0 + B[4] * z1 + B[7] * z2;
      y[2] -= B[2] * z0 + B[5] * z1 + B[8] * z2;
    }
  }
  for (std::size_t k = 0; k < n; ++k)  // D y = z
    for (int j = 0; j < 3; ++j) w[3 * k + j] *= pivot_inverse_[k][j];
  for (std::size_t k = n; k-- > 0;) {  // L^T x = y
    double s0 = w[3 * k], s1 = w[3 * k + 1], s2 = w[3 * k + 2];
    for (std::uint32_t q = column_start_[k]; q < column_start_[k + 1]; ++q) {
      const double* B = value_[q].data();
      const double* y = w + 3 * row_[q];
      s0 -= B[0] * y[0] + B[1] * y[1] + B[2] * y[2];
      s1 -= B[3] * y[0] + B[4] * y[1] + B[5] * y[2];
      s2 -= B[6] * y[0] + B[7] * y[1] + B[8] * y[2];
    }
    const auto& l = inside_[k];
    s1 -= l[2] * s2;
    s0 -= l[0] * s1 + l[1] * s2;
    w[3 * k] = s0;
    w[3 * k + 1] = s1;
    w[3 * k + 2] = s2;
  }
  for (std::size_t k = 0; k < n; ++k)
    for (int j = 0; j < 3; ++j) x[3 * order_[k] + j] = w[3 * k + j];
}

}  // namespace graintwin::fdem
