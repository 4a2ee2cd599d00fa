#include "sfm/tracks.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>

namespace mound::sfm {

std::vector<std::vector<TrackElement>> BuildTracks(const std::vector<VerifiedPair>& pairs,
                                                   const std::vector<int>& kps) {
  std::vector<int> offset(kps.size() + 1, 0);
  for (size_t i = 0; i < kps.size(); ++i) offset[i + 1] = offset[i] + kps[i];
  std::vector<int> parent(offset.back());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const VerifiedPair& p : pairs) {
    for (const auto& [a, b] : p.inliers) {
      const int ra = find(offset[p.image1] + a), rb = find(offset[p.image2] + b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  std::unordered_map<int, std::vector<TrackElement>> by_root;
  for (size_t i = 0; i < kps.size(); ++i) {
    for (int k = 0; k < kps[i]; ++k) {
      by_root[find(offset[i] + k)].push_back({static_cast<int>(i), k});
    }
  }
  std::vector<std::vector<TrackElement>> tracks;
  for (auto& [root, t] : by_root) {
    if (t.size() < 2) continue;
    std::sort(t.begin(), t.end(), [](const TrackElement& a, const TrackElement& b) {
      return a.image != b.image ? a.image < b.image : a.keypoint < b.keypoint;
    });
    bool twice = false;
    for (size_t j = 1; j < t.size(); ++j) twice |= t[j].image == t[j - 1].image;
    if (!twice) tracks.push_back(std::move(t));
  }
  std::sort(tracks.begin(), tracks.end(), [](const auto& a, const auto& b) {
    return a.front().image != b.front().image ? a.front().image < b.front().image
                                              : a.front().keypoint < b.front().keypoint;
  });
  return tracks;
}

}  // namespace mound::sfm
