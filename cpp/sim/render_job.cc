#include "sim/render_job.h"

#include <cmath>
#include <filesystem>
#include <map>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"
#include "sim/npy.h"

namespace mound::sim {
namespace {

using nlohmann::json;

// The array `a` found at `path`: exactly `count` finite numbers.
std::vector<double> FiniteNumbers(const json& a, const std::string& path, size_t count) {
  if (!a.is_array() || a.size() != count) {
    throw InputError(path + ": expected an array of " + std::to_string(count) + " numbers");
  }
  std::vector<double> out;
  for (size_t i = 0; i < count; ++i) {
    if (!a[i].is_number() || !std::isfinite(a[i].get<double>())) {
      throw InputError(path + "[" + std::to_string(i) + "]: expected a finite number");
    }
    out.push_back(a[i].get<double>());
  }
  return out;
}

std::vector<double> RequireNumbers(const json& obj, const std::string& key, const std::string& path,
                                   size_t count) {
  return FiniteNumbers(RequireField(obj, key, path), JoinPath(path, key), count);
}

// A 3x3 matrix as nested arrays, row-major.
std::vector<double> RequireMatrix3(const json& obj, const std::string& key, const std::string& path) {
  const json& m = RequireField(obj, key, path);
  const std::string p = JoinPath(path, key);
  if (!m.is_array() || m.size() != 3) throw InputError(p + ": expected a 3x3 array of numbers");
  std::vector<double> out;
  for (size_t r = 0; r < 3; ++r) {
    const std::vector<double> row = FiniteNumbers(m[r], p + "[" + std::to_string(r) + "]", 3);
    out.insert(out.end(), row.begin(), row.end());
  }
  return out;
}

double RequirePositive(const json& obj, const std::string& key, const std::string& path) {
  const double v = RequireFinite(obj, key, path);
  if (v <= 0) throw InputError(JoinPath(path, key) + ": must be > 0, got " + FormatNumber(v));
  return v;
}

int RequireInt(const json& obj, const std::string& key, const std::string& path, long long lo,
               long long hi) {
  const json& v = RequireField(obj, key, path);
  if (!v.is_number_integer() || v.get<long long>() < lo || v.get<long long>() > hi) {
    throw InputError(JoinPath(path, key) + ": expected an integer in [" + std::to_string(lo) +
                     ", " + std::to_string(hi) + "]");
  }
  return static_cast<int>(v.get<long long>());
}

// A data file named by the job: absolute, or relative to the job's folder; it must be a
// regular file (not a device, a pipe or a folder), so that an endless input such as
// /dev/zero is refused before it is read.
std::string Resolve(const std::string& base, const std::string& rel, const std::string& where) {
  if (rel.empty()) throw InputError(where + ": empty path");
  const std::filesystem::path p(rel);
  const std::string file = p.is_absolute() ? rel : (std::filesystem::path(base) / rel).string();
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (ec || !std::filesystem::exists(status)) {
    throw InputError(where + ": " + file + ": no such file");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw InputError(where + ": " + file + ": not a regular file");
  }
  return file;
}

Heightfield LoadHeightfield(const json& h, const std::string& dir) {
  const std::string file = Resolve(dir, RequireString(h, "npy", "heightfield"), "heightfield.npy");
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
    if (!std::isfinite(z)) throw InputError("heightfield.npy: " + file + " has a non-finite height");
    hf.z_m.push_back(static_cast<float>(z));
  }
  return hf;
}

Texture LoadTexture(const json& t, const std::string& dir) {
  const std::string file = Resolve(dir, RequireString(t, "npy", "texture"), "texture.npy");
  NpyArray a = ReadNpy(file);
  if (a.descr != "|u1" || a.shape.size() != 3 || a.shape[2] != 3 || a.shape[0] < 1 ||
      a.shape[1] < 1 || a.shape[0] > 100000 || a.shape[1] > 100000) {
    throw InputError("texture.npy: " + file + " must be a uint8 array of shape (h, w, 3)");
  }
  return Texture(RequireFinite(t, "x0_m", "texture"), RequireFinite(t, "y0_m", "texture"),
                 RequirePositive(t, "texel_m", "texture"), static_cast<int>(a.shape[1]),
                 static_cast<int>(a.shape[0]), std::move(a.data));
}

geometry::CameraModel LoadCamera(const json& c) {
  geometry::CameraModel cam;
  cam.width = RequireInt(c, "width", "camera", 1, 20000);
  cam.height = RequireInt(c, "height", "camera", 1, 20000);
  const std::vector<double> K = RequireMatrix3(c, "K", "camera");
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1) {
    throw InputError("camera.K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
  }
  if (K[0] <= 0 || K[4] <= 0) throw InputError("camera.K: fx and fy must be > 0");
  if (static_cast<long long>(cam.width) * cam.height > 64LL * 1000 * 1000) {
    throw InputError("camera: width x height must be at most 64 megapixels");
  }
  cam.fx = K[0];
  cam.fy = K[4];
  cam.cx = K[2];
  cam.cy = K[5];
  if (c.contains("dist_k1k2p1p2k3")) {
    const std::vector<double> d = RequireNumbers(c, "dist_k1k2p1p2k3", "camera", 5);
    std::copy(d.begin(), d.end(), cam.dist.begin());
  }
  return cam;
}

geometry::Rigid3d LoadPose(const json& p, const std::string& path) {
  const std::vector<double> R = RequireMatrix3(p, "R", path);
  const std::vector<double> t = RequireNumbers(p, "t", path, 3);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += R[3 * r + k] * R[3 * c + k];
      if (std::fabs(dot - (r == c)) > 1e-6) {
        throw InputError(path + ".R: not a rotation matrix (R R^T != I)");
      }
    }
  }
  const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
  if (det < 0) throw InputError(path + ".R: a reflection (det -1), not a rotation");
  return {Eigen::Matrix3d(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(R.data())),
          Eigen::Vector3d(t[0], t[1], t[2])};
}

