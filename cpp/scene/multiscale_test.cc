#include "scene/multiscale.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "common/error.h"

namespace mound::scene {
namespace {

// A small block of textured pixels with a bright disc (a "mound") in band 0.
PixelBlock RandomBlock(int bands, int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 5);
  PixelBlock b{bands, rows, cols, {}};
  for (int c = 0; c < bands; ++c) {
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        const double r = std::hypot(i - rows / 2, j - cols / 2);
        b.values.push_back(200 + 40 * c + noise(rng) + (c == 0 && r < 5 ? 30 : 0) + 0.3 * j);
      }
    }
  }
  return b;
}

MultiscaleSpec Spec(int bands, bool ndvi) {
  MultiscaleSpec s;
  s.radii_px = {1, 2, 4};
  s.background_px = 8;
  s.n_bands = bands;
  if (ndvi) {
    s.red_band = 1;
    s.nir_band = 2;
  }
  return s;
}

// The features of one pixel straight from their definition (plain loops over each window).
std::vector<double> Naive(const PixelBlock& b, const MultiscaleSpec& s, int i, int j) {
  const size_t n = static_cast<size_t>(b.rows) * b.cols;
  auto valid = [&](int r, int c) {
    for (int k = 0; k < b.bands; ++k) {
      if (!std::isfinite(b.values[k * n + r * b.cols + c])) return false;
    }
    if (s.HasNdvi()) {
      const double red = b.values[s.red_band * n + r * b.cols + c];
      const double nir = b.values[s.nir_band * n + r * b.cols + c];
      if (!(std::fabs(nir + red) > 1e-9)) return false;
    }
    return true;
  };
  auto value = [&](int ch, int r, int c) {
    if (ch < b.bands) return b.values[ch * n + r * b.cols + c];
    const double red = b.values[s.red_band * n + r * b.cols + c];
    const double nir = b.values[s.nir_band * n + r * b.cols + c];
    return (nir - red) / (nir + red);
  };
  struct Stat {
    double sum = 0, sq = 0, n = 0;
    double Mean() const { return sum / n; }
  };
  auto window = [&](int ch, int r0, int r1, int c0, int c1) {  // inclusive
    Stat st;
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        if (!valid(r, c)) continue;
        const double v = value(ch, r, c);
        st.sum += v;
        st.sq += v * v;
        st.n += 1;
      }
    }
    return st;
  };
  std::vector<double> out, small;
  double last_bg_mean = 0;
  const int hb = s.background_px;
  for (int ch = 0; ch < s.NumChannels(); ++ch) {
    const Stat bg = window(ch, i - hb, i + hb, j - hb, j + hb);
    const double sigma = std::sqrt(std::max(bg.sq / bg.n - bg.Mean() * bg.Mean(), 0.0)) +
                         1e-3 * std::fabs(bg.Mean()) + 1e-9;
    last_bg_mean = bg.Mean();
    for (size_t k = 0; k < s.radii_px.size(); ++k) {
      const int h = s.radii_px[k];
      const Stat in = window(ch, i - h, i + h, j - h, j + h);
      const Stat outer = window(ch, i - 2 * h, i + 2 * h, j - 2 * h, j + 2 * h);
      const double ring = (outer.sum - in.sum) / std::max(outer.n - in.n, 1.0);
      const double contrast = (in.Mean() - ring) / sigma;
      out.push_back(contrast);
      out.push_back(std::fabs(contrast));
      out.push_back(std::sqrt(std::max(in.sq / in.n - in.Mean() * in.Mean(), 0.0)) / sigma);
      const double de = window(ch, i - h, i + h, j + 1, j + h).Mean() -
                        window(ch, i - h, i + h, j - h, j - 1).Mean();
      const double dn = window(ch, i - h, i - 1, j - h, j + h).Mean() -
                        window(ch, i + 1, i + h, j - h, j + h).Mean();
      out.push_back(std::hypot(de, dn) / sigma);
      if (k == 0) small.push_back(in.Mean());
    }
  }
  if (s.HasNdvi()) {
    out.push_back(small.back());
    out.push_back(last_bg_mean);
  }
  if (s.n_bands > 1) {
    double total = 0;
    for (int k = 0; k < s.n_bands; ++k) total += small[k];
    for (int k = 0; k < s.n_bands; ++k) out.push_back(small[k] / total);
  }
  return out;
}

