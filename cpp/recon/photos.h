// A photo card as it comes off the aircraft: every file under a folder (recursively, links
// to folders not followed, unreadable folders skipped and reported), what kind of file it
// is by its first bytes, and the EXIF facts of each image. Headers only: no pixels are
// decoded. `mound_recon photos CARD_DIR` writes it as JSON (mound.photo_list v1) for the
// photo sorter (python/mound/photos).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "recon/exif.h"

namespace mound::recon {

struct CardFile {
  std::string file;  // relative to the card's folder, '/'-separated
  std::string kind;  // jpeg, tiff, png, not_an_image, unreadable, bad_name (not UTF-8:
                     // `file` then has each bad byte as \xNN and is not opened)
  uint64_t bytes = 0;
  Exif exif;  // jpeg and tiff only
};

struct CardListing {
  std::vector<CardFile> files;       // sorted by file
  std::vector<std::string> skipped;  // folders that could not be read, with the reason
};

// Throws InputError when `dir` is not a readable folder.
CardListing ListCard(const std::string& dir);

}  // namespace mound::recon
