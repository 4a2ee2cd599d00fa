// The densify pipeline of mound_recon as a library function: a georeferenced sparse model
// (recon.json + points.ply) and its images in, the fused dense cloud (cpp/mvs: plane sweep,
// consistency, voxel fusion) cropped to the site out, with dense.json's document. The CLI
// maps its flags onto DensifyOptions and writes the files; nothing here writes.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "geometry/ply.h"
#include "mvs/dense.h"

namespace mound::recon {

struct DensifyOptions {
  std::string recon_dir;   // recon.json and points.ply of `mound_recon reconstruct`
  std::string images_dir;  // empty: recon.json's images_dir
  mvs::DenseOptions dense;
  void Check() const;  // InputError naming the option (dense's as the CLI spells them)
};

struct DensifyResult {
  nlohmann::json doc;  // dense.json: status ok, or failed with reason (then `cloud` is empty)
  // ENU metres, with colours and the scalars nx ny nz (unit normal) and support (depth-map
  // pixels merged); only the points within the sparse model's horizontal extent (its 1st
  // to 99th percentiles): oblique views also see far ground at grazing angles.
  geometry::PlyCloud cloud;
};

// InputError for a model that failed, is not georeferenced (frame enu, metric scale), has
// fewer than 2 registered images, or whose images are missing; a result with `status:
// failed` when no depth survived the consistency check.
DensifyResult Densify(const DensifyOptions& options);

}  // namespace mound::recon