void ExpectNear(const std::vector<double>& got, const std::vector<double>& want, double tol) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t k = 0; k < got.size(); ++k) {
    EXPECT_NEAR(got[k], want[k], tol * (1 + std::fabs(want[k]))) << "feature " << k;
  }
}

TEST(Multiscale, FeaturesFollowTheirDefinition) {
  for (const bool ndvi : {false, true}) {
    const MultiscaleSpec s = Spec(3, ndvi);
    const PixelBlock b = RandomBlock(3, 40, 44, 7);
    const CellGrid cells{9, 2, 9, 11};  // centres 10, 12, ..., 26 and 10 .. 30
    const std::vector<double> f = Features(b, s, cells);
    const int nf = s.NumFeatures();
    ASSERT_EQ(f.size(), static_cast<size_t>(9 * 11 * nf));
    EXPECT_EQ(nf, (3 + ndvi) * 4 * 3 + (ndvi ? 2 : 0) + 3);
    for (int k = 0; k < cells.rows; k += 4) {
      for (int l = 0; l < cells.cols; l += 3) {
        const std::vector<double> want = Naive(b, s, cells.First() + k * 2, cells.First() + l * 2);
        const auto at = f.begin() + (static_cast<size_t>(k) * cells.cols + l) * nf;
        ExpectNear(std::vector<double>(at, at + nf), want, 1e-9);
      }
    }
  }
}

TEST(Multiscale, AMoundIsBrighterThanItsRing) {
  const MultiscaleSpec s = Spec(1, false);
  const PixelBlock b = RandomBlock(1, 40, 40, 3);  // a disc of radius 5 px at (20, 20)
  const std::vector<double> on = Features(b, s, CellGrid{20, 1, 1, 1});
  EXPECT_GT(on[4 * 2 + 0], 1.0);  // radius 4's contrast: more than a background sigma
  EXPECT_GT(on[4 * 2 + 2], 0.0);  // texture
  const std::vector<double> off = Features(b, s, CellGrid{12, 1, 1, 1});  // (12, 12)
  EXPECT_LT(std::fabs(off[4 * 2 + 0]), on[4 * 2 + 0] / 2);
}

TEST(Multiscale, NodataGivesNoFeatures) {
  const MultiscaleSpec s = Spec(2, false);
  PixelBlock b = RandomBlock(2, 40, 40, 5);
  const size_t n = 40 * 40;
  b.values[1 * n + 20 * 40 + 20] = std::nan("");  // the centre of cell (0, 0) below
  for (int i = 0; i < 40; ++i) b.values[i * 40 + 13] = std::nan("");  // a column in the halo
  const CellGrid cells{20, 1, 1, 2};                                  // centres (20, 20|21)
  const std::vector<double> f = Features(b, s, cells);
  const int nf = s.NumFeatures();
  for (int k = 0; k < nf; ++k) EXPECT_TRUE(std::isnan(f[k]));
  // Cell (0, 1): one invalid column of 17 in its background window: 94 % < 95 % valid.
  for (int k = 0; k < nf; ++k) EXPECT_TRUE(std::isnan(f[nf + k]));
  MultiscaleSpec lax = s;
  lax.min_valid = 0.9;
  const std::vector<double> g = Features(b, lax, cells);
  for (int k = 0; k < nf; ++k) EXPECT_TRUE(std::isfinite(g[nf + k]));
}

