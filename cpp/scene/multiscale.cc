#include "scene/multiscale.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <type_traits>

#include "common/error.h"

// Inlined into the generic and the AVX2 row loops, so that each is compiled for both.
#define MOUND_INLINE inline __attribute__((always_inline))
#define MOUND_LAMBDA_INLINE __attribute__((always_inline))
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MOUND_SCENE_X86 1
#else
#define MOUND_SCENE_X86 0
#endif

namespace mound::scene {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kClip = 6.0;  // model.py's CLIP
constexpr double kInf = std::numeric_limits<double>::infinity();

// A summed-area table with a zero first row and column, built one row at a time as numpy's
// _sat does (np.cumsum down axis 0, then along axis 1: each row's prefix sums run over the
// running column sums), so that its sums are numpy's to the bit. Only the last `ring` rows
// are kept (row i in slot i % ring): the cells of a row need rows within the features'
// reach of it, and the scorer adds rows as it goes down the block, so the table of a
// 1126-pixel block holds ~100 rows (0.9 MB) instead of 1127 (10 MB) and stays in cache.
class Sat {
 public:
  // Sized for rows of `cols` pixels and emptied (row 0, the zero row, added); the memory of
  // an earlier block is kept (a long-lived scorer allocates and faults its pages in once).
  void Reset(int cols, int ring) {
    w1_ = static_cast<size_t>(cols) + 1;
    ring_ = ring;
    p_.resize(static_cast<size_t>(ring) * w1_);
    std::fill(p_.begin(), p_.begin() + static_cast<std::ptrdiff_t>(w1_), 0.0);
    column_.assign(cols, 0.0);
  }
  // Adds the block's next row (row `i` of the table is pixel row i - 1).
  void AddRow(int i, const double* v) {
    double* r = Row(i);
    r[0] = 0;
    ++r;
    const int cols = static_cast<int>(column_.size());
    for (int j = 0; j < cols; ++j) column_[j] += v[j];
    double run = 0;
    for (int j = 0; j < cols; ++j) r[j] = run += column_[j];
  }
  const double* Row(int i) const { return p_.data() + static_cast<size_t>(i % ring_) * w1_; }
  double* Row(int i) { return p_.data() + static_cast<size_t>(i % ring_) * w1_; }

 private:
  size_t w1_ = 1;
  int ring_ = 1;
  std::vector<double> p_;
  std::vector<double> column_;  // the column sums so far
};

// One output row's cells: pixel row i, pixel columns j0 + l * stride (l < m).
struct RowCells {
  int i, j0, stride, m;
};

// Sums over rows i-top..i+bottom, columns j-left..j+right of every cell of the row, in
// numpy's order of operations ((A - B) - C) + D.
MOUND_INLINE void Box(const Sat& p, const RowCells& rc, int top, int bottom, int left, int right,
                      double* __restrict out) {
  const double* lo = p.Row(rc.i + bottom + 1);
  const double* hi = p.Row(rc.i - top);
  const int jr = rc.j0 + right + 1;
  const int jl = rc.j0 - left;
  if (rc.stride == 1) {
    const double* a = lo + jr;
    const double* b = hi + jr;
    const double* c = lo + jl;
    const double* d = hi + jl;
    for (int l = 0; l < rc.m; ++l) out[l] = a[l] - b[l] - c[l] + d[l];
    return;
  }
  const int s = rc.stride;
  for (int l = 0; l < rc.m; ++l) {
    out[l] = lo[jr + l * s] - hi[jr + l * s] - lo[jl + l * s] + hi[jl + l * s];
  }
}

// The block's channels (bands, NDVI), their squares and valid pixels as tables, filled
// row by row as the cells go down the block (AddRowsTo).
struct Tables {
  std::vector<Sat> p1, p2;
  Sat count;
  bool has_count = false;  // false when every pixel is valid
  std::vector<unsigned char> valid;
  int cols = 0;
  const PixelBlock* block = nullptr;
  const MultiscaleSpec* spec = nullptr;
  int added = 0;                // table rows added so far (row 0 is the zero row)
  std::vector<double> row, sq;  // scratch

