// Order statistics of a sample, the one implementation the libraries share.
#pragma once

#include <vector>

namespace mound {

// The element of rank round(q (n - 1)) in the sorted sample (q in [0, 1]); NaN when empty.
// Takes a copy: the caller's order is kept.
double Quantile(std::vector<double> v, double q);

// Quantile(v, 0.5): for an even count the upper of the two middle elements.
double Median(std::vector<double> v);

}  // namespace mound
