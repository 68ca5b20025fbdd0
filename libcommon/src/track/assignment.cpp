#include "graintwin/track/assignment.hpp"

#include <cmath>
#include <limits>
#include <queue>
#include <string>

#include "graintwin/core/error.hpp"

namespace graintwin::track {

Assignment solve_assignment(const SparseCosts& c, const std::vector<double>& lost_cost) {
  const std::size_t n = c.rows(), m = c.columns;
  if (lost_cost.size() != n) throw UsageError("solve_assignment: one lost cost per row is needed");
  if (c.row_start.empty() || c.row_start.front() != 0 || c.row_start.back() != c.column.size() ||
      c.column.size() != c.cost.size())
    throw UsageError("solve_assignment: inconsistent sparse cost table");
  for (std::size_t e = 0; e < c.column.size(); ++e)
    if (c.column[e] >= m || !std::isfinite(c.cost[e]))
      throw UsageError("solve_assignment: edge " + std::to_string(e) + " has a column out of range or a non-finite cost");
  for (double w : lost_cost)
    if (!std::isfinite(w)) throw UsageError("solve_assignment: lost costs must be finite");

  // Columns m + r are the private "lost" columns of the rows. A row's edges: its candidates, then lost.
  const std::size_t cols = m + n;
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> price(cols, 0.0), dist(cols, inf);
  std::vector<int> owner(cols, -1), via(cols, -1), column_of(n, -1);
  std::vector<char> done(cols, 0);
  std::vector<std::size_t> touched, scanned;
  using Entry = std::pair<double, std::size_t>;  // (distance, column): ties go to the lower column
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap;
  const auto for_each_edge = [&](std::size_t r, auto&& f) {
    for (std::size_t e = c.row_start[r]; e < c.row_start[r + 1]; ++e) f(static_cast<std::size_t>(c.column[e]), c.cost[e]);
    f(m + r, lost_cost[r]);
  };
  const auto cost_of = [&](std::size_t r, std::size_t col) {  // cheapest edge r -> col
    double w = inf;
    for_each_edge(r, [&](std::size_t k, double x) {
      if (k == col && x < w) w = x;
    });
    return w;
  };

  for (std::size_t s = 0; s < n; ++s) {
    // Dijkstra from row s over reduced costs c(i, k) - price[k] - u_i (non-negative by the
    // invariant that every assigned row holds its cheapest column at the current prices).
    const auto relax = [&](std::size_t r, double base) {
      for_each_edge(r, [&](std::size_t k, double w) {
        if (done[k]) return;
        const double d = base + w - price[k];
        if (d < dist[k]) {
          if (dist[k] == inf) touched.push_back(k);
          dist[k] = d;
          via[k] = static_cast<int>(r);
          heap.push({d, k});
        }
      });
    };
    relax(s, 0.0);
    std::size_t free_col = cols;
    double dmin = 0.0;
    while (!heap.empty()) {
      const auto [d, k] = heap.top();
      heap.pop();
      if (done[k] || d > dist[k]) continue;
      done[k] = 1;
      if (owner[k] < 0) {
        free_col = k;
        dmin = d;
        break;
      }
      scanned.push_back(k);
      const std::size_t r = static_cast<std::size_t>(owner[k]);
      relax(r, d - (cost_of(r, k) - price[k]));
    }
    // The row's own lost column is always reachable, so a free column was found.
    for (std::size_t k : scanned) price[k] += dist[k] - dmin;
    for (std::size_t k = free_col;;) {  // flip the path
      const int r = via[k];
      const int previous = column_of[static_cast<std::size_t>(r)];
      column_of[static_cast<std::size_t>(r)] = static_cast<int>(k);
      owner[k] = r;
      if (static_cast<std::size_t>(r) == s) break;
      k = static_cast<std::size_t>(previous);
    }
    for (std::size_t k : touched) dist[k] = inf, done[k] = 0, via[k] = -1;
    touched.clear();
    scanned.clear();
    heap = {};
  }

  Assignment a;
  a.column_of.assign(n, -1);
  for (std::size_t r = 0; r < n; ++r) {
    const std::size_t k = static_cast<std::size_t>(column_of[r]);
    a.total_cost += cost_of(r, k);
    if (k < m) a.column_of[r] = static_cast<int>(k);
  }
  return a;
}

}  // namespace graintwin::track
