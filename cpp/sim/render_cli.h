// mound_render: renders the images of a render job (see render_job.h).
//
//   mound_render JOB.json --out DIR [--threads N] [--geometry]
//
// Writes every image of the job under DIR (PNG lossless, or JPEG quality 95, by extension),
// each atomically; with --geometry also <image>.depth.npy (float32 (h, w), camera-frame z in
// metres, NaN where no surface) and <image>.xyz.npy (float32 (h, w, 3), the ENU point seen).
// Prints a mound.render_result JSON summary on stdout. Exit codes as every tool: 0, 2, 1.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace mound::sim {

int RunMoundRender(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mound::sim