  // Adds the table rows up to `last` (pixel rows up to last - 1).
  void AddRowsTo(int last) {
    const PixelBlock& b = *block;
    const size_t n = static_cast<size_t>(b.rows) * b.cols;
    const int nc = spec->NumChannels();
    for (; added < last; ++added) {
      // Pixel row i: each channel's row (0 where a pixel is not valid; NDVI from the band
      // values), its square and the valid flags into the tables.
      const int i = added;
      const unsigned char* ok = valid.data() + static_cast<size_t>(i) * b.cols;
      for (int c = 0; c < nc; ++c) {
        if (c < b.bands) {
          const double* v = b.values.data() + c * n + static_cast<size_t>(i) * b.cols;
          for (int j = 0; j < b.cols; ++j) row[j] = ok[j] ? v[j] : 0.0;
        } else {
          const size_t at = static_cast<size_t>(i) * b.cols;
          const double* red = b.values.data() + spec->red_band * n + at;
          const double* nir = b.values.data() + spec->nir_band * n + at;
          for (int j = 0; j < b.cols; ++j) {
            row[j] = ok[j] ? (nir[j] - red[j]) / (nir[j] + red[j]) : 0.0;
          }
        }
        for (int j = 0; j < b.cols; ++j) sq[j] = row[j] * row[j];
        p1[c].AddRow(i + 1, row.data());
        p2[c].AddRow(i + 1, sq.data());
      }
      if (has_count) {
        for (int j = 0; j < b.cols; ++j) row[j] = ok[j] ? 1.0 : 0.0;
        count.AddRow(i + 1, row.data());
      }
    }
  }
};

// Prepares the tables of a block: its valid pixels, and empty tables that keep the rows
// within the features' reach of a row of cells (AddRowsTo fills them).
void BuildTables(const PixelBlock& b, const MultiscaleSpec& spec, Tables& t) {
  const size_t n = static_cast<size_t>(b.rows) * b.cols;
  const int nc = spec.NumChannels();
  t.cols = b.cols;
  t.block = &b;
  t.spec = &spec;
  t.added = 0;
  t.valid.assign(n, 1);
  for (int c = 0; c < b.bands; ++c) {
    const double* v = b.values.data() + c * n;
    for (size_t k = 0; k < n; ++k) {
      if (!std::isfinite(v[k])) t.valid[k] = 0;
    }
  }
  if (spec.HasNdvi()) {  // NDVI is defined where nir + red is not ~0
    const double* red = b.values.data() + spec.red_band * n;
    const double* nir = b.values.data() + spec.nir_band * n;
    for (size_t k = 0; k < n; ++k) {
      if (t.valid[k] && !(std::fabs(nir[k] + red[k]) > 1e-9)) t.valid[k] = 0;
    }
  }
  const bool uniform = std::all_of(t.valid.begin(), t.valid.end(), [](auto v) { return v; });
  // A row of cells at pixel row i reads table rows i - reach .. i + reach + 1.
  const int ring = 2 * spec.ReachPx() + 2;
  t.p1.resize(nc);
  t.p2.resize(nc);
  for (int c = 0; c < nc; ++c) {
    t.p1[c].Reset(b.cols, ring);
    t.p2[c].Reset(b.cols, ring);
  }
  t.has_count = !uniform;
  if (t.has_count) t.count.Reset(b.cols, ring);
  t.row.resize(b.cols);
  t.sq.resize(b.cols);
}

// The loops of a row of cells, each over m cells, on restrict-qualified arrays so that the
// compiler vectorises them (the same operations in the same order as features.py).
MOUND_INLINE void Reciprocal(const double* __restrict n, double* __restrict out, int m) {
  for (int l = 0; l < m; ++l) out[l] = 1.0 / n[l];
}
// 1 / max(n(2h) - n(h), 1): the ring's count from the two windows' counts.
MOUND_INLINE void RingReciprocal(const double* __restrict inner, const double* __restrict outer,
                                 double* __restrict out, int m) {
  for (int l = 0; l < m; ++l) out[l] = 1.0 / std::max(outer[l] - inner[l], 1.0);
}
// The background's mean and 1 / sigma_bg.
MOUND_INLINE void Background(const double* __restrict sum, const double* __restrict sq,
                             const double* __restrict inv_n, double* __restrict mean,
                             double* __restrict inv, int m) {
  for (int l = 0; l < m; ++l) {
    const double mb = sum[l] * inv_n[l];
    double var = sq[l] * inv_n[l] - mb * mb;
    var = std::max(var, 0.0);
    double scale = std::sqrt(var);
    scale += 1e-3 * std::fabs(mb) + 1e-9;
    mean[l] = mb;
    inv[l] = 1.0 / scale;
  }
}
MOUND_INLINE void Contrast(const double* __restrict s, const double* __restrict s2,
                           const double* __restrict inv_n, const double* __restrict inv_ring,
                           const double* __restrict inv, double* __restrict mean,
                           double* __restrict f, int m) {
  for (int l = 0; l < m; ++l) {
    mean[l] = s[l] * inv_n[l];
    const double ring = (s2[l] - s[l]) * inv_ring[l];
    f[l] = (mean[l] - ring) * inv[l];
  }
}
MOUND_INLINE void Abs(const double* __restrict x, double* __restrict f, int m) {
  for (int l = 0; l < m; ++l) f[l] = std::fabs(x[l]);
}
MOUND_INLINE void Texture(const double* __restrict q, const double* __restrict inv_n,
                          const double* __restrict mean, const double* __restrict inv,
                          double* __restrict f, int m) {
  for (int l = 0; l < m; ++l) {
    double var = q[l] * inv_n[l] - mean[l] * mean[l];
    var = std::max(var, 0.0);
    f[l] = std::sqrt(var) * inv[l];
  }
}
// The difference of two halves' means.
MOUND_INLINE void HalfDiff(const double* __restrict a, const double* __restrict inv_a,
                           const double* __restrict b, const double* __restrict inv_b,
                           double* __restrict d, int m) {
  for (int l = 0; l < m; ++l) d[l] = a[l] * inv_a[l] - b[l] * inv_b[l];
}
MOUND_INLINE void Dipole(const double* __restrict de, const double* __restrict dn,
                         const double* __restrict inv, double* __restrict f, int m) {
  for (int l = 0; l < m; ++l) f[l] = std::sqrt(de[l] * de[l] + dn[l] * dn[l]) * inv[l];
}
// The four features of one channel and radius h over a row of cells (stride 1), in one
// pass: the window's box, its east, west, north and south halves and the squares' box share
// the table rows (i - h, i, i + 1, i + h + 1) and columns (j - h, j, j + 1, j + h + 1) they
// read, so each value is loaded once instead of once per box, and no box is stored to be
// read again. Every value is computed with the operations, in the order, of Box, Contrast,
// Abs, Texture, HalfDiff and Dipole above (the same bits; tested against them).
//
// With a model (Mode kHinge or kLinear), the four features go straight into the cells'
// logits `acc` in their order, as four passes of the logit sink would add them, instead of
// being stored (kStore).
enum class RadiusMode { kStore, kHinge, kLinear };
// One feature's folded weights (Folded, per feature).
struct FeatureWeights {
  double wx, lo, hi, wc, wm, mu, sd;
};
// A feature's term added to a logit: the logit sink's operations (LogitRows), one cell.
template <RadiusMode Mode>
MOUND_INLINE double AddTerm(double acc, double v, const FeatureWeights& w) {
  const double x = std::min(std::max(v, w.lo), w.hi);
  if constexpr (Mode == RadiusMode::kHinge) {
    const double xc = std::min(std::max(x, w.mu - w.sd), w.mu + w.sd);
    const double dev = std::max(std::fabs(x - w.mu), w.sd);
    return (acc + (v - v)) + (w.wx * x + w.wm * dev - w.wc * xc);
  } else {
    return (acc + (v - v)) + w.wx * x;
  }
}
template <RadiusMode Mode>
MOUND_INLINE void RadiusFeatures(
    const double* __restrict lo, const double* __restrict hi, const double* __restrict r0,
    const double* __restrict r1, const double* __restrict lo2, const double* __restrict hi2, int h,
    const double* __restrict s2h, const double* __restrict inv_n, const double* __restrict inv_ring,
    const double* __restrict inv, const double* __restrict inv_e, const double* __restrict inv_w,
    const double* __restrict inv_no, const double* __restrict inv_so, double* __restrict mean,
    double* __restrict contrast, double* __restrict abs_contrast, double* __restrict texture,
    double* __restrict dipole, double* __restrict acc, const FeatureWeights* __restrict w, int m) {
  const int jr = h + 1, jl = -h;  // offsets from the cell's column
  for (int l = 0; l < m; ++l) {
    const double a = lo[l + jr], b = hi[l + jr], c = lo[l + jl], d = hi[l + jl];
    const double s = a - b - c + d;
    const double mu = s * inv_n[l];
    const double ring = (s2h[l] - s) * inv_ring[l];
    const double f = (mu - ring) * inv[l];
    mean[l] = mu;
    const double q = lo2[l + jr] - hi2[l + jr] - lo2[l + jl] + hi2[l + jl];
    double var = q * inv_n[l] - mu * mu;
    var = std::max(var, 0.0);
    const double tex = std::sqrt(var) * inv[l];
    const double east = a - b - lo[l + 1] + hi[l + 1];
    const double west = lo[l] - hi[l] - c + d;
    const double de = east * inv_e[l] - west * inv_w[l];
    const double north = r0[l + jr] - b - r0[l + jl] + d;
    const double south = a - r1[l + jr] - c + r1[l + jl];
    const double dn = north * inv_no[l] - south * inv_so[l];
    const double dip = std::sqrt(de * de + dn * dn) * inv[l];
    if constexpr (Mode == RadiusMode::kStore) {
      contrast[l] = f;
      abs_contrast[l] = std::fabs(f);
      texture[l] = tex;
      dipole[l] = dip;
    } else {
      double x = acc[l];
      x = AddTerm<Mode>(x, f, w[0]);
      x = AddTerm<Mode>(x, std::fabs(f), w[1]);
      x = AddTerm<Mode>(x, tex, w[2]);
      x = AddTerm<Mode>(x, dip, w[3]);
      acc[l] = x;
    }
  }
}

// One row of cells' features, in the order of features.py's names(), each handed to a
// sink(f, values) (m values). Holds the row's buffers and the windows' reciprocal counts,
// allocated once per block: the counts are the windows' areas (computed once) when every
// pixel of the block is valid, else box sums of the count table, row by row.
class RowKernel {
 public:
  RowKernel(const MultiscaleSpec& spec, int m) : spec_(spec), m_(m) {
    const std::vector<int>& hs = spec.radii_px;
    for (int h : hs) sizes_.push_back(h);
    for (int h : hs) sizes_.push_back(2 * h);
    sizes_.push_back(spec.background_px);
    std::sort(sizes_.begin(), sizes_.end());
    sizes_.erase(std::unique(sizes_.begin(), sizes_.end()), sizes_.end());
    for (int size : sizes_) {  // the windows whose sums the fused pass reads
      outer_.push_back(size == spec.background_px ||
                       std::any_of(hs.begin(), hs.end(), [size](int h) { return 2 * h == size; }));
    }
    auto buffers = [m](size_t n) {
      return std::vector<std::vector<double>>(n, std::vector<double>(m));
    };
    counts_ = buffers(sizes_.size());
    inv_n_ = buffers(sizes_.size());
    sums_ = buffers(sizes_.size());
    half_counts_ = buffers(4 * hs.size());
    half_inv_ = buffers(4 * hs.size());
    inv_ring_ = buffers(hs.size());
    small_ = buffers(spec.NumChannels());
    for (auto* v : {&mean_bg_, &inv_, &q_, &mean_, &f_, &ea_, &wa_, &de_, &dn_, &total_}) {
      v->resize(m);
    }
  }

