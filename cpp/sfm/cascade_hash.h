// Cascade hashing for matching SIFT descriptors (Cheng, Leng, Wu, Cui, Lu, "Fast and
// accurate image matching with cascade hashing for 3D reconstruction", CVPR 2014; the
// matcher of OpenMVG): each descriptor, centred on the mean descriptor of the image set,
// gets a 128-bit code (signs of random projections) and, in each of 6 groups, an 8-bit
// bucket (signs of 8 more). A query's candidates are the descriptors sharing a bucket with
// it in any group; the `candidates` of them nearest in Hamming distance are compared
// exactly (L2), which gives the two nearest neighbours for the ratio test. About
// 6 N / 256 Hamming distances and `candidates` L2 distances per query instead of a k-d
// tree's traversal and checks.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace mound::sfm {

using Descriptors = Eigen::Matrix<float, Eigen::Dynamic, 128, Eigen::RowMajor>;

class CascadeHasher {
 public:
  static constexpr int kGroups = 6;
  static constexpr int kBucketBits = 8;

  // `mean`: the mean descriptor of the image set (the codes' centre); `seed`: the random
  // projections (the same for every image of a set).
  CascadeHasher(const Eigen::Matrix<float, 1, 128>& mean, uint64_t seed = 5);

  struct Hashed {
    std::vector<std::array<uint64_t, 2>> codes;                  // per descriptor
    std::vector<std::array<uint8_t, kGroups>> bucket;            // per descriptor
    std::array<std::vector<std::vector<int>>, kGroups> members;  // per group, per bucket
  };
  Hashed Hash(const Descriptors& d) const;

  // For each query row q (in `rows`, or all when empty) of `query`: its two nearest rows of
  // `train` among the candidates, indices (-1 when fewer) and squared L2 distances.
  void Nearest2(const Descriptors& query, const Hashed& query_hash, const Descriptors& train,
                const Hashed& train_hash, const std::vector<int>& rows, int candidates,
                std::vector<std::array<int, 2>>* index,
                std::vector<std::array<float, 2>>* dist2) const;

 private:
  Eigen::Matrix<float, 1, 128> mean_;
  Eigen::Matrix<float, 128, 128, Eigen::RowMajor> primary_;
  Eigen::Matrix<float, kGroups * kBucketBits, 128, Eigen::RowMajor> secondary_;
};

}  // namespace mound::sfm
