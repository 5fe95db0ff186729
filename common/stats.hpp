// Small order statistics shared by the modules.
#pragma once

#include <algorithm>
#include <vector>

namespace ovo {

/// The upper median of v (its element at index size/2 once sorted); 0 for an empty v.
inline double upperMedian(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace ovo
