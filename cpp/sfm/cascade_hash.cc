#include "sfm/cascade_hash.h"

#include <algorithm>
#include <bitset>
#include <limits>
#include <random>

namespace mound::sfm {

CascadeHasher::CascadeHasher(const Eigen::Matrix<float, 1, 128>& mean, uint64_t seed)
    : mean_(mean) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  for (int r = 0; r < 128; ++r)
    for (int c = 0; c < 128; ++c) primary_(r, c) = g(rng);
  for (int r = 0; r < kGroups * kBucketBits; ++r)
    for (int c = 0; c < 128; ++c) secondary_(r, c) = g(rng);
}

CascadeHasher::Hashed CascadeHasher::Hash(const Descriptors& d) const {
  Hashed h;
  const int n = static_cast<int>(d.rows());
  h.codes.resize(n);
  h.bucket.resize(n);
  for (auto& g : h.members) g.assign(1 << kBucketBits, {});
  if (n == 0) return h;
  for (int i = 0; i < n; ++i) {
    // Row by row dot products (a matrix-vector product of this size trips GCC 12's
    // -Waggressive-loop-optimizations inside Eigen).
    const Eigen::Matrix<float, 1, 128> c = d.row(i) - mean_;
    std::array<uint64_t, 2> code{0, 0};
    for (int b = 0; b < 128; ++b)
      if (primary_.row(b).dot(c) > 0) code[b >> 6] |= uint64_t{1} << (b & 63);
    h.codes[i] = code;
    for (int g = 0; g < kGroups; ++g) {
      int id = 0;
      for (int b = 0; b < kBucketBits; ++b)
        id = (id << 1) | (secondary_.row(g * kBucketBits + b).dot(c) > 0);
      h.bucket[i][g] = static_cast<uint8_t>(id);
      h.members[g][id].push_back(i);
    }
  }
  return h;
}

void CascadeHasher::Nearest2(const Descriptors& query, const Hashed& qh, const Descriptors& train,
                             const Hashed& th, const std::vector<int>& rows, int candidates,
                             std::vector<std::array<int, 2>>* index,
                             std::vector<std::array<float, 2>>* dist2) const {
  const int nq = rows.empty() ? static_cast<int>(query.rows()) : static_cast<int>(rows.size());
  index->assign(nq, {-1, -1});
  dist2->assign(nq,
                {std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()});
  const int nt = static_cast<int>(train.rows());
  std::vector<int> stamp(nt, -1);
  std::vector<int> found;
  std::array<std::vector<int>, 129> by_hamming;
  for (int k = 0; k < nq; ++k) {
    const int q = rows.empty() ? k : rows[k];
    found.clear();
    for (int g = 0; g < kGroups; ++g)
      for (int t : th.members[g][qh.bucket[q][g]])
        if (stamp[t] != k) {
          stamp[t] = k;
          found.push_back(t);
        }
    for (auto& v : by_hamming) v.clear();
    const auto& cq = qh.codes[q];
    for (int t : found) {
      const auto& ct = th.codes[t];
      const int hd = static_cast<int>(std::bitset<64>(cq[0] ^ ct[0]).count() +
                                      std::bitset<64>(cq[1] ^ ct[1]).count());
      by_hamming[hd].push_back(t);
    }
    int compared = 0;
    auto& bi = (*index)[k];
    auto& bd = (*dist2)[k];
    for (int hd = 0; hd <= 128 && compared < candidates; ++hd)
      for (int t : by_hamming[hd]) {
        if (compared >= candidates) break;
        ++compared;
        const float d = (query.row(q) - train.row(t)).squaredNorm();
        if (d < bd[0]) {
          bd[1] = bd[0];
          bi[1] = bi[0];
          bd[0] = d;
          bi[0] = t;
        } else if (d < bd[1]) {
          bd[1] = d;
          bi[1] = t;
        }
      }
  }
}

}  // namespace mound::sfm
