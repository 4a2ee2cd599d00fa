#include "scene/kernel_job.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <istream>
#include <limits>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "common/atomic_file.h"
#include "common/enum_names.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/npy.h"
#include "scene/block_scores.h"

namespace mound::scene {
namespace {

using nlohmann::json;

constexpr size_t kMaxBlockPixels = size_t{100} << 20;  // per band: 10,240 x 10,240
constexpr size_t kMaxStreamedBytes = size_t{1} << 30;  // a streamed block's pixels

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

// Every field but the block.
KernelJob ParseJobFields(const json& doc, const std::string& path) {
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

  return job;
}

void CheckJob(KernelJob& job) {
  job.spec.n_bands = job.block.bands;
  job.spec.Check();
  job.model.Check(job.spec.NumFeatures());
  CheckBlock(job.block, job.spec, job.cells);
}

}  // namespace

KernelJob LoadKernelJob(const std::string& path) {
  return ParseKernelJob(ReadFile(path), path, std::filesystem::path(path).parent_path().string());
}

KernelJob ParseKernelJob(const std::string& text, const std::string& path, const std::string& dir) {
  const json doc = ParseJson(text, path);
  KernelJob job = ParseJobFields(doc, path);
  const json& block = RequireField(doc, "block", "");
  if (!block.is_string()) throw InputError("block: expected the .npy file's name");
  job.block = LoadBlock(ResolveDataFile(dir, block.get<std::string>(), "block"));
  CheckJob(job);
  return job;
}

namespace {

// A streamed block's layout: how many bytes follow its request's line.
struct BlockLayout {
  int bands = 0, rows = 0, cols = 0;
  size_t item_bytes = 4;
  size_t mask_bytes = 0;  // "cell_mask": one byte per cell after the pixels (0: not scored)
  size_t PixelBytes() const { return item_bytes * bands * static_cast<size_t>(rows) * cols; }
  size_t Bytes() const { return PixelBytes() + mask_bytes; }
};

BlockLayout ParseLayout(const json& doc) {
  const json& b = RequireField(doc, "block", "");
  if (!b.is_object()) {
    throw InputError(
        "block: expected {\"dtype\": \"<f4\" or \"<f8\", \"shape\": [bands, rows, cols]}");
  }
  BlockLayout layout;
  const std::string dtype = RequireString(b, "dtype", "block");
  if (dtype != "<f4" && dtype != "<f8") throw InputError("block.dtype: expected <f4 or <f8");
  layout.item_bytes = dtype == "<f4" ? 4 : 8;
  const json& shape = RequireField(b, "shape", "block");
  if (!shape.is_array() || shape.size() != 3) {
    throw InputError("block.shape: expected [bands, rows, cols]");
  }
  const std::vector<double> dims = FiniteNumbers(shape, "block.shape", 3);
  for (size_t k = 0; k < 3; ++k) {
    if (dims[k] != std::floor(dims[k]) || dims[k] < 1 || dims[k] > (k == 0 ? 64 : 1 << 20)) {
      throw InputError("block.shape[" + std::to_string(k) +
                       "]: a whole number, 1 .. 64 bands or 1 .. 1,048,576 pixels");
    }
  }
  layout.bands = static_cast<int>(dims[0]);
  layout.rows = static_cast<int>(dims[1]);
  layout.cols = static_cast<int>(dims[2]);
  if (static_cast<size_t>(layout.rows) * layout.cols > kMaxBlockPixels) {
    throw InputError("block.shape: at most 100 Mpx a band");
  }
  if (b.contains("cell_mask")) {
    layout.mask_bytes = static_cast<size_t>(RequireInt(b, "cell_mask", "block", 1, 1 << 28));
  }
  if (layout.Bytes() > kMaxStreamedBytes) throw InputError("block.shape: at most 1 GiB a block");
  return layout;
}

// The block's bytes into job->block (float32 or float64, as the layout says).
void ReadBlock(std::istream& in, const BlockLayout& layout, std::vector<unsigned char>* raw,
               PixelBlock* b) {
  const size_t n = static_cast<size_t>(layout.bands) * layout.rows * layout.cols;
  // In pieces of at most 64 MB: input that ends early never allocates the whole block.
  const size_t want = layout.Bytes();
  raw->clear();
  while (raw->size() < want) {
    const size_t at = raw->size();
    const size_t piece = std::min(want - at, size_t{64} << 20);
    raw->resize(at + piece);
    in.read(reinterpret_cast<char*>(raw->data() + at), static_cast<std::streamsize>(piece));
    if (static_cast<size_t>(in.gcount()) != piece) {
      throw InputError("block: the input ended " +
                       std::to_string(want - at - static_cast<size_t>(in.gcount())) +
                       " bytes before the block's end");
    }
  }
  b->bands = layout.bands;
  b->rows = layout.rows;
  b->cols = layout.cols;
  b->values.resize(n);  // the cell mask stays in raw, after the pixels
  ElementsToDouble(layout.item_bytes == 8 ? "<f8" : "<f4", raw->data(), n, b->values.data());
}

// A reply's payload: arrays one after another, each named in the reply's "parts".
struct Part {
  std::string name, dtype;
  std::vector<size_t> shape;
  const void* data;
  size_t bytes;
};

template <typename T>
Part PartOf(const std::string& name, const char* dtype, std::vector<size_t> shape,
            const std::vector<T>& v) {
  return {name, dtype, std::move(shape), v.data(), v.size() * sizeof(T)};
}

void Reply(std::ostream& out, json head, const std::vector<Part>& parts) {
  size_t bytes = 0;
  if (!parts.empty()) {
    json list = json::array();
    for (const Part& p : parts) {
      list.push_back({{"name", p.name}, {"dtype", p.dtype}, {"shape", p.shape}});
      bytes += p.bytes;
    }
    head["parts"] = list;
    head["dtype"] = parts[0].dtype;
    head["shape"] = parts[0].shape;
    head["bytes"] = bytes;
  }
  out << head.dump() << "\n";
  for (const Part& p : parts) {
    if (p.bytes > 0)
      out.write(static_cast<const char*>(p.data), static_cast<std::streamsize>(p.bytes));
  }
  out.flush();
}

// The request's "scores": the calibration, the margin and the rasters' nodata value.
struct ScoresRequest {
  Calibration calibration;
  int margin = 1;
  float nodata = -9999.0f;
  bool logits = false;  // the block's logits too
};

ScoresRequest ParseScores(const json& doc) {
  const json& s = RequireField(doc, "scores", "");
  if (!s.is_object()) throw InputError("scores: expected an object");
  ScoresRequest r;
  r.calibration.a = RequireInRange(s, "a", "scores", -1e6, 1e6);
  r.calibration.b = RequireInRange(s, "b", "scores", -1e6, 1e6);
  r.margin = RequireInt(s, "margin", "scores", 0, 4096);
  r.nodata = static_cast<float>(RequireInRange(s, "nodata", "scores", -3e38, 3e38));
  const json& l = RequireField(s, "logits", "scores");
  if (!l.is_boolean()) throw InputError("scores.logits: expected true or false");
  r.logits = l.get<bool>();
  return r;
}

}  // namespace

int ServeKernelJobs(std::istream& in, std::ostream& out, Simd simd) {
#if defined(__GLIBC__)
  // The block-sized buffers of one request (scores, rasters: megabytes each) stay in the
  // heap for the next instead of going back to the system and faulting in again, zeroed,
  // per block.
  mallopt(M_MMAP_THRESHOLD, 1 << 28);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
  Scorer scorer(simd);
  KernelJob job;
  std::vector<unsigned char> raw;
  std::vector<double> result;
  std::string line;
  for (size_t request = 1; std::getline(in, line); ++request) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string where = "request " + std::to_string(request);
    // Unreadable JSON or block layout: how many bytes follow is unknown, so the stream
    // cannot go on (exit 2). Any other bad field: the block is read past and refused.
    json doc;
    BlockLayout layout;
    try {
      doc = ParseJson(line, where);
      layout = ParseLayout(doc);
    } catch (const InputError& e) {
      throw InputError(where + ": " + e.what());
    }
    std::string want;
    ScoresRequest scores;
    try {
      job = ParseJobFields(doc, where);
      want = RequireString(doc, "want", "");
      if (want != "logits" && want != "features" && want != "scores") {
        throw InputError("want: expected logits, features or scores");
      }
      if (want == "scores") scores = ParseScores(doc);
    } catch (const InputError& e) {
      ReadBlock(in, layout, &raw, &job.block);  // keeps the stream in step
      Reply(out, {{"status", "error"}, {"message", where + ": " + e.what()}}, {});
      continue;
    }
    ReadBlock(in, layout, &raw, &job.block);
    const size_t rows = job.cells.rows, cols = job.cells.cols;
    BlockScores bs;
    try {
      CheckJob(job);
      if (layout.mask_bytes > 0 && layout.mask_bytes != rows * cols) {
        throw InputError("block.cell_mask: " + std::to_string(layout.mask_bytes) + " bytes for " +
                         std::to_string(rows * cols) + " cells");
      }
      if (want == "scores" &&
          (2 * scores.margin >= job.cells.rows || 2 * scores.margin >= job.cells.cols)) {
        throw InputError("scores.margin: leaves no core of the block's cells");
      }
    } catch (const InputError& e) {
      Reply(out, {{"status", "error"}, {"message", where + ": " + e.what()}}, {});
      continue;
    }
    json head{{"status", "ok"}, {"simd", SimdName(scorer.simd())}};
    std::vector<Part> parts;
    if (want == "features") {
      scorer.Features(job.block, job.spec, job.cells, &result);
      parts.push_back(PartOf("features", "<f8",
                             {rows, cols, static_cast<size_t>(job.spec.NumFeatures())}, result));
    } else {
      scorer.Logits(job.block, job.spec, job.model, job.cells, &result);
      if (layout.mask_bytes > 0) {  // cells outside an area of interest: no logit
        const unsigned char* mask = raw.data() + layout.PixelBytes();
        for (size_t k = 0; k < result.size(); ++k)
          if (mask[k] == 0) result[k] = std::numeric_limits<double>::quiet_NaN();
      }
      if (want == "logits") {
        size_t scored = 0;
        for (double v : result) scored += std::isfinite(v) ? 1 : 0;
        head["scored"] = scored;
        parts.push_back(PartOf("logits", "<f8", {rows, cols}, result));
      } else {
        bs = ScoreBlock(result, job.cells.rows, job.cells.cols, scores.margin, scores.calibration,
                        scores.nodata);
        const size_t nr = rows - 2 * scores.margin, nc = cols - 2 * scores.margin;
        const size_t np = bs.peak_row.size();
        parts = {PartOf("p", "<f4", {nr, nc}, bs.p),
                 PartOf("reward", "<f4", {nr, nc}, bs.reward),
                 PartOf("peak_row", "<i4", {np}, bs.peak_row),
                 PartOf("peak_col", "<i4", {np}, bs.peak_col),
                 PartOf("peak_p", "<f8", {np}, bs.peak_p),
                 PartOf("peak_logit", "<f8", {np}, bs.peak_logit)};
        if (scores.logits) parts.push_back(PartOf("logits", "<f8", {rows, cols}, result));
        head["scored"] = bs.scored;  // the core's cells with a p
        head["p_sum"] = bs.p_sum;
      }
    }
    head["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Reply(out, head, parts);
  }
  return 0;
}

}  // namespace mound::scene
