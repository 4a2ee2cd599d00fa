#include "sim/render_job.h"

#include <cmath>
#include <filesystem>
#include <map>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/npy.h"
#include "geometry/json_io.h"

namespace mound::sim {
namespace {

using nlohmann::json;

double RequirePositive(const json& obj, const std::string& key, const std::string& path) {
  const double v = RequireFinite(obj, key, path);
  if (v <= 0) throw InputError(JoinPath(path, key) + ": must be > 0, got " + FormatNumber(v));
  return v;
}

Heightfield LoadHeightfield(const json& h, const std::string& dir) {
  const std::string file =
      ResolveDataFile(dir, RequireString(h, "npy", "heightfield"), "heightfield.npy");
  const NpyArray a = ReadNpy(file);
  if (a.descr == "|u1" || a.shape.size() != 2 || a.shape[0] < 2 || a.shape[1] < 2 ||
      a.shape[0] > 100000 || a.shape[1] > 100000) {
    throw InputError("heightfield.npy: " + file +
                     " must be a float array of shape (ny, nx), 2 <= ny, nx <= 100000");
  }
  Heightfield hf;
  hf.x0_m = RequireFinite(h, "x0_m", "heightfield");
  hf.y0_m = RequireFinite(h, "y0_m", "heightfield");
  hf.spacing_m = RequirePositive(h, "spacing_m", "heightfield");
  hf.ny = static_cast<int>(a.shape[0]);
  hf.nx = static_cast<int>(a.shape[1]);
  for (double z : a.AsDouble()) {
    if (!std::isfinite(z))
      throw InputError("heightfield.npy: " + file + " has a non-finite height");
    hf.z_m.push_back(static_cast<float>(z));
  }
  return hf;
}

Texture LoadTexture(const json& t, const std::string& dir) {
  const std::string file = ResolveDataFile(dir, RequireString(t, "npy", "texture"), "texture.npy");
  NpyArray a = ReadNpy(file);
  if (a.descr != "|u1" || a.shape.size() != 3 || a.shape[2] != 3 || a.shape[0] < 1 ||
      a.shape[1] < 1 || a.shape[0] > 100000 || a.shape[1] > 100000) {
    throw InputError("texture.npy: " + file + " must be a uint8 array of shape (h, w, 3)");
  }
  return Texture(RequireFinite(t, "x0_m", "texture"), RequireFinite(t, "y0_m", "texture"),
                 RequirePositive(t, "texel_m", "texture"), static_cast<int>(a.shape[1]),
                 static_cast<int>(a.shape[0]), std::move(a.data));
}

std::string CheckImageFile(const std::string& file, const std::string& path) {
  const std::filesystem::path p(file);
  const std::string ext = p.extension().string();
  if (file.empty() || p.is_absolute() || file.find("..") != std::string::npos) {
    throw InputError(path + ": must be a relative path inside the output directory, got '" + file +
                     "'");
  }
  if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") {
    throw InputError(path + ": must end in .png, .jpg or .jpeg, got '" + file + "'");
  }
  return file;
}

}  // namespace

RenderJob LoadRenderJob(const std::string& path) {
  return ParseRenderJob(ReadFile(path), path, std::filesystem::path(path).parent_path().string());
}

RenderJob ParseRenderJob(const std::string& text, const std::string& path, const std::string& dir) {
  const json doc = ParseJson(text, path);
  CheckSchema(doc, "mound.render", 1, path);
  RenderJob job;
  job.scene.terrain = LoadHeightfield(RequireField(doc, "heightfield", ""), dir);
  job.scene.texture = LoadTexture(RequireField(doc, "texture", ""), dir);
  job.camera = geometry::CameraFromJson(RequireField(doc, "camera", ""), "camera");
  if (static_cast<long long>(job.camera.width) * job.camera.height > 64LL * 1000 * 1000) {
    throw InputError("camera: width x height must be at most 64 megapixels");  // the frame buffers
  }
  if (doc.contains("background_rgb")) {
    const std::vector<double> bg = RequireNumbers(doc, "background_rgb", "", 3);
    for (int c = 0; c < 3; ++c) {
      if (bg[c] < 0 || bg[c] > 255) throw InputError("background_rgb: values must be in [0, 255]");
      job.scene.background_rgb[c] = bg[c];
    }
  }
  job.noise_sigma = OptionalNonNegative(doc, "noise_sigma", "").value_or(0);
  job.vignetting = OptionalNonNegative(doc, "vignetting", "").value_or(0);
  if (job.vignetting >= 1) throw InputError("vignetting: must be in [0, 1)");
  if (doc.contains("seed"))
    job.seed = static_cast<uint64_t>(RequireInt(doc, "seed", "", 0, 2147483647));
  const json& images = RequireField(doc, "images", "");
  if (!images.is_array() || images.empty()) throw InputError("images: expected a non-empty array");
  std::map<std::string, size_t> stems;  // output stem (no extension) -> first image with it
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string p = "images[" + std::to_string(k) + "]";
    if (!images[k].is_object()) throw InputError(p + ": expected an object");
    ImageJob im;
    im.file = CheckImageFile(RequireString(images[k], "file", p), JoinPath(p, "file"));
    // Two images with one output name (or one stem: their .depth.npy would collide) would
    // overwrite each other: a job error, not a race.
    const std::string stem =
        std::filesystem::path(im.file).lexically_normal().replace_extension().string();
    const auto [it, fresh] = stems.emplace(stem, k);
    if (!fresh) {
      throw InputError(JoinPath(p, "file") + ": '" + im.file + "' is the same output as images[" +
                       std::to_string(it->second) + "]");
    }
    const std::string pp = JoinPath(p, "cam_from_world");
    im.cam_from_world = geometry::PoseFromJson(RequireField(images[k], "cam_from_world", p), pp);
    const Eigen::Vector3d c = im.cam_from_world.Centre();
    double ground = 0;
    if (job.scene.terrain.HeightAt(c[0], c[1], &ground) && c[2] <= ground) {
      throw InputError(pp + ": the camera centre (" + FormatNumber(c[0]) + ", " +
                       FormatNumber(c[1]) + ", " + FormatNumber(c[2]) +
                       ") m is below the ground (" + FormatNumber(ground) + " m)");
    }
    job.images.push_back(std::move(im));
  }
  return job;
}

}  // namespace mound::sim