  template <typename Sink>
  MOUND_INLINE void Row(const Tables& t, const RowCells& rc, unsigned char* enough, Sink&& sink) {
    const int m = m_;
    const std::vector<int>& hs = spec_.radii_px;
    const int hbg = spec_.background_px;
    if (t.has_count || !counted_) Counts(t, rc);
    const size_t bg = Index(hbg);
    int k = 0;
    const int nc = spec_.NumChannels();
    for (int c = 0; c < nc; ++c) {
      const Sat& p1 = t.p1[c];
      const Sat& p2 = t.p2[c];
      for (size_t z = 0; z < sizes_.size(); ++z) {
        if (rc.stride == 1 && !outer_[z]) continue;  // the fused pass sums its own window
        const int h = sizes_[z];
        Box(p1, rc, h, h, h, h, sums_[z].data());
      }
      Box(p2, rc, hbg, hbg, hbg, hbg, q_.data());
      Background(sums_[bg].data(), q_.data(), inv_n_[bg].data(), mean_bg_.data(), inv_.data(), m);
      for (size_t r = 0; r < hs.size(); ++r) {
        const int h = hs[r];
        const size_t z = Index(h);
        const double* rn = inv_n_[z].data();
        if (rc.stride == 1) {
          const double* const* hv = &half_ptr_[4 * r];
          auto radius = [&](auto mode, double* acc, const FeatureWeights* w) MOUND_LAMBDA_INLINE {
            RadiusFeatures<decltype(mode)::value>(
                p1.Row(rc.i + h + 1) + rc.j0, p1.Row(rc.i - h) + rc.j0, p1.Row(rc.i) + rc.j0,
                p1.Row(rc.i + 1) + rc.j0, p2.Row(rc.i + h + 1) + rc.j0, p2.Row(rc.i - h) + rc.j0, h,
                sums_[Index(2 * h)].data(), rn, inv_ring_[r].data(), inv_.data(), hv[0], hv[1],
                hv[2], hv[3], mean_.data(), f_.data(), ea_.data(), q_.data(), wa_.data(), acc, w,
                m);
          };
          if constexpr (std::decay_t<Sink>::kLogits) {
            const FeatureWeights w[4] = {sink.At(k), sink.At(k + 1), sink.At(k + 2),
                                         sink.At(k + 3)};
            if (sink.fm.hinge) {
              radius(std::integral_constant<RadiusMode, RadiusMode::kHinge>(), sink.acc, w);
            } else {
              radius(std::integral_constant<RadiusMode, RadiusMode::kLinear>(), sink.acc, w);
            }
            k += 4;
          } else {
            radius(std::integral_constant<RadiusMode, RadiusMode::kStore>(), nullptr, nullptr);
            sink(k++, f_.data());
            sink(k++, ea_.data());
            sink(k++, q_.data());
            sink(k++, wa_.data());
          }
          if (r == 0) std::copy(mean_.begin(), mean_.end(), small_[c].begin());
          continue;
        }
        Contrast(sums_[z].data(), sums_[Index(2 * h)].data(), rn, inv_ring_[r].data(), inv_.data(),
                 mean_.data(), f_.data(), m);
        if (r == 0) std::copy(mean_.begin(), mean_.end(), small_[c].begin());
        sink(k++, f_.data());
        Abs(f_.data(), ea_.data(), m);
        sink(k++, ea_.data());
        Box(p2, rc, h, h, h, h, q_.data());
        Texture(q_.data(), rn, mean_.data(), inv_.data(), f_.data(), m);
        sink(k++, f_.data());
        const double* const* hv = &half_ptr_[4 * r];
        Box(p1, rc, h, h, -1, h, ea_.data());
        Box(p1, rc, h, h, h, -1, wa_.data());
        HalfDiff(ea_.data(), hv[0], wa_.data(), hv[1], de_.data(), m);
        Box(p1, rc, h, -1, h, h, ea_.data());
        Box(p1, rc, -1, h, h, h, wa_.data());
        HalfDiff(ea_.data(), hv[2], wa_.data(), hv[3], dn_.data(), m);
        Dipole(de_.data(), dn_.data(), inv_.data(), f_.data(), m);
        sink(k++, f_.data());
      }
    }
    if (spec_.HasNdvi()) {
      sink(k++, small_[nc - 1].data());
      sink(k++, mean_bg_.data());  // the last channel's: NDVI's
    }
    if (spec_.n_bands > 1) {
      std::fill(total_.begin(), total_.end(), 0.0);
      for (int b = 0; b < spec_.n_bands; ++b) {
        for (int l = 0; l < m; ++l) total_[l] += small_[b][l];
      }
      for (int b = 0; b < spec_.n_bands; ++b) {
        for (int l = 0; l < m; ++l) f_[l] = small_[b][l] / total_[l];
        sink(k++, f_.data());
      }
    }
    const double need = spec_.min_valid * (2.0 * hbg + 1) * (2.0 * hbg + 1);
    const double* nbg = counts_[bg].data();
    const unsigned char* valid_row = t.valid.data() + static_cast<size_t>(rc.i) * t.cols;
    for (int l = 0; l < m; ++l) {
      enough[l] = valid_row[rc.j0 + l * rc.stride] && nbg[l] >= need;
    }
  }