double PlainLogit(const LinearModel& m, const double* x, int nf) {
  double out = m.weights.back();
  for (int k = 0; k < nf; ++k) {
    double z = (x[k] - m.mean[k]) / m.std[k];
    if (m.clip) z = std::min(std::max(z, -6.0), 6.0);
    out += m.weights[k] * z;
    if (m.basis == Basis::kHinge) {
      out +=
          m.weights[nf + k] * std::max(z - 1, 0.0) + m.weights[2 * nf + k] * std::max(-z - 1, 0.0);
    }
  }
  return out;
}

TEST(Multiscale, LogitsAreTheModelOfTheFeatures) {
  const MultiscaleSpec s = Spec(3, true);
  const PixelBlock b = RandomBlock(3, 40, 44, 11);
  const CellGrid cells{8, 1, 24, 28};
  const std::vector<double> f = Features(b, s, cells);
  const int nf = s.NumFeatures();
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  for (const Basis basis : {Basis::kNone, Basis::kHinge}) {
    for (const bool clip : {false, true}) {
      LinearModel m{basis, clip, {}, {}, {}};
      for (int k = 0; k < nf; ++k) {
        // Means and spreads from the features themselves, so that some cells clip.
        double sum = 0;
        for (int c = 0; c < cells.rows * cells.cols; ++c) sum += f[c * nf + k];
        m.mean.push_back(sum / (cells.rows * cells.cols));
        m.std.push_back(0.05 + 0.1 * std::fabs(g(rng)) * (1 + std::fabs(m.mean.back())));
      }
      for (int k = 0; k < (basis == Basis::kHinge ? 3 : 1) * nf + 1; ++k)
        m.weights.push_back(g(rng));
      const std::vector<double> logits = Logits(b, s, m, cells);
      for (int c = 0; c < cells.rows * cells.cols; ++c) {
        EXPECT_NEAR(logits[c], PlainLogit(m, &f[c * nf], nf), 1e-9 * (1 + std::fabs(logits[c])));
      }
    }
  }
}

// Stride 1 runs one fused pass per channel and radius (RadiusFeatures), other strides the
// separate box loops: the same cells get the same bits, with and without nodata (the
// count table) and NDVI.
TEST(Multiscale, StrideSamplesTheSameCells) {
  for (const bool holes : {false, true}) {
    const MultiscaleSpec s = Spec(3, true);
    PixelBlock b = RandomBlock(3, 50, 50, 13);
    if (holes) {
      b.values[50 * 20 + 22] = std::nan("");
      b.values[2 * 50 * 50 + 50 * 30 + 17] = std::nan("");
    }
    const int nf = s.NumFeatures();
    const std::vector<double> dense = Features(b, s, CellGrid{9, 1, 31, 31});   // pixels 9..39
    const std::vector<double> coarse = Features(b, s, CellGrid{8, 3, 10, 10});  // 9, 12, .., 36
    int finite = 0;
    for (int k = 0; k < 10; ++k) {
      for (int l = 0; l < 10; ++l) {
        for (int f = 0; f < nf; ++f) {
          const double want = dense[((3 * k) * 31 + 3 * l) * nf + f];
          const double got = coarse[(k * 10 + l) * nf + f];
          finite += std::isfinite(want) ? 1 : 0;
          EXPECT_TRUE(got == want || (std::isnan(got) && std::isnan(want))) << k << " " << l;
        }
      }
    }
    EXPECT_GT(finite, 50 * nf) << holes;
    // Logits too: at stride 1 the fused pass adds the four features' terms itself.
    std::mt19937 rng(5);
    std::normal_distribution<double> g(0, 1);
    for (const Basis basis : {Basis::kNone, Basis::kHinge}) {
      LinearModel model{
          basis, true, std::vector<double>(nf, 0.3), std::vector<double>(nf, 0.5), {}};
      for (int w = 0; w < (basis == Basis::kHinge ? 3 : 1) * nf + 1; ++w)
        model.weights.push_back(g(rng));
      const std::vector<double> fine = Logits(b, s, model, CellGrid{9, 1, 31, 31});
      const std::vector<double> sparse = Logits(b, s, model, CellGrid{8, 3, 10, 10});
      for (int k = 0; k < 10; ++k) {
        for (int l = 0; l < 10; ++l) {
          const double want = fine[(3 * k) * 31 + 3 * l], got = sparse[k * 10 + l];
          EXPECT_TRUE(got == want || (std::isnan(got) && std::isnan(want))) << k << " " << l;
        }
      }
    }
  }
}

