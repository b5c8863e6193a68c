#pragma once
/// @file median.h
/// The median the VO stages use for robust statistics (parallax, depth ratios, flow): the element at index
/// size / 2 after sorting (the upper of the two middle values for an even count), found by a partial sort in
/// place; 0 for an empty vector.

#include <algorithm>
#include <vector>

namespace planetary_vo {

template <typename T>
T medianInPlace(std::vector<T>* values) {
  if (values->empty()) return T(0);
  const auto mid = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), mid, values->end());
  return *mid;
}

}  // namespace planetary_vo
