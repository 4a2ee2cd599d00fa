// Retrieval on a synthetic strip: 40 images, each seeing 30 of 300 landmarks (a window
// moving 7 landmarks per image, so images up to 4 apart overlap), shuffled so that the
// capture order says nothing. Landmark descriptors are drawn around 20 texture prototypes
// (as real SIFT descriptors cluster), observed with noise, and every image adds clutter of
// its own. Retrieval must find overlapping images, not images of the same textures.
#include "sfm/retrieval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "sfm/pairing.h"

namespace mound::sfm {
namespace {

constexpr int kImages = 40, kLandmarks = 300, kStep = 7, kSeen = 30;

struct Strip {
  std::vector<ImageFeatures> features;
  std::vector<int> place;  // image index -> position along the strip
};

Strip MakeStrip(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> gauss(0, 1);
  auto clamp_row = [](Eigen::Matrix<float, 1, 128>& d) { d = d.cwiseMax(0.0f); };
  std::vector<Eigen::Matrix<float, 1, 128>> proto(20), landmark(kLandmarks);
  for (auto& p : proto)
    for (int c = 0; c < 128; ++c) p[c] = 40 * std::abs(gauss(rng));
  for (int l = 0; l < kLandmarks; ++l) {
    landmark[l] = proto[rng() % proto.size()];
    for (int c = 0; c < 128; ++c) landmark[l][c] += 12 * gauss(rng);
    clamp_row(landmark[l]);
  }
  Strip s;
  s.place.resize(kImages);
  std::iota(s.place.begin(), s.place.end(), 0);
  std::shuffle(s.place.begin(), s.place.end(), rng);
  for (int i = 0; i < kImages; ++i) {
    const int first = s.place[i] * kStep;
    std::vector<Eigen::Matrix<float, 1, 128>> rows;
    for (int l = first; l < std::min(kLandmarks, first + kSeen); ++l) {
      Eigen::Matrix<float, 1, 128> d = landmark[l];
      for (int c = 0; c < 128; ++c) d[c] += 4 * gauss(rng);
      clamp_row(d);
      rows.push_back(d);
    }
    for (int c = 0; c < 20; ++c) {  // clutter: this image's own
      Eigen::Matrix<float, 1, 128> d = proto[rng() % proto.size()];
      for (int k = 0; k < 128; ++k) d[k] += 12 * gauss(rng);
      clamp_row(d);
      rows.push_back(d);
    }
    ImageFeatures f;
    f.descriptors.resize(static_cast<Eigen::Index>(rows.size()), 128);
    for (size_t r = 0; r < rows.size(); ++r)
      f.descriptors.row(static_cast<Eigen::Index>(r)) = rows[r];
    s.features.push_back(std::move(f));
  }
  return s;
}

TEST(Retrieval, FindsTheImagesThatOverlapNotThoseOfTheSameTextures) {
  const Strip s = MakeStrip(11);
  RetrievalOptions o;
  o.words = 16;
  o.sample_per_image = 50;
  const Eigen::MatrixXf g = GlobalDescriptors(s.features, o);
  ASSERT_EQ(g.rows(), kImages);
  for (int i = 0; i < kImages; ++i) EXPECT_NEAR(g.row(i).norm(), 1.0f, 1e-4f);
  const auto similar = MostSimilar(g, 3);
  int overlapping = 0;
  for (int i = 0; i < kImages; ++i) {
    ASSERT_EQ(similar[i].size(), 3u);
    for (int j : similar[i]) overlapping += std::abs(s.place[i] - s.place[j]) * kStep < kSeen;
  }
  // All but a few of the 120 retrieved images overlap (random ones would in 8 of 40).
  EXPECT_GE(overlapping, 114) << overlapping;
  // The same input, the same descriptors.
  EXPECT_TRUE(g.isApprox(GlobalDescriptors(s.features, o)));
}

TEST(Retrieval, UnlocatedImagesArePairedByAppearanceAndTheSetIsConnected) {
  const Strip s = MakeStrip(12);
  const auto similar = MostSimilar(GlobalDescriptors(s.features, {}), 4);
  PairingOptions po;
  po.exhaustive_up_to = 20;  // 40 images: too many for every pair
  po.sequence_window = 0;    // capture order says nothing here
  po.retrieval_neighbours = 4;
  const std::vector<std::optional<Eigen::Vector3d>> none(kImages);
  EXPECT_TRUE(PairsByAppearance(none, po));
  const PairSelection sel = SelectPairs(none, po, &similar);
  EXPECT_EQ(sel.method, "sequential+retrieval");
  EXPECT_LE(sel.pairs.size(), size_t{kImages * 4});
  EXPECT_GE(sel.pairs.size(), size_t{kImages * 2});
  // Connected along the strip: every image has a retrieved pair with a neighbour on it.
  std::vector<int> parent(kImages);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  int far = 0;
  for (const auto& [i, j] : sel.pairs) {
    parent[root(i)] = root(j);
    far += std::abs(s.place[i] - s.place[j]) * kStep >= kSeen;
  }
  for (int i = 0; i < kImages; ++i) EXPECT_EQ(root(i), root(0)) << i;
  EXPECT_LE(far, 6);
  // Without descriptors the same set falls back to the sequence alone (here: nothing).
  EXPECT_EQ(SelectPairs(none, po).method, "sequential");
  EXPECT_TRUE(SelectPairs(none, po).pairs.empty());
  // Retrieval is asked for only where it is used: not for a set small enough for every
  // pair, not when every image is located, not with no retrieval neighbours.
  PairingOptions small = po;
  small.exhaustive_up_to = kImages;
  EXPECT_FALSE(PairsByAppearance(none, small));
  EXPECT_EQ(SelectPairs(none, small, &similar).method, "exhaustive");
  std::vector<std::optional<Eigen::Vector3d>> all(kImages);
  for (int i = 0; i < kImages; ++i) all[i] = Eigen::Vector3d(10.0 * i, 0, 50);
  EXPECT_FALSE(PairsByAppearance(all, po));
  EXPECT_EQ(SelectPairs(all, po, &similar).method, "spatial");
  PairingOptions off = po;
  off.retrieval_neighbours = 0;
  EXPECT_FALSE(PairsByAppearance(none, off));
  EXPECT_EQ(SelectPairs(none, off, &similar).method, "sequential");
}

TEST(Retrieval, EmptyAndDegenerateInputs) {
  std::vector<ImageFeatures> f(3);  // no descriptors at all
  const Eigen::MatrixXf g = GlobalDescriptors(f, {});
  EXPECT_EQ(g.rows(), 3);
  EXPECT_EQ(g.norm(), 0.0f);
  const auto s = MostSimilar(g, 5);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0], (std::vector<int>{1, 2}));  // ties by index, at most n - 1
  RetrievalOptions bad;
  bad.words = 0;
  EXPECT_ANY_THROW(GlobalDescriptors(f, bad));
  EXPECT_TRUE(MostSimilar(Eigen::MatrixXf(0, 8), 3).empty());
}

}  // namespace
}  // namespace mound::sfm