 private:
  size_t Index(int h) const {
    return static_cast<size_t>(std::lower_bound(sizes_.begin(), sizes_.end(), h) - sizes_.begin());
  }
  // A window's valid-pixel count over the row's cells: its area when every pixel is valid,
  // else a box sum of the count table.
  MOUND_INLINE void Count(const Tables& t, const RowCells& rc, int top, int bottom, int left,
                          int right, double* out) const {
    if (t.has_count) {
      Box(t.count, rc, top, bottom, left, right, out);
    } else {
      std::fill(out, out + m_, static_cast<double>((top + bottom + 1) * (left + right + 1)));
    }
  }
  // The reciprocal counts shared by every channel (one division per window and cell instead
  // of one per channel; multiplying by them rounds differently from numpy's division by
  // the counts, by an ulp).
  MOUND_INLINE void Counts(const Tables& t, const RowCells& rc) {
    for (size_t z = 0; z < sizes_.size(); ++z) {
      const int h = sizes_[z];
      Count(t, rc, h, h, h, h, counts_[z].data());
      Reciprocal(counts_[z].data(), inv_n_[z].data(), m_);
    }
    const std::vector<int>& hs = spec_.radii_px;
    half_ptr_.clear();
    for (size_t r = 0; r < hs.size(); ++r) {
      const int h = hs[r];
      const int sides[4][4] = {{h, h, -1, h}, {h, h, h, -1}, {h, -1, h, h}, {-1, h, h, h}};
      for (int e = 0; e < 4; ++e) {
        double* n = half_counts_[4 * r + e].data();
        Count(t, rc, sides[e][0], sides[e][1], sides[e][2], sides[e][3], n);
        Reciprocal(n, half_inv_[4 * r + e].data(), m_);
        half_ptr_.push_back(half_inv_[4 * r + e].data());
      }
      RingReciprocal(counts_[Index(h)].data(), counts_[Index(2 * h)].data(), inv_ring_[r].data(),
                     m_);
    }
    counted_ = true;
  }