// A long-lived scorer keeps its tables between blocks: blocks of other sizes, with and
// without nodata (a count table or none), give the bits a fresh scorer gives, and the
// AVX2 loops the bits of the generic ones.
TEST(Multiscale, AReusedScorerAndAvx2GiveTheBitsOfAFreshGenericOne) {
  const MultiscaleSpec s = Spec(3, true);
  const int nf = s.NumFeatures();
  std::mt19937 rng(4);
  std::normal_distribution<double> g(0, 1);
  LinearModel m{
      Basis::kHinge, true, std::vector<double>(nf, 0.5), std::vector<double>(nf, 0.7), {}};
  for (int k = 0; k < 3 * nf + 1; ++k) m.weights.push_back(g(rng));
  std::vector<Simd> simds{Simd::kGeneric};
  if (ResolveSimd(Simd::kAuto) == Simd::kAvx2) simds.push_back(Simd::kAvx2);
  for (const Simd simd : simds) {
    Scorer reused(simd);
    EXPECT_EQ(reused.simd(), simd);
    for (const int size : {40, 52, 36}) {
      for (const bool holes : {false, true}) {
        PixelBlock b = RandomBlock(3, size, size + 3, static_cast<unsigned>(size));
        if (holes) b.values[size * 5 + 7] = std::nan("");
        const CellGrid cells{8, 1, size - 16, size - 13};
        std::vector<double> got, want, fgot;
        reused.Logits(b, s, m, cells, &got);
        Scorer(Simd::kGeneric).Logits(b, s, m, cells, &want);
        ASSERT_EQ(got.size(), want.size());
        EXPECT_EQ(0, std::memcmp(got.data(), want.data(), got.size() * sizeof(double)))
            << SimdName(simd) << " " << size << " " << holes;
        reused.Features(b, s, cells, &fgot);
        const std::vector<double> fwant = Features(b, s, cells);
        ASSERT_EQ(fgot.size(), fwant.size());
        EXPECT_EQ(0, std::memcmp(fgot.data(), fwant.data(), fgot.size() * sizeof(double)));
      }
    }
  }
}

TEST(Multiscale, RefusesABlockTooSmallAndBadSpecs) {
  const MultiscaleSpec s = Spec(2, false);
  const PixelBlock b = RandomBlock(2, 30, 30, 1);
  EXPECT_NO_THROW(Features(b, s, CellGrid{8, 1, 14, 14}));  // centres 8 .. 21: reach 8 each side
  EXPECT_THROW(Features(b, s, CellGrid{8, 1, 15, 14}), InputError);
  EXPECT_THROW(Features(b, s, CellGrid{7, 1, 1, 1}), InputError);
  MultiscaleSpec bad = s;
  bad.radii_px = {2, 2};
  EXPECT_THROW(bad.Check(), InputError);
  bad = s;
  bad.background_px = 4;
  EXPECT_THROW(bad.Check(), InputError);
  bad = s;
  bad.red_band = 1;
  EXPECT_THROW(bad.Check(), InputError);  // red without near-infrared
  LinearModel m{Basis::kHinge, true, std::vector<double>(s.NumFeatures(), 0.0),
                std::vector<double>(s.NumFeatures(), 1.0),
                std::vector<double>(s.NumFeatures() + 1, 0.0)};
  EXPECT_THROW(m.Check(s.NumFeatures()), InputError);  // hinge wants 3F + 1 weights
  m.basis = Basis::kNone;
  EXPECT_NO_THROW(m.Check(s.NumFeatures()));
  m.std[2] = 0;
  EXPECT_THROW(m.Check(s.NumFeatures()), InputError);
}

}  // namespace
}  // namespace mound::scene
