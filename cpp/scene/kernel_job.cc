#include "scene/kernel_job.h"

#include <filesystem>

#include "common/atomic_file.h"
#include "common/enum_names.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/npy.h"

namespace mound::scene {
namespace {

using nlohmann::json;

constexpr size_t kMaxBlockPixels = size_t{100} << 20;  // per band: 10,240 x 10,240

constexpr EnumName<Basis> kBasisNames[] = {{Basis::kNone, "none"}, {Basis::kHinge, "hinge"}};

std::vector<double> Numbers(const json& obj, const std::string& key, const std::string& path,
                            size_t max_count) {
  const json& a = RequireField(obj, key, path);
  const std::string where = JoinPath(path, key);
  if (!a.is_array() || a.size() > max_count) {
    throw InputError(where + ": expected an array of at most " + std::to_string(max_count) +
                     " numbers");
  }
  return FiniteNumbers(a, where, a.size());
}

int OptionalBand(const json& obj, const std::string& key) {
  if (!obj.contains(key) || obj.at(key).is_null()) return -1;
  return RequireInt(obj, key, "features", 0, 63);
}

PixelBlock LoadBlock(const std::string& file) {
  const NpyArray a = ReadNpy(file);
  if ((a.descr != "<f4" && a.descr != "<f8") || a.shape.size() != 3 || a.shape[0] < 1 ||
      a.shape[0] > 64 || a.shape[1] < 1 || a.shape[2] < 1 ||
      a.shape[1] * a.shape[2] > kMaxBlockPixels) {
    throw InputError("block: " + file +
                     " must be a float32/float64 array (bands, rows, cols), 1 to 64 bands, at "
                     "most 100 Mpx a band");
  }
  PixelBlock b;
  b.bands = static_cast<int>(a.shape[0]);
  b.rows = static_cast<int>(a.shape[1]);
  b.cols = static_cast<int>(a.shape[2]);
  b.values = a.AsDouble();
  return b;
}

}  // namespace

KernelJob LoadKernelJob(const std::string& path) {
  return ParseKernelJob(ReadFile(path), path, std::filesystem::path(path).parent_path().string());
}

KernelJob ParseKernelJob(const std::string& text, const std::string& path, const std::string& dir) {
  const json doc = ParseJson(text, path);
  CheckSchema(doc, "mound.scene_kernel", 1, path);
  KernelJob job;
  const json& f = RequireField(doc, "features", "");
  if (!f.is_object()) throw InputError("features: expected an object");
  if (RequireString(f, "kind", "features") != "multiscale") {
    throw InputError("features.kind: the kernel computes 'multiscale' features only");
  }
  for (double r : Numbers(f, "radii_px", "features", 16)) {
    if (r != std::floor(r) || r < 1 || r > 4096) {
      throw InputError("features.radii_px: whole numbers of pixels, 1 .. 4096");
    }
    job.spec.radii_px.push_back(static_cast<int>(r));
  }
  job.spec.background_px = RequireInt(f, "background_px", "features", 1, 4096);
  job.spec.red_band = OptionalBand(f, "red_band");
  job.spec.nir_band = OptionalBand(f, "nir_band");
  job.spec.min_valid = RequireInRange(f, "min_valid", "features", 1e-6, 1.0);

  const json& m = RequireField(doc, "model", "");
  if (!m.is_object()) throw InputError("model: expected an object");
  const std::string basis = RequireString(m, "basis", "model");
  const std::optional<Basis> b = FromName(basis, kBasisNames);
  if (!b)
    throw InputError("model.basis: expected " + ExpectedNames(kBasisNames) + ", got '" + basis +
                     "'");
  job.model.basis = *b;
  const json& clip = RequireField(m, "clip", "model");
  if (!clip.is_boolean()) throw InputError("model.clip: expected true or false");
  job.model.clip = clip.get<bool>();
  job.model.mean = Numbers(m, "mean", "model", 4096);
  job.model.std = Numbers(m, "std", "model", 4096);
  job.model.weights = Numbers(m, "weights", "model", 3 * 4096 + 1);

  const json& c = RequireField(doc, "cells", "");
  if (!c.is_object()) throw InputError("cells: expected an object");
  job.cells.halo = RequireInt(c, "halo", "cells", 0, 8192);
  job.cells.stride = RequireInt(c, "stride", "cells", 1, 4096);
  job.cells.rows = RequireInt(c, "rows", "cells", 1, 16384);
  job.cells.cols = RequireInt(c, "cols", "cells", 1, 16384);

  job.block = LoadBlock(ResolveDataFile(dir, RequireString(doc, "block", ""), "block"));
  job.spec.n_bands = job.block.bands;
  job.spec.Check();
  job.model.Check(job.spec.NumFeatures());
  CheckBlock(job.block, job.spec, job.cells);
  return job;
}

}  // namespace mound::scene
