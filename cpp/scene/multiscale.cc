#include "scene/multiscale.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include "common/error.h"

namespace mound::scene {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kClip = 6.0;  // model.py's CLIP
constexpr double kInf = std::numeric_limits<double>::infinity();

// A summed-area table with a zero first row and column. Built one row at a time as numpy's
// _sat does (np.cumsum down axis 0, then along axis 1: each row's prefix sums run over the
// running column sums), so that its sums are numpy's to the bit.
class Sat {
 public:
  Sat(int rows, int cols)
      : w1_(static_cast<size_t>(cols) + 1), p_((rows + 1) * w1_, 0.0), column_(cols, 0.0) {}
  // Adds the block's next row (row `i` of the table is pixel row i - 1).
  void AddRow(int i, const double* v) {
    double* r = Row(i) + 1;
    const int cols = static_cast<int>(column_.size());
    for (int j = 0; j < cols; ++j) column_[j] += v[j];
    double run = 0;
    for (int j = 0; j < cols; ++j) r[j] = run += column_[j];
  }
  const double* Row(int i) const { return p_.data() + static_cast<size_t>(i) * w1_; }
  double* Row(int i) { return p_.data() + static_cast<size_t>(i) * w1_; }

 private:
  size_t w1_;
  std::vector<double> p_;
  std::vector<double> column_;  // the column sums so far
};

// One output row's cells: pixel row i, pixel columns j0 + l * stride (l < m).
struct RowCells {
  int i, j0, stride, m;
};

// Sums over rows i-top..i+bottom, columns j-left..j+right of every cell of the row, in
// numpy's order of operations ((A - B) - C) + D.
void Box(const Sat& p, const RowCells& rc, int top, int bottom, int left, int right, double* out) {
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

// The block's channels (bands, NDVI), their squares and valid pixels as tables.
struct Tables {
  std::vector<Sat> p1, p2;
  std::optional<Sat> count;  // none when every pixel is valid
  std::vector<unsigned char> valid;
  int cols = 0;
};

Tables BuildTables(const PixelBlock& b, const MultiscaleSpec& spec) {
  const size_t n = static_cast<size_t>(b.rows) * b.cols;
  const int nc = spec.NumChannels();
  Tables t;
  t.cols = b.cols;
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
  for (int c = 0; c < nc; ++c) {
    t.p1.emplace_back(b.rows, b.cols);
    t.p2.emplace_back(b.rows, b.cols);
  }
  if (!uniform) t.count.emplace(b.rows, b.cols);
  // One pass over the block, a row at a time: each channel's row (0 where a pixel is not
  // valid; NDVI from the band values), its square and the valid flags into the tables.
  std::vector<double> row(b.cols), sq(b.cols);
  for (int i = 0; i < b.rows; ++i) {
    const unsigned char* ok = t.valid.data() + static_cast<size_t>(i) * b.cols;
    for (int c = 0; c < nc; ++c) {
      if (c < b.bands) {
        const double* v = b.values.data() + c * n + static_cast<size_t>(i) * b.cols;
        for (int j = 0; j < b.cols; ++j) row[j] = ok[j] ? v[j] : 0.0;
      } else {
        const size_t at = static_cast<size_t>(i) * b.cols;
        const double* red = b.values.data() + spec.red_band * n + at;
        const double* nir = b.values.data() + spec.nir_band * n + at;
        for (int j = 0; j < b.cols; ++j) {
          row[j] = ok[j] ? (nir[j] - red[j]) / (nir[j] + red[j]) : 0.0;
        }
      }
      for (int j = 0; j < b.cols; ++j) sq[j] = row[j] * row[j];
      t.p1[c].AddRow(i + 1, row.data());
      t.p2[c].AddRow(i + 1, sq.data());
    }
    if (!uniform) {
      for (int j = 0; j < b.cols; ++j) row[j] = ok[j] ? 1.0 : 0.0;
      t.count->AddRow(i + 1, row.data());
    }
  }
  return t;
}

// The reciprocals of a window's valid-pixel counts over a row of cells (shared by every
// channel: one division per window and cell instead of one per channel): 1 / its area when
// every pixel is valid, else 1 / box sums of the valid table. Multiplying by them rounds
// differently from numpy's division by the counts (by an ulp).
class InvCounts {
 public:
  InvCounts(const Tables& t, const RowCells& rc, int top, int bottom, int left, int right)
      : counts_(rc.m), values_(rc.m) {
    if (!t.count) {
      std::fill(counts_.begin(), counts_.end(),
                static_cast<double>((top + bottom + 1) * (left + right + 1)));
    } else {
      Box(*t.count, rc, top, bottom, left, right, counts_.data());
    }
    for (int l = 0; l < rc.m; ++l) values_[l] = 1.0 / counts_[l];
  }
  const double* data() const { return values_.data(); }
  const double* counts() const { return counts_.data(); }

 private:
  std::vector<double> counts_, values_;
};

// Computes one row of cells' features in the order of features.py's names() and hands each
// to sink(f, values) (m values); `enough` says, per cell, whether its centre pixel is valid
// and its background window valid enough.
template <typename Sink>
void FeatureRow(const Tables& t, const MultiscaleSpec& spec, const RowCells& rc,
                std::vector<unsigned char>& enough, Sink&& sink) {
  const int m = rc.m;
  const std::vector<int>& hs = spec.radii_px;
  const int hbg = spec.background_px;
  std::set<int> sizes(hs.begin(), hs.end());
  for (int h : hs) sizes.insert(2 * h);
  sizes.insert(hbg);
  std::map<int, InvCounts> inv_n;
  for (int h : sizes) inv_n.try_emplace(h, t, rc, h, h, h, h);
  struct Halves {
    InvCounts e, w, n, s;
  };
  std::vector<Halves> half;
  std::vector<std::vector<double>> inv_ring;
  for (int h : hs) {
    half.push_back({InvCounts(t, rc, h, h, -1, h), InvCounts(t, rc, h, h, h, -1),
                    InvCounts(t, rc, h, -1, h, h), InvCounts(t, rc, -1, h, h, h)});
    // 1 / max(n(2h) - n(h), 1): the ring's count from the two windows' counts
    const double* a = inv_n.at(h).counts();
    const double* b = inv_n.at(2 * h).counts();
    std::vector<double>& r = inv_ring.emplace_back(m);
    for (int l = 0; l < m; ++l) r[l] = 1.0 / std::max(b[l] - a[l], 1.0);
  }
  std::map<int, std::vector<double>> sums;
  for (int h : sizes) sums[h].resize(m);
  std::vector<double> mean_bg(m), inv(m), q(m), mean(m), f(m), ea(m), wa(m), de(m), dn(m);
  const int nc = spec.NumChannels();
  std::vector<std::vector<double>> small(nc, std::vector<double>(m));
  int k = 0;
  for (int c = 0; c < nc; ++c) {
    const Sat& p1 = t.p1[c];
    const Sat& p2 = t.p2[c];
    for (int h : sizes) Box(p1, rc, h, h, h, h, sums[h].data());
    {
      const double* rbg = inv_n.at(hbg).data();
      const double* sbg = sums[hbg].data();
      Box(p2, rc, hbg, hbg, hbg, hbg, q.data());
      for (int l = 0; l < m; ++l) {
        const double mb = sbg[l] * rbg[l];
        double var = q[l] * rbg[l] - mb * mb;
        var = std::max(var, 0.0);
        double scale = std::sqrt(var);
        scale += 1e-3 * std::fabs(mb) + 1e-9;
        mean_bg[l] = mb;
        inv[l] = 1.0 / scale;
      }
    }
    for (size_t r = 0; r < hs.size(); ++r) {
      const int h = hs[r];
      const double* rn = inv_n.at(h).data();
      const double* rr = inv_ring[r].data();
      const double* s = sums[h].data();
      const double* s2 = sums[2 * h].data();
      for (int l = 0; l < m; ++l) {
        mean[l] = s[l] * rn[l];
        const double ring = (s2[l] - s[l]) * rr[l];
        f[l] = (mean[l] - ring) * inv[l];
      }
      if (r == 0) std::copy(mean.begin(), mean.end(), small[c].begin());
      sink(k++, f.data());
      for (int l = 0; l < m; ++l) f[l] = std::fabs(f[l]);
      sink(k++, f.data());
      Box(p2, rc, h, h, h, h, q.data());
      for (int l = 0; l < m; ++l) {
        double var = q[l] * rn[l] - mean[l] * mean[l];
        var = std::max(var, 0.0);
        f[l] = std::sqrt(var) * inv[l];
      }
      sink(k++, f.data());
      const Halves& hv = half[r];
      const double *re = hv.e.data(), *rw = hv.w.data(), *rno = hv.n.data(), *rs = hv.s.data();
      Box(p1, rc, h, h, -1, h, ea.data());
      Box(p1, rc, h, h, h, -1, wa.data());
      for (int l = 0; l < m; ++l) de[l] = ea[l] * re[l] - wa[l] * rw[l];
      Box(p1, rc, h, -1, h, h, ea.data());
      Box(p1, rc, -1, h, h, h, wa.data());
      for (int l = 0; l < m; ++l) {
        dn[l] = ea[l] * rno[l] - wa[l] * rs[l];
        f[l] = std::sqrt(de[l] * de[l] + dn[l] * dn[l]) * inv[l];
      }
      sink(k++, f.data());
    }
  }
  if (spec.HasNdvi()) {
    sink(k++, small[nc - 1].data());
    sink(k++, mean_bg.data());  // the last channel's: NDVI's
  }
  if (spec.n_bands > 1) {
    std::vector<double> total(m, 0.0);
    for (int b = 0; b < spec.n_bands; ++b) {
      for (int l = 0; l < m; ++l) total[l] += small[b][l];
    }
    for (int b = 0; b < spec.n_bands; ++b) {
      for (int l = 0; l < m; ++l) f[l] = small[b][l] / total[l];
      sink(k++, f.data());
    }
  }
  const double need = spec.min_valid * (2.0 * hbg + 1) * (2.0 * hbg + 1);
  const double* nbg = inv_n.at(hbg).counts();
  const unsigned char* valid_row = t.valid.data() + static_cast<size_t>(rc.i) * t.cols;
  for (int l = 0; l < m; ++l) {
    enough[l] = valid_row[rc.j0 + l * rc.stride] && nbg[l] >= need;
  }
}

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

std::vector<double> Features(const PixelBlock& block, const MultiscaleSpec& spec,
                             const CellGrid& cells) {
  spec.Check();
  CheckBlock(block, spec, cells);
  const Tables t = BuildTables(block, spec);
  const int nf = spec.NumFeatures();
  const int m = cells.cols;
  std::vector<double> out(static_cast<size_t>(cells.rows) * m * nf);
  std::vector<unsigned char> enough(m);
  for (int k = 0; k < cells.rows; ++k) {
    const RowCells rc{cells.First() + k * cells.stride, cells.First(), cells.stride, m};
    double* row = out.data() + static_cast<size_t>(k) * m * nf;
    FeatureRow(t, spec, rc, enough, [&](int f, const double* v) {
      for (int l = 0; l < m; ++l) row[static_cast<size_t>(l) * nf + f] = v[l];
    });
    for (int l = 0; l < m; ++l) {
      double* x = row + static_cast<size_t>(l) * nf;
      const bool ok =
          enough[l] && std::all_of(x, x + nf, [](double v) { return std::isfinite(v); });
      if (!ok) std::fill(x, x + nf, kNan);
    }
  }
  return out;
}

std::vector<double> Logits(const PixelBlock& block, const MultiscaleSpec& spec,
                           const LinearModel& model, const CellGrid& cells) {
  spec.Check();
  model.Check(spec.NumFeatures());
  CheckBlock(block, spec, cells);
  const Tables t = BuildTables(block, spec);
  const Folded fm = Fold(model);
  const int m = cells.cols;
  std::vector<double> out(static_cast<size_t>(cells.rows) * m);
  std::vector<unsigned char> enough(m);
  std::vector<double> finite(m);
  double* fin = finite.data();
  for (int k = 0; k < cells.rows; ++k) {
    const RowCells rc{cells.First() + k * cells.stride, cells.First(), cells.stride, m};
    double* acc = out.data() + static_cast<size_t>(k) * m;
    std::fill(acc, acc + m, fm.constant);
    std::fill(finite.begin(), finite.end(), 0.0);
    // One pass per feature: fin becomes NaN once a feature is not finite (x * 0).
    FeatureRow(t, spec, rc, enough, [&](int f, const double* v) {
      const double wx = fm.w_x[f], lo = fm.lo[f], hi = fm.hi[f];
      if (fm.hinge) {
        const double wc = fm.w_c[f], wm = fm.w_m[f], mu = fm.mean[f], sd = fm.std[f];
        const double clo = mu - sd, chi = mu + sd;
        for (int l = 0; l < m; ++l) {
          fin[l] += v[l] * 0.0;
          const double x = std::min(std::max(v[l], lo), hi);
          const double xc = std::min(std::max(x, clo), chi);
          const double dev = std::max(std::fabs(x - mu), sd);
          acc[l] += wx * x + wm * dev - wc * xc;
        }
      } else {
        for (int l = 0; l < m; ++l) {
          fin[l] += v[l] * 0.0;
          acc[l] += wx * std::min(std::max(v[l], lo), hi);
        }
      }
    });
    for (int l = 0; l < m; ++l) {
      if (!enough[l] || finite[l] != 0.0) acc[l] = kNan;
    }
  }
  return out;
}

}  // namespace mound::scene