  const MultiscaleSpec& spec_;
  int m_;
  bool counted_ = false;
  std::vector<int> sizes_;   // the windows' half-sides: the radii, twice them, the background
  std::vector<bool> outer_;  // per size: an outer ring's or the background's
  std::vector<std::vector<double>> counts_, inv_n_, sums_;   // per size
  std::vector<std::vector<double>> half_counts_, half_inv_;  // per radius: E, W, N, S halves
  std::vector<const double*> half_ptr_;
  std::vector<std::vector<double>> inv_ring_;  // per radius
  std::vector<std::vector<double>> small_;     // per channel: the smallest window's mean
  std::vector<double> mean_bg_, inv_, q_, mean_, f_, ea_, wa_, de_, dn_, total_;
};

// The model folded for one pass per feature (model.py's _folded): logit = const +
// sum_f w_x x_f - w_c clip(x_f, mean -+ std) + w_m max(|x_f - mean|, std), x_f clipped to
// mean +- 6 std (+-inf: a model without clipping).
struct Folded {
  std::vector<double> w_x, w_c, w_m, mean, std, lo, hi;
  double constant = 0;
  bool hinge = false;
};

Folded Fold(const LinearModel& model) {
  const size_t n = model.mean.size();
  Folded f;
  f.hinge = model.basis == Basis::kHinge;
  f.mean = model.mean;
  f.std = model.std;
  double constant = model.weights.back();
  std::vector<double> w1(model.weights.begin(), model.weights.begin() + n);
  std::vector<double> a(n, 0.0), b(n, 0.0);
  if (f.hinge) {
    double sum_b = 0, a_mean = 0;
    for (size_t k = 0; k < n; ++k) {
      a[k] = (model.weights[n + k] - model.weights[2 * n + k]) / 2;
      b[k] = (model.weights[n + k] + model.weights[2 * n + k]) / 2;
      w1[k] += a[k];
      a_mean += a[k] / f.std[k] * f.mean[k];
      sum_b += b[k];
    }
    constant += a_mean - sum_b;
  }
  double w_mean = 0;
  for (size_t k = 0; k < n; ++k) {
    f.w_x.push_back(w1[k] / f.std[k]);
    f.w_c.push_back(a[k] / f.std[k]);
    f.w_m.push_back(b[k] / f.std[k]);
    f.lo.push_back(model.clip ? f.mean[k] - kClip * f.std[k] : -kInf);
    f.hi.push_back(model.clip ? f.mean[k] + kClip * f.std[k] : kInf);
    w_mean += w1[k] / f.std[k] * f.mean[k];
  }
  f.constant = constant - w_mean;
  return f;
}

}  // namespace

