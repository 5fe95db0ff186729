// Small order statistics shared by the modules.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace ovo {

/// The upper median of v (its element at index size/2 once sorted); 0 for an empty v.
inline double upperMedian(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// Percentile (0..100) of a sample, linear interpolation between order statistics; 0 for an
/// empty sample.
inline double percentile(std::vector<double> values, double pct) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos = pct / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

}  // namespace ovo