std::string CheckImageFile(const std::string& file, const std::string& path) {
  const std::filesystem::path p(file);
  const std::string ext = p.extension().string();
  if (file.empty() || p.is_absolute() || file.find("..") != std::string::npos) {
    throw InputError(path + ": must be a relative path inside the output directory, got '" + file + "'");
  }
  if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") {
    throw InputError(path + ": must end in .png, .jpg or .jpeg, got '" + file + "'");
  }
  return file;
}

}  // namespace

RenderJob LoadRenderJob(const std::string& path) {
  return ParseRenderJob(ReadFile(path), path,
                        std::filesystem::path(path).parent_path().string());
}

RenderJob ParseRenderJob(const std::string& text, const std::string& path, const std::string& dir) {
  const json doc = ParseJson(text, path);
  CheckSchema(doc, "mound.render", 1, path);
  RenderJob job;
  job.scene.terrain = LoadHeightfield(RequireField(doc, "heightfield", ""), dir);
  job.scene.texture = LoadTexture(RequireField(doc, "texture", ""), dir);
  job.camera = LoadCamera(RequireField(doc, "camera", ""));
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
  if (doc.contains("seed")) job.seed = static_cast<uint64_t>(RequireInt(doc, "seed", "", 0, 2147483647));
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
    im.cam_from_world = LoadPose(RequireField(images[k], "cam_from_world", p), pp);
    const Eigen::Vector3d c = im.cam_from_world.Centre();
    double ground = 0;
    if (job.scene.terrain.HeightAt(c[0], c[1], &ground) && c[2] <= ground) {
      throw InputError(pp + ": the camera centre (" + FormatNumber(c[0]) + ", " + FormatNumber(c[1]) +
                       ", " + FormatNumber(c[2]) + ") m is below the ground (" +
                       FormatNumber(ground) + " m)");
    }
    job.images.push_back(std::move(im));
  }
  return job;
}

}  // namespace mound::sim
