#include "graintwin/core/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "graintwin/core/geometry.hpp"

namespace graintwin {

double d50_of_curve(const std::vector<double>& diameter, const std::vector<double>& percent_passing) {
  if (diameter.empty() || diameter.size() != percent_passing.size()) return 0.0;
  const auto at = std::lower_bound(percent_passing.begin(), percent_passing.end(), 50.0);
  if (at == percent_passing.end()) return diameter.back();
  const std::size_t k = static_cast<std::size_t>(at - percent_passing.begin());
  if (k == 0) return diameter.front();
  const double p0 = percent_passing[k - 1], p1 = percent_passing[k];
  return diameter[k - 1] + (50.0 - p0) / (p1 - p0) * (diameter[k] - diameter[k - 1]);
}

double d50_of_volumes(std::vector<double> volumes) {
  std::sort(volumes.begin(), volumes.end());  // diameter grows with volume
  const double total = std::accumulate(volumes.begin(), volumes.end(), 0.0);
  if (!(total > 0.0)) return 0.0;
  std::vector<double> diameter, percent;
  double passing = 0.0;
  for (double v : volumes) {
    passing += v;
    diameter.push_back(equivalent_diameter(v));
    percent.push_back(100.0 * passing / total);
  }
  return d50_of_curve(diameter, percent);
}

}  // namespace graintwin
