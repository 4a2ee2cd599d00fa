// Tracks: the observations of one scene point across images, from the verified matches
// of image pairs (union-find over (image, keypoint), as COLMAP's correspondence graph).
#pragma once

#include <vector>

#include "sfm/features.h"

namespace mound::sfm {

struct TrackElement {
  int image = 0, keypoint = 0;
};

// Union-find over (image, keypoint) of the verified matches; tracks that would see one
// image twice are dropped.
std::vector<std::vector<TrackElement>> BuildTracks(const std::vector<VerifiedPair>& pairs,
                                                   const std::vector<int>& keypoints_per_image);

}  // namespace mound::sfm
