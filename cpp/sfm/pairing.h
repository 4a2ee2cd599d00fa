// Which image pairs to match (COLMAP's exhaustive, sequential and spatial matchers, in one
// choice): every pair is matched only when the set is small and its images are not located;
// otherwise each image is paired with the next `sequence_window` images in capture order
// and, where positions are known (GPS, the simulator's poses), with its nearest neighbours
// by position: up to `spatial_neighbours` per image within a distance limit, and, where the
// height above the ground is known (`ground_z`), only those whose nadir footprints overlap
// by at least `min_overlap`. Located images are thus matched with the ones that see the same
// ground, not with all of them. Images without a position in a set too large for every
// pair are paired, where their global descriptors are given (sfm/retrieval), with the
// images that look most like them.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace mound::sfm {

struct PairingOptions {
  int exhaustive_up_to = 20;   // unlocated sets this small: every pair
  int sequence_window = 3;     // images ahead in capture order (0: none)
  int spatial_neighbours = 8;  // nearest located images per image
  // Neighbours no farther than this (0: `max_distance_factor` times the median distance
  // of the located images to their nearest neighbour, so that separate sites on one card
  // are not joined by their nearest images; 0 and 0: no limit).
  double max_distance_m = 0;
  double max_distance_factor = 10;
  // Nadir footprints (optional): the ground's height in the positions' frame, and the
  // camera's field of view as focal length and image size in pixels.
  std::optional<double> ground_z;
  double focal_px = 0;
  int width_px = 0, height_px = 0;
  double min_overlap = 0.3;      // of the smaller footprint's area, heading unknown
  int retrieval_neighbours = 8;  // most similar images per unlocated image
};

struct PairSelection {
  std::vector<std::pair<int, int>> pairs;  // i < j, sorted, unique
  // "exhaustive", "sequential", "spatial", "spatial+footprint", each but the first with
  // "+retrieval" when unlocated images were paired by appearance.
  std::string method;
  int located = 0;            // images with a position
  double max_distance_m = 0;  // the limit applied (0: none)
};

// `positions[i]`: image i's position (metres, any local frame with z up), or nothing.
// Whether SelectPairs pairs some images by appearance: `retrieval_neighbours` > 0 and some
// image has no position, in a set beyond every pair (so `similar` is worth computing).
bool PairsByAppearance(const std::vector<std::optional<Eigen::Vector3d>>& positions,
                       const PairingOptions& options);

// Images are in capture order. `similar` (optional, sfm::MostSimilar): each image's most
// similar images, most similar first; used for the images without a position when
// PairsByAppearance.
PairSelection SelectPairs(const std::vector<std::optional<Eigen::Vector3d>>& positions,
                          const PairingOptions& options,
                          const std::vector<std::vector<int>>* similar = nullptr);

// The overlap of two nadir footprints (discs of the image's half-diagonal on the ground:
// the heading is unknown), as a fraction of the smaller one's area; heights above ground
// `h1`, `h2` > 0, horizontal distance `d`.
double FootprintOverlap(double h1, double h2, double d, double focal_px, int width_px,
                        int height_px);

}  // namespace mound::sfm
