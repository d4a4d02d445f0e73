// Order statistics shared by the bench's tables and metrics.
#pragma once

#include <vector>

namespace hdabench::util {

// p-quantile of sorted values, linear between order statistics
// (position p * (n - 1)); 0 when empty.
double Quantile(const std::vector<double>& sorted, double p);

}  // namespace hdabench::util
