#include "sfm/pairing.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace mound::sfm {
namespace {

bool Has(const PairSelection& s, int i, int j) {
  return std::binary_search(s.pairs.begin(), s.pairs.end(),
                            std::make_pair(std::min(i, j), std::max(i, j)));
}

// A raster of 3 lines of 6 images (10 m apart along a line, 25 m between lines) at 60 m,
// flown as a boustrophedon, then 6 images of another site 1 km east.
std::vector<std::optional<Eigen::Vector3d>> Layout() {
  std::vector<std::optional<Eigen::Vector3d>> p;
  for (int line = 0; line < 3; ++line)
    for (int k = 0; k < 6; ++k)
      p.push_back(Eigen::Vector3d((line % 2 ? 5 - k : k) * 10.0, line * 25.0, 60.0));
  for (int k = 0; k < 6; ++k) p.push_back(Eigen::Vector3d(1000.0 + 10 * k, 0.0, 60.0));
  return p;
}

TEST(Pairing, NeighboursByPositionNotFarPairs) {
  PairingOptions o;
  o.sequence_window = 1;
  o.spatial_neighbours = 6;
  const PairSelection s = SelectPairs(Layout(), o);
  EXPECT_EQ(s.method, "spatial");
  EXPECT_EQ(s.located, 24);
  EXPECT_TRUE(Has(s, 0, 1));    // along the line
  EXPECT_TRUE(Has(s, 0, 11));   // across lines: image 11 is above image 0 (boustrophedon)
  EXPECT_TRUE(Has(s, 18, 23));  // the other site among itself
  EXPECT_FALSE(Has(s, 0, 17));  // the far end of the next line but one
  for (const auto& [i, j] : s.pairs) {
    const bool a = i >= 18, b = j >= 18;
    if (a != b) {
      EXPECT_EQ(j, i + 1) << i << " " << j;  // only the sequence joins the sites
    }
  }
  EXPECT_LT(s.pairs.size(), 24u * 23u / 2u / 3u);
  EXPECT_DOUBLE_EQ(s.max_distance_m, 100.0);  // 10 x the median nearest distance, 10 m
  // Without the limit, the other site's images find their sixth neighbour here.
  o.max_distance_factor = 0;
  const PairSelection joined = SelectPairs(Layout(), o);
  EXPECT_TRUE(Has(joined, 5, 18));
}

TEST(Pairing, FootprintsDecideWhenTheGroundIsKnown) {
  PairingOptions o;
  o.sequence_window = 0;
  o.spatial_neighbours = 100;
  o.ground_z = 0.0;
  o.focal_px = 457;  // 70 degrees across 640 px
  o.width_px = 640;
  o.height_px = 480;
  o.min_overlap = 0.5;
  const PairSelection s = SelectPairs(Layout(), o);
  EXPECT_EQ(s.method, "spatial+footprint");
  EXPECT_TRUE(Has(s, 0, 1));
  EXPECT_FALSE(Has(s, 0, 18));  // 1 km apart: no common ground
  // Every pair kept overlaps by at least half, every pair left out by less.
  for (int i = 0; i < 24; ++i)
    for (int j = i + 1; j < 24; ++j) {
      const auto a = *Layout()[i], b = *Layout()[j];
      const double f = FootprintOverlap(60, 60, (a - b).head<2>().norm(), 457, 640, 480);
      EXPECT_EQ(Has(s, i, j), f >= 0.5) << i << " " << j << " " << f;
    }
  // Flying lower shrinks the footprints: fewer pairs.
  o.ground_z = 30.0;
  EXPECT_LT(SelectPairs(Layout(), o).pairs.size(), s.pairs.size());
}

TEST(Pairing, WithoutPositionsSmallSetsAreExhaustiveLargeOnesSequential) {
  std::vector<std::optional<Eigen::Vector3d>> none(12);
  PairSelection s = SelectPairs(none, PairingOptions{});
  EXPECT_EQ(s.method, "exhaustive");
  EXPECT_EQ(s.pairs.size(), 66u);
  none.resize(40);
  s = SelectPairs(none, PairingOptions{});
  EXPECT_EQ(s.method, "sequential");
  EXPECT_EQ(s.pairs.size(), 39u + 38u + 37u);
  EXPECT_EQ(s.located, 0);
}

TEST(Pairing, FootprintOverlapIsAFraction) {
  EXPECT_DOUBLE_EQ(FootprintOverlap(60, 60, 0, 457, 640, 480), 1.0);
  EXPECT_DOUBLE_EQ(FootprintOverlap(60, 60, 1000, 457, 640, 480), 0.0);
  EXPECT_DOUBLE_EQ(FootprintOverlap(10, 60, 5, 457, 640, 480), 1.0);  // inside the larger
  const double half = FootprintOverlap(60, 60, 30, 457, 640, 480);
  EXPECT_GT(half, 0.5);
  EXPECT_LT(half, 1.0);
  EXPECT_GT(half, FootprintOverlap(60, 60, 40, 457, 640, 480));
}

}  // namespace
}  // namespace mound::sfm
