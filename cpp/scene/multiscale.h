// The coarse search's multiscale scene features and its logistic model, compiled: the
// per-pixel kernel of `mound scene score` (python/mound/scene/features.py and model.py hold
// the definitions and the reference implementation in numpy; tests hold the two equal).
//
// For every channel (the bands, then NDVI when red and near-infrared are among them) and
// every radius h (pixels) of a cell's centre pixel (i, j), with box sums from summed-area
// tables built in numpy's order (cumulative sums down the columns, then along the rows):
//   contrast_h    = (mean of the (2h+1)^2 window - mean of the ring out to 2h) / sigma_bg
//   |contrast_h|
//   texture_h     = std of the window / sigma_bg
//   dipole_h      = |(east half - west half, north half - south half)| / sigma_bg
// then NDVI's mean at the smallest radius and over the background, and each band's share of
// the bands' sum at the smallest radius. sigma_bg = the channel's std over the background
// window (half-side background_px) + 1e-3 |its mean| + 1e-9. A cell whose centre pixel is
// nodata, whose background window holds < min_valid valid pixels, or with a non-finite
// feature has no features (NaN) and no logit.
//
// The logit is w . phi(z) + bias, z = (x - mean) / std clipped to +-6 (unless the model says
// otherwise), phi = z (basis none) or (z, max(z - 1, 0), max(-z - 1, 0)) (hinge).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/enum_names.h"

namespace mound::scene {

struct MultiscaleSpec {
  std::vector<int> radii_px;  // increasing, >= 1
  int background_px = 48;     // > the largest radius
  int n_bands = 0;            // bands of the block, in the model's order
  int red_band = -1;          // 0-based band of red / near-infrared; NDVI when both are set
  int nir_band = -1;
  double min_valid = 0.95;  // share of the background window that must be valid

  bool HasNdvi() const { return red_band >= 0 && nir_band >= 0; }
  int NumChannels() const { return n_bands + (HasNdvi() ? 1 : 0); }
  int NumFeatures() const;
  // The half-side of the widest window: the background's, or an outer ring's (2h).
  int ReachPx() const;
  // InputError naming the field ("features.radii_px", ...).
  void Check() const;
};

enum class Basis { kNone, kHinge };

struct LinearModel {
  Basis basis = Basis::kHinge;
  bool clip = true;
  std::vector<double> mean, std;  // the standardiser, per feature
  std::vector<double> weights;    // F (none) or 3F (hinge) weights, then the bias
  void Check(int n_features) const;
};

// bands x rows x cols pixels, band-major; NaN = nodata (in every band where one is).
struct PixelBlock {
  int bands = 0, rows = 0, cols = 0;
  std::vector<double> values;
};

// The cells scored: cell (k, l) is centred on pixel (first + k stride, first + l stride),
// first = halo + stride / 2 (features.py's grid).
struct CellGrid {
  int halo = 0;
  int stride = 1;
  int rows = 0, cols = 0;
  int First() const { return halo + stride / 2; }
};

// Throws InputError when `block` does not hold every window the cells need.
void CheckBlock(const PixelBlock& block, const MultiscaleSpec& spec, const CellGrid& cells);

// The instruction set the kernel's loops run with. Generic runs on any x86-64 (SSE2) and
// elsewhere; AVX2 where the CPU has it (x86-64 only). Both give the same bits: no fused
// multiply-adds, no reordered sums.
enum class Simd { kAuto, kGeneric, kAvx2 };
inline constexpr EnumName<Simd> kSimdNames[] = {
    {Simd::kAuto, "auto"}, {Simd::kGeneric, "generic"}, {Simd::kAvx2, "avx2"}};
// kAuto -> the best this CPU has; InputError for kAvx2 on a CPU without it.
Simd ResolveSimd(Simd wanted);
std::string SimdName(Simd simd);

// Scores blocks one after another, keeping its tables (~10 per channel and block pixel,
// float64) between them: a long-lived kernel (`mound_scene --serve`) allocates and faults
// them in once instead of per block.
class Scorer {
 public:
  explicit Scorer(Simd simd = Simd::kAuto);
  ~Scorer();
  Scorer(const Scorer&) = delete;
  Scorer& operator=(const Scorer&) = delete;
  Simd simd() const { return simd_; }
  // As Features() and Logits() below, into `out` (resized).
  void Features(const PixelBlock& block, const MultiscaleSpec& spec, const CellGrid& cells,
                std::vector<double>* out);
  void Logits(const PixelBlock& block, const MultiscaleSpec& spec, const LinearModel& model,
              const CellGrid& cells, std::vector<double>* out);

 private:
  struct Workspace;
  std::unique_ptr<Workspace> ws_;
  Simd simd_;
};

// Features, (rows * cols) x NumFeatures() row-major; NaN rows where a cell has none.
std::vector<double> Features(const PixelBlock& block, const MultiscaleSpec& spec,
                             const CellGrid& cells);
// Logits (uncalibrated), rows * cols row-major; NaN where a cell has no features.
std::vector<double> Logits(const PixelBlock& block, const MultiscaleSpec& spec,
                           const LinearModel& model, const CellGrid& cells);

}  // namespace mound::scene