int MultiscaleSpec::NumFeatures() const {
  return NumChannels() * 4 * static_cast<int>(radii_px.size()) + (HasNdvi() ? 2 : 0) +
         (n_bands > 1 ? n_bands : 0);
}

int MultiscaleSpec::ReachPx() const {
  return radii_px.empty() ? background_px : std::max(background_px, 2 * radii_px.back());
}

void MultiscaleSpec::Check() const {
  if (radii_px.empty() || radii_px.size() > 16) {
    throw InputError("features.radii_px: 1 to 16 radii in pixels");
  }
  for (size_t k = 0; k < radii_px.size(); ++k) {
    if (radii_px[k] < 1 || (k > 0 && radii_px[k] <= radii_px[k - 1])) {
      throw InputError("features.radii_px: increasing radii >= 1 pixel");
    }
  }
  if (background_px <= radii_px.back() || background_px > 4096) {
    throw InputError("features.background_px: must exceed the largest radius (<= 4096)");
  }
  if (n_bands < 1 || n_bands > 64) throw InputError("block: 1 to 64 bands");
  for (const auto& [band, name] : {std::pair{red_band, "red_band"}, {nir_band, "nir_band"}}) {
    if (band < -1 || band >= n_bands) {
      throw InputError(std::string("features.") + name + ": not a band of the block (0-based)");
    }
  }
  if ((red_band >= 0) != (nir_band >= 0) || (HasNdvi() && red_band == nir_band)) {
    throw InputError("features.red_band, nir_band: both or neither, and different bands");
  }
  if (!(min_valid > 0 && min_valid <= 1)) throw InputError("features.min_valid: in (0, 1]");
}

