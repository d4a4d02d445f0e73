// Order statistics shared by the bench's tables and metrics.
#pragma once

#include <vector>

namespace hdabench::util {

// p-quantile of sorted values, linear between order statistics
// (position p * (n - 1)); 0 when empty.
double Quantile(const std::vector<double>& sorted, double p);

// The upper median (the element at n / 2 in sorted order, so for an even
// count the larger of the two middle ones), without sorting; 0 when empty.
double UpperMedian(std::vector<double> values);

}  // namespace hdabench::util
