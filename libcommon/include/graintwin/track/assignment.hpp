#pragma once
// Minimum-cost assignment on a sparse candidate graph, with a "lost" option per row: each row
// (reference grain) takes one of its candidate columns (grains of the next scan) or is lost at its
// own cost; each column is taken at most once. Solved exactly by successive shortest augmenting
// paths (Jonker-Volgenant style: Dijkstra on reduced costs with column prices), which only visits
// the part of the graph a conflict touches, so a near-diagonal problem of 16 000 rows costs about
// as much as reading its edges; no dense matrix, no all-pairs loop.
#include <cstdint>
#include <vector>

namespace graintwin::track {

/// Candidate edges row by row (CSR): row r's edges are [row_start[r], row_start[r + 1]).
struct SparseCosts {
  std::size_t columns = 0;
  std::vector<std::size_t> row_start{0};  ///< rows + 1 entries
  std::vector<std::uint32_t> column;      ///< < columns
  std::vector<double> cost;               ///< finite
  std::size_t rows() const { return row_start.size() - 1; }
  /// Appends an edge to the last row (call end_row() after each row's edges).
  void add(std::uint32_t c, double w) {
    column.push_back(c);
    cost.push_back(w);
  }
  void end_row() { row_start.push_back(column.size()); }
};

struct Assignment {
  std::vector<int> column_of;  ///< per row: its column, or -1 (lost)
  double total_cost = 0.0;     ///< sum of the edge costs taken plus the lost costs
};

/// The assignment of least total cost. lost_cost has one finite entry per row. Parallel edges
/// (the same column twice in a row) are allowed; the cheaper one counts. Deterministic. UsageError
/// on inconsistent sizes, a column out of range or a non-finite cost.
Assignment solve_assignment(const SparseCosts& costs, const std::vector<double>& lost_cost);

}  // namespace graintwin::track
