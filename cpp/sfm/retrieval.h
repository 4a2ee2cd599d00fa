// Image retrieval for sets without positions (issue 29): each image gets one global
// descriptor, so that a set too large for every pair is matched only where images look
// alike, as COLMAP's vocabulary-tree matcher does. The descriptor is VLAD (Jegou, Douze,
// Schmid, Perez, "Aggregating local descriptors into a compact image representation",
// CVPR 2010) over a codebook learnt on the set itself (k-means++ and Lloyd iterations on a
// sample of its RootSIFT descriptors): per visual word the sum of the residuals of the
// descriptors assigned to it, each word's block L2-normalised (intra-normalisation,
// Arandjelovic and Zisserman 2013), signed square roots, the whole L2-normalised. The
// similarity of two images is the dot product of their descriptors.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "sfm/features.h"

namespace mound::sfm {

struct RetrievalOptions {
  int words = 64;              // codebook size (VLAD dimension: 128 x words)
  int sample_per_image = 400;  // descriptors per image the codebook learns from
  int iterations = 12;         // Lloyd iterations
  uint64_t seed = 7;
};

// One row per image: L2-normalised VLAD (all zeros for an image without descriptors).
Eigen::MatrixXf GlobalDescriptors(const std::vector<ImageFeatures>& features,
                                  const RetrievalOptions& options = {});

// The `k` most similar other images of each image (most similar first) by the rows of
// `global` (GlobalDescriptors); ties by index.
std::vector<std::vector<int>> MostSimilar(const Eigen::MatrixXf& global, int k);

}  // namespace mound::sfm