void LinearModel::Check(int n_features) const {
  const size_t n = static_cast<size_t>(n_features);
  if (mean.size() != n) {
    throw InputError("model.mean: " + std::to_string(mean.size()) + " values for " +
                     std::to_string(n) + " features");
  }
  if (std.size() != n) throw InputError("model.std: one value per feature");
  for (size_t k = 0; k < n; ++k) {
    if (!std::isfinite(mean[k]) || std::fabs(mean[k]) > 1e12) {
      throw InputError("model.mean[" + std::to_string(k) + "]: not a finite number");
    }
    if (!(std[k] > 0 && std[k] < 1e12)) {
      throw InputError("model.std[" + std::to_string(k) + "]: must be > 0");
    }
  }
  const size_t want = (basis == Basis::kHinge ? 3 * n : n) + 1;
  if (weights.size() != want) {
    throw InputError("model.weights: " + std::to_string(weights.size()) + " values, expected " +
                     std::to_string(want) + " for this basis");
  }
  for (size_t k = 0; k < weights.size(); ++k) {
    if (!std::isfinite(weights[k]) || std::fabs(weights[k]) > 1e12) {
      throw InputError("model.weights[" + std::to_string(k) + "]: not a finite number");
    }
  }
}

void CheckBlock(const PixelBlock& block, const MultiscaleSpec& spec, const CellGrid& cells) {
  if (block.bands != spec.n_bands) throw InputError("block: band count differs from the spec");
  if (block.values.size() != static_cast<size_t>(block.bands) * block.rows * block.cols) {
    throw InputError("block: size does not match its shape");
  }
  if (cells.stride < 1 || cells.rows < 1 || cells.cols < 1 || cells.halo < 0) {
    throw InputError("cells: stride, rows and cols must be >= 1, halo >= 0");
  }
  const long long reach = spec.ReachPx();
  const long long first = cells.First();
  for (const auto& [n, size, name] :
       {std::tuple{cells.rows, block.rows, "rows"}, {cells.cols, block.cols, "cols"}}) {
    const long long last = first + static_cast<long long>(n - 1) * cells.stride;
    if (first - reach < 0 || last + reach + 1 > size) {
      throw InputError(std::string("cells.") + name + ": the block's " + name + " (" +
                       std::to_string(size) + ") do not hold the windows of " + std::to_string(n) +
                       " cells (halo " + std::to_string(cells.halo) + ", reach " +
                       std::to_string(reach) + " px)");
    }
  }
}

