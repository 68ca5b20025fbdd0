#pragma once
// Order statistics shared by the modules: one definition of the median they all use.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace graintwin {

/// The median of `values` (taken by value: partially reordered, O(n)): the element at index n/2 of
/// the sorted values, which is the upper of the two middle ones for an even n. 0 for no values.
template <class T>
double median(std::vector<T> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return static_cast<double>(*middle);
}

/// d50 read off a sieve curve: the diameter at which `percent_passing` (ascending, by volume)
/// reaches 50 %, interpolated linearly between the points on either side; the first diameter when
/// the curve starts at or above 50 %. 0 for an empty curve. The one definition of d50
/// (docs/conventions.md).
double d50_of_curve(const std::vector<double>& diameter, const std::vector<double>& percent_passing);

/// d50 of grains given by their volumes: the sieve curve of their equivalent-sphere diameters
/// d = (6 V / pi)^(1/3), each grain's volume passing from its own diameter on, read by d50_of_curve.
double d50_of_volumes(std::vector<double> volumes);

}  // namespace graintwin
