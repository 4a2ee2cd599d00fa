#include "tsp/tour.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

namespace mound::tsp {
namespace {

// Naive model: the oriented cycle as a vector; reverse the path a..b by rotation.
std::vector<int> NaiveReverse(std::vector<int> v, int a, int b) {
  const auto it = std::find(v.begin(), v.end(), a);
  std::rotate(v.begin(), it, v.end());
  const auto jt = std::find(v.begin(), v.end(), b);
  std::reverse(v.begin(), jt + 1);
  return v;
}

// Same oriented cycle, compared from node 0.
std::vector<int> FromZero(std::vector<int> v) {
  std::rotate(v.begin(), std::find(v.begin(), v.end(), 0), v.end());
  return v;
}

TEST(TourTest, RandomReversalsMatchNaiveModelAndUndoRestores) {
  std::mt19937 rng(7);
  for (int n : {3, 4, 5, 10, 31, 200}) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    Tour tour(order);
    tour.SetJournaling(true);
    std::vector<int> model = order;
    for (int step = 0; step < 500; ++step) {
      const int a = static_cast<int>(rng() % n), b = static_cast<int>(rng() % n);
      tour.Reverse(a, b);
      model = NaiveReverse(model, a, b);
      ASSERT_EQ(FromZero(tour.Order()), FromZero(model)) << "n=" << n << " step=" << step;
      for (int v = 0; v < n; ++v) {
        ASSERT_EQ(tour.Prev(tour.Next(v)), v);
      }
    }
    const int x = model[1], y = model[n / 2], z = model[n - 1];
    EXPECT_TRUE(tour.Between(model[0], y, z));
    EXPECT_FALSE(n > 3 && tour.Between(y, x, z));
    tour.UndoTo(0);
    EXPECT_EQ(FromZero(tour.Order()), FromZero(order));
  }
}

TEST(TourTest, RejectsNonPermutation) {
  EXPECT_THROW(Tour({0, 1, 1}), std::invalid_argument);
  EXPECT_THROW(Tour({0, 3, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace mound::tsp
