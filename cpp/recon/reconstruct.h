// One site's reconstruction from its images, as `mound_recon reconstruct` runs it (COLMAP's
// RunMapperImpl behind RunMapper): features (SIFT, or KLT tracks), the pairs to match
// (sfm::SelectPairs: from the photos' positions where known), matching and geometric
// verification, the incremental mapper, and the metric frame from GPS (a robust similarity,
// or the levelled fit for consumer GPS heights). The CLI maps its flags onto the options
// and writes the files; nothing here writes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sfm/features.h"
#include "sfm/reconstruction.h"

namespace mound::recon {

struct ReconstructOptions {
  std::string images_dir;
  std::string camera_file;  // mound.camera JSON or K.txt; empty: EXIF, refined
  std::string gps;          // empty: none; "exif"; else a mound.poses file
  sfm::FeatureOptions features;
  std::string feature_kind = "sift";  // sift | klt
  std::string matching = "auto";      // auto | exhaustive | sequential | retrieval
  std::string matcher = "cascade";    // cascade | flann (sfm::MatcherKind)
  int window = 8;                     // sequential: images ahead; auto, retrieval: at most 3
  int neighbours = 8;                 // nearest (by GPS) or most similar images per image
  std::string align;                  // level | full; empty: level with EXIF GPS, else full
  int threads = 1;
  uint64_t seed = 1;
  std::string tool;  // recon.json's "tool"
  // Empty when usable, else what is wrong, naming the option as the CLI spells it.
  std::string Check() const;
};

struct ReconstructResult {
  nlohmann::json doc;                        // recon.json: status ok, or failed with reason
  std::vector<std::string> files;            // the images, sorted by name
  std::vector<sfm::ImageFeatures> features;  // per image
  std::optional<sfm::Reconstruction> model;  // none when failed
};

// InputError for bad input (naming the file or option); a result with `status: failed`
// and no model when valid input allowed no reconstruction.
ReconstructResult Reconstruct(const ReconstructOptions& options);

}  // namespace mound::recon
