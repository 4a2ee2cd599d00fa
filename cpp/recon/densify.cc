#include "recon/densify.h"

#include <algorithm>
#include <filesystem>

#include "common/error.h"
#include "common/json_util.h"
#include "common/stats.h"
#include "common/timing.h"
#include "geometry/json_io.h"
#include "recon/recon_io.h"

namespace mound::recon {
namespace {

// The model's camera, registered images and sparse points (validated).
mvs::DenseInput ReadModel(const std::string& dir, const nlohmann::json& recon,
                          const std::string& images_dir, std::vector<std::string>* files) {
  const std::string path = dir + "/recon.json";
  mvs::DenseInput in;
  try {
    in.camera = geometry::CameraFromJson(RequireField(recon, "camera", ""), "camera");
    const nlohmann::json& images = RequireField(recon, "images", "");
    if (!images.is_array()) throw InputError("images: expected an array");
    for (size_t k = 0; k < images.size(); ++k) {
      const std::string at = "images[" + std::to_string(k) + "]";
      if (!images[k].is_object()) throw InputError(at + ": expected an object");
      if (!images[k].value("registered", false)) continue;
      const std::string file = RequireString(images[k], "file", at);
      in.cam_from_world.push_back(geometry::PoseFromJson(
          RequireField(images[k], "cam_from_world", at), at + ".cam_from_world"));
      in.image_paths.push_back(images_dir + "/" + file);
      files->push_back(file);
    }
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  if (in.image_paths.size() < 2) {
    throw InputError(path + ": images: " + std::to_string(in.image_paths.size()) +
                     " registered image(s); dense stereo needs at least 2");
  }
  const geometry::PlyCloud sparse = ReadCloud(dir + "/points.ply", "RECON_DIR/points.ply");
  in.sparse_points = sparse.xyz;
  return in;
}

}  // namespace

void DensifyOptions::Check() const {
  if (recon_dir.empty()) throw InputError("RECON_DIR: empty");
  dense.Check();
}

DensifyResult Densify(const DensifyOptions& options) {
  options.Check();
  const mvs::DenseOptions& o = options.dense;
  const std::string& dir = options.recon_dir;
  const bool images_given = !options.images_dir.empty();
  const std::string recon_path = dir + "/recon.json";
  const nlohmann::json recon = LoadRecon(recon_path);
  // A field's text, or "" when it is absent or not a string.
  auto text = [&](const char* key) {
    return recon.contains(key) && recon[key].is_string() ? recon[key].get<std::string>()
                                                         : std::string();
  };
  const std::string status = RequireString(recon, "status", "");
  if (status != "ok") {
    const std::string reason = text("reason");
    throw InputError(recon_path + ": status: the reconstruction " + status + " (" +
                     (reason.empty() ? "no reason given" : reason) + "); nothing to densify");
  }
  if (text("frame") != "enu" || text("scale") != "metric") {
    throw InputError(recon_path +
                     ": frame: densify needs a georeferenced model (frame enu, metric scale: "
                     "run reconstruct with --gps)");
  }
  const std::string images_dir =
      images_given ? options.images_dir : RequireString(recon, "images_dir", "");
  std::error_code ec;
  if (!std::filesystem::is_directory(images_dir, ec)) {
    throw InputError((images_given ? "--images: " : recon_path + ": images_dir: ") + images_dir +
                     " is not a directory (give the images with --images)");
  }
  std::vector<std::string> files;
  const mvs::DenseInput in = ReadModel(dir, recon, images_dir, &files);
  nlohmann::json doc = {{"schema", "mound.dense"},
                        {"version", 1},
                        {"tool", "mound_recon densify"},
                        {"recon_dir", dir},
                        {"images_dir", images_dir},
                        {"status", "ok"},
                        {"frame", "enu"}};
  if (recon.contains("origin")) doc["origin"] = recon["origin"];
  doc["method"] =
      "plane sweep along the vertical, NCC over the best views, forward-backward consistency, "
      "voxel fusion";
  doc["options"] = {{"resolution_m", o.resolution_m},
                    {"max_image_size", o.max_image_size},
                    {"source_views", o.source_views},
                    {"best_views", o.best_views},
                    {"window", o.window},
                    {"min_ncc", o.min_ncc},
                    {"min_texture", o.min_texture},
                    {"min_consistent", o.min_consistent},
                    {"max_reprojection_px", o.max_reprojection_px},
                    {"max_relative_depth", o.max_relative_depth},
                    {"max_step_px", o.max_step_px},
                    {"threads", o.threads}};
  const int n = static_cast<int>(in.image_paths.size());
  auto t0 = Clock::now();
  const std::vector<std::vector<int>> sources = mvs::SelectSourceViews(in, o.source_views);
  const double select_s = Since(t0);
  t0 = Clock::now();
  int images_read = 0;
  const std::vector<mvs::DepthMap> maps = mvs::ComputeDepthMaps(in, sources, o, &images_read);
  const double depth_s = Since(t0);
  doc["images_read"] = images_read;  // each image once while they fit in memory
  t0 = Clock::now();
  mvs::DenseCloud cloud = mvs::FuseDepthMaps(maps, o);
  // The site: the horizontal extent of the sparse model (its 1st to 99th percentiles);
  // oblique views also see far ground at grazing angles, which the sparse model leaves out.
  std::vector<double> xs, ys;
  for (const Eigen::Vector3d& p : in.sparse_points) {
    xs.push_back(p.x());
    ys.push_back(p.y());
  }
  const double x0 = Quantile(xs, 0.01), x1 = Quantile(xs, 0.99), y0 = Quantile(ys, 0.01),
               y1 = Quantile(ys, 0.99);
  geometry::PlyCloud ply;
  ply.comments = {
      "mound.dense v1: fused multi-view stereo points, ENU metres; nx ny nz: unit normal; support: "
      "depth-map pixels merged"};
  for (const char* f : {"nx", "ny", "nz", "support"}) ply.scalars[f];
  for (size_t k = 0; k < cloud.xyz.size(); ++k) {
    const Eigen::Vector3d& p = cloud.xyz[k];
    if (p.x() < x0 || p.x() > x1 || p.y() < y0 || p.y() > y1) continue;
    ply.xyz.push_back(p);
    ply.rgb.push_back(cloud.rgb[k]);
    ply.scalars["nx"].push_back(cloud.normal[k].x());
    ply.scalars["ny"].push_back(cloud.normal[k].y());
    ply.scalars["nz"].push_back(cloud.normal[k].z());
    ply.scalars["support"].push_back(cloud.support[k]);
  }
  const double fuse_s = Since(t0);
  nlohmann::json per = nlohmann::json::array();
  int depth_pixels = 0;
  for (int i = 0; i < n; ++i) {
    const mvs::DepthMap& m = maps[i];
    nlohmann::json src = nlohmann::json::array();
    for (int j : m.sources) src.push_back(files[j]);
    per.push_back({{"file", files[i]},
                   {"sources", src},
                   {"size", {m.width, m.height}},
                   {"planes", m.planes},
                   {"height_range_m", {m.height_min, m.height_max}},
                   {"depth_pixels", m.valid},
                   {"consistent_pixels", cloud.consistent_pixels[i]},
                   {"seconds", m.seconds}});
    depth_pixels += m.valid;
  }
  doc["images"] = per;
  doc["site_bounds_enu_m"] = {{"x", {x0, x1}}, {"y", {y0, y1}}};
  doc["points"] = ply.xyz.size();
  doc["depth_pixels"] = depth_pixels;
  doc["timings_s"] = {{"select_views", select_s}, {"depth_maps", depth_s}, {"fusion", fuse_s}};
  if (ply.xyz.empty()) {
    doc["status"] = "failed";
    doc["reason"] = "no depth survived the consistency check (too little texture or overlap)";
    return {doc, geometry::PlyCloud{}};
  }
  doc["cloud"] = "dense.ply";
  return {doc, std::move(ply)};
}

}  // namespace mound::recon
