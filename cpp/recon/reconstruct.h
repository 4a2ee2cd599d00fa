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

#include "common/enum_names.h"
#include "sfm/features.h"
#include "sfm/reconstruction.h"

namespace mound::recon {

enum class FeatureKind { kSift, kKlt };
// kAuto: SelectPairs' choice (spatial from GPS, exhaustive for small sets, appearance for
// images without a position); kSequential: the next `window` images only.
enum class Matching { kAuto, kExhaustive, kSequential, kRetrieval };
enum class GpsSource { kNone, kExif, kPosesFile };
// kAuto: kLevel with EXIF GPS (consumer GPS heights drift), else kFull.
enum class Align { kAuto, kLevel, kFull };
// The lens when the camera comes from EXIF: refined in bundle adjustment with a prior
// about EXIF's values (f sd 1 %, k1 and k2 sd 0.01, OpenSfM's defaults: the default),
// refined freely (COLMAP's self-calibration), or held at EXIF's values (ODM's
// --use-fixed-camera-params).
enum class Lens { kPrior, kFree, kFixed };

// Their names in flags and in recon.json.
inline constexpr EnumName<FeatureKind> kFeatureKindNames[] = {{FeatureKind::kSift, "sift"},
                                                              {FeatureKind::kKlt, "klt"}};
inline constexpr EnumName<Matching> kMatchingNames[] = {{Matching::kAuto, "auto"},
                                                        {Matching::kExhaustive, "exhaustive"},
                                                        {Matching::kSequential, "sequential"},
                                                        {Matching::kRetrieval, "retrieval"}};
inline constexpr EnumName<sfm::MatcherKind> kMatcherNames[] = {
    {sfm::MatcherKind::kFlann, "flann"},
    {sfm::MatcherKind::kCascadeHash, "cascade"},
    {sfm::MatcherKind::kExact, "exact"}};
inline constexpr EnumName<Align> kAlignNames[] = {{Align::kLevel, "level"}, {Align::kFull, "full"}};
inline constexpr EnumName<Lens> kLensNames[] = {
    {Lens::kPrior, "prior"}, {Lens::kFree, "free"}, {Lens::kFixed, "fixed"}};

struct ReconstructOptions {
  std::string images_dir;
  std::string camera_file;  // mound.camera JSON or K.txt; empty: EXIF, refined
  GpsSource gps = GpsSource::kNone;
  std::string poses_file;  // kPosesFile: a mound.poses file
  sfm::FeatureOptions features;
  FeatureKind feature_kind = FeatureKind::kSift;
  Matching matching = Matching::kAuto;
  sfm::MatcherKind matcher = sfm::MatcherKind::kCascadeHash;
  int window = 8;      // sequential: images ahead; auto, retrieval: at most 3
  int neighbours = 8;  // nearest (by GPS) or most similar images per image
  Align align = Align::kAuto;
  std::optional<Lens> lens;  // none: prior with EXIF (a camera file is calibrated: fixed)
  int threads = 1;
  uint64_t seed = 1;
  std::string tool;  // recon.json's "tool"
  // InputError naming the option as the CLI spells it ("--window: ...") when unusable.
  void Check() const;
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
