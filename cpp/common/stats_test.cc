#include "common/stats.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mound {
namespace {

TEST(Stats, QuantileAndMedianRanks) {
  const std::vector<double> odd = {5, 1, 4, 2, 3};
  EXPECT_EQ(Median(odd), 3);
  EXPECT_EQ(Quantile(odd, 0.0), 1);
  EXPECT_EQ(Quantile(odd, 1.0), 5);
  EXPECT_EQ(Quantile(odd, 0.9), 5);  // rank round(3.6) = 4
  const std::vector<double> even = {4, 1, 3, 2};
  EXPECT_EQ(Median(even), 3);                            // the upper middle element (rank size / 2)
  EXPECT_EQ(odd, (std::vector<double>{5, 1, 4, 2, 3}));  // the input untouched
  EXPECT_TRUE(std::isnan(Median({})));
}

}  // namespace
}  // namespace mound
