// mound_recon: the 3-D stage's command table (COLMAP's `colmap <command>` pattern):
//   mound_recon reconstruct IMAGES_DIR --out OUT_DIR [--camera camera.json|K.txt]
//               [--gps poses.json|exif] [--max-image-size PX] [--max-features N]
//               [--matching auto|exhaustive|sequential] [--threads N] [--seed N]
// Exit codes: 0 ok, 1 internal error, 2 bad input (one line naming it), 3 valid input that
// allowed no result (recon.json then says "status": "failed" and why).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace mound::recon {

int RunMoundRecon(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mound::recon