namespace {

// The sinks of RowKernel::Row. Features: each into its column of the row's cells.
struct FeatureSink {
  static constexpr bool kLogits = false;
  double* row;
  int nf, m;
  MOUND_INLINE void operator()(int f, const double* __restrict v) const {
    double* __restrict out = row;
    for (int l = 0; l < m; ++l) out[static_cast<size_t>(l) * nf + f] = v[l];
  }
};

// Logits: one pass per feature adds its term (AddTerm) to the cells' logits. v - v is 0 for
// a finite feature (acc + 0 is acc, to the bit) and NaN for an infinite one (which clipping
// would otherwise hide): the cell's logit becomes NaN once a feature is not finite. Row
// hands it the four features of a channel and radius at once where it computes them in one
// pass (kLogits, At).
struct LogitSink {
  static constexpr bool kLogits = true;
  const Folded& fm;
  double* acc;
  int m;
  FeatureWeights At(int f) const {
    return {fm.w_x[f], fm.lo[f], fm.hi[f], fm.w_c[f], fm.w_m[f], fm.mean[f], fm.std[f]};
  }
  MOUND_INLINE void operator()(int f, const double* __restrict v) const {
    double* __restrict out = acc;
    const FeatureWeights w = At(f);
    if (fm.hinge) {
      for (int l = 0; l < m; ++l) out[l] = AddTerm<RadiusMode::kHinge>(out[l], v[l], w);
    } else {
      for (int l = 0; l < m; ++l) out[l] = AddTerm<RadiusMode::kLinear>(out[l], v[l], w);
    }
  }
};

// The rows of cells: their features into `out` ((rows * cols) x F, NaN rows where a cell has
// none).
MOUND_INLINE void FeatureRows(Tables& t, const MultiscaleSpec& spec, const CellGrid& cells,
                              double* out) {
  const int nf = spec.NumFeatures();
  const int m = cells.cols;
  std::vector<unsigned char> enough(m);
  RowKernel kernel(spec, m);
  for (int k = 0; k < cells.rows; ++k) {
    const RowCells rc{cells.First() + k * cells.stride, cells.First(), cells.stride, m};
    t.AddRowsTo(rc.i + spec.ReachPx() + 1);
    double* row = out + static_cast<size_t>(k) * m * nf;
    kernel.Row(t, rc, enough.data(), FeatureSink{row, nf, m});
    for (int l = 0; l < m; ++l) {
      double* x = row + static_cast<size_t>(l) * nf;
      const bool ok =
          enough[l] && std::all_of(x, x + nf, [](double v) { return std::isfinite(v); });
      if (!ok) std::fill(x, x + nf, kNan);
    }
  }
}

// The rows of cells: their logits into `out` (rows * cols, NaN where a cell has none).
MOUND_INLINE void LogitRows(Tables& t, const MultiscaleSpec& spec, const Folded& fm,
                            const CellGrid& cells, double* out) {
  const int m = cells.cols;
  std::vector<unsigned char> enough(m);
  RowKernel kernel(spec, m);
  for (int k = 0; k < cells.rows; ++k) {
    const RowCells rc{cells.First() + k * cells.stride, cells.First(), cells.stride, m};
    t.AddRowsTo(rc.i + spec.ReachPx() + 1);
    double* __restrict acc = out + static_cast<size_t>(k) * m;
    std::fill(acc, acc + m, fm.constant);
    kernel.Row(t, rc, enough.data(), LogitSink{fm, acc, m});
    for (int l = 0; l < m; ++l) {
      if (!enough[l]) acc[l] = kNan;
    }
  }
}

// The same loops compiled twice: for any x86-64 (SSE2) and for AVX2, chosen at run time.
// Neither lets the compiler fuse a multiply and an add (-ffp-contract=off) or reorder
// sums, so both give the same bits.
void FeatureRowsGeneric(Tables& t, const MultiscaleSpec& spec, const CellGrid& cells, double* out) {
  FeatureRows(t, spec, cells, out);
}
void LogitRowsGeneric(Tables& t, const MultiscaleSpec& spec, const Folded& fm,
                      const CellGrid& cells, double* out) {
  LogitRows(t, spec, fm, cells, out);
}
#if MOUND_SCENE_X86
__attribute__((target("avx2"))) void FeatureRowsAvx2(Tables& t, const MultiscaleSpec& spec,
                                                     const CellGrid& cells, double* out) {
  FeatureRows(t, spec, cells, out);
}
__attribute__((target("avx2"))) void LogitRowsAvx2(Tables& t, const MultiscaleSpec& spec,
                                                   const Folded& fm, const CellGrid& cells,
                                                   double* out) {
  LogitRows(t, spec, fm, cells, out);
}
#endif

bool CpuHasAvx2() {
#if MOUND_SCENE_X86
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

}  // namespace

Simd ResolveSimd(Simd wanted) {
  if (wanted == Simd::kAuto) return CpuHasAvx2() ? Simd::kAvx2 : Simd::kGeneric;
  if (wanted == Simd::kAvx2 && !CpuHasAvx2()) {
    throw InputError("--simd: this CPU has no AVX2 (use generic or auto)");
  }
  return wanted;
}

std::string SimdName(Simd simd) { return NameOf(simd, kSimdNames); }

struct Scorer::Workspace {
  Tables tables;
};

Scorer::Scorer(Simd simd) : ws_(std::make_unique<Workspace>()), simd_(ResolveSimd(simd)) {}
Scorer::~Scorer() = default;

void Scorer::Features(const PixelBlock& block, const MultiscaleSpec& spec, const CellGrid& cells,
                      std::vector<double>* out) {
  spec.Check();
  CheckBlock(block, spec, cells);
  BuildTables(block, spec, ws_->tables);
  out->resize(static_cast<size_t>(cells.rows) * cells.cols * spec.NumFeatures());
#if MOUND_SCENE_X86
  if (simd_ == Simd::kAvx2) return FeatureRowsAvx2(ws_->tables, spec, cells, out->data());
#endif
  FeatureRowsGeneric(ws_->tables, spec, cells, out->data());
}

void Scorer::Logits(const PixelBlock& block, const MultiscaleSpec& spec, const LinearModel& model,
                    const CellGrid& cells, std::vector<double>* out) {
  spec.Check();
  model.Check(spec.NumFeatures());
  CheckBlock(block, spec, cells);
  BuildTables(block, spec, ws_->tables);
  const Folded fm = Fold(model);
  out->resize(static_cast<size_t>(cells.rows) * cells.cols);
#if MOUND_SCENE_X86
  if (simd_ == Simd::kAvx2) return LogitRowsAvx2(ws_->tables, spec, fm, cells, out->data());
#endif
  LogitRowsGeneric(ws_->tables, spec, fm, cells, out->data());
}

std::vector<double> Features(const PixelBlock& block, const MultiscaleSpec& spec,
                             const CellGrid& cells) {
  std::vector<double> out;
  Scorer().Features(block, spec, cells, &out);
  return out;
}

std::vector<double> Logits(const PixelBlock& block, const MultiscaleSpec& spec,
                           const LinearModel& model, const CellGrid& cells) {
  std::vector<double> out;
  Scorer().Logits(block, spec, model, cells, &out);
  return out;
}

}  // namespace mound::scene
