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

}  // namespace graintwin
