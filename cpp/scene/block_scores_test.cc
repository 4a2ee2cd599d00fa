#include "scene/block_scores.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/error.h"

namespace mound::scene {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// 4 x 5 cells, margin 1: the core is rows 1..2, cols 1..3.
TEST(BlockScores, CalibratesAndFindsTheCoresMaxima) {
  const std::vector<double> logits = {0, 0,    0,   0, 9,  //
                                      0, 2,    1,   1, 0,  //
                                      0, kNan, 1.5, 1, 0,  //
                                      0, 0,    0,   0, 0};
  const Calibration cal{2.0, -1.0};
  const BlockScores s = ScoreBlock(logits, 4, 5, 1, cal, -9999.0f);
  ASSERT_EQ(s.p.size(), 6u);
  const double p2 = 1 / (1 + std::exp(-(2 * 2.0 - 1)));
  EXPECT_FLOAT_EQ(s.p[0], static_cast<float>(p2));
  EXPECT_EQ(s.p[3], -9999.0f);  // the NaN logit
  EXPECT_EQ(s.reward[3], -9999.0f);
  const double h = -(p2 * std::log2(p2) + (1 - p2) * std::log2(1 - p2));
  EXPECT_NEAR(s.reward[0], h, 1e-6);
  EXPECT_EQ(s.scored, 5);
  // Maxima: (1, 1) (logit 2); (2, 2) has 1.5 beside 2 diagonally: not one; (1, 3) sees the
  // 9 in the margin: not one.
  ASSERT_EQ(s.peak_row.size(), 1u);
  EXPECT_EQ(s.peak_row[0], 1);
  EXPECT_EQ(s.peak_col[0], 1);
  EXPECT_EQ(s.peak_logit[0], 2.0);
  EXPECT_DOUBLE_EQ(s.peak_p[0], p2);
}

TEST(BlockScores, APlateauIsAMaximumEverywhereAndNoCoreIsRefused) {
  const std::vector<double> flat(9, 0.5);
  const BlockScores s = ScoreBlock(flat, 3, 3, 0, Calibration{}, -1.0f);
  EXPECT_EQ(s.peak_row.size(), 9u);  // ties count, as numpy's q == maximum_filter(q)
  EXPECT_NEAR(s.p_sum, 9 / (1 + std::exp(-0.5)), 1e-12);
  EXPECT_THROW(ScoreBlock(flat, 3, 3, 2, Calibration{}, -1.0f), InputError);
  EXPECT_THROW(ScoreBlock(flat, 3, 4, 0, Calibration{}, -1.0f), InputError);
}

}  // namespace
}  // namespace mound::scene
