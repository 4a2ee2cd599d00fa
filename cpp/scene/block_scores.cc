#include "scene/block_scores.h"

#include <cmath>
#include <limits>

#include "common/error.h"

namespace mound::scene {

BlockScores ScoreBlock(const std::vector<double>& logits, int rows, int cols, int margin,
                       const Calibration& calibration, float nodata) {
  if (margin < 0 || rows - 2 * margin < 1 || cols - 2 * margin < 1) {
    throw InputError("scores.margin: leaves no core of the block's cells");
  }
  const size_t n = static_cast<size_t>(rows) * cols;
  if (logits.size() != n) throw InputError("scores: the logits do not match the block's cells");
  constexpr double kNegInf = -std::numeric_limits<double>::infinity();
  // p of every cell (margin included), -inf where there is none (scipy's expit, both
  // branches: exp of a negative number only).
  std::vector<double> p(n);
  for (size_t k = 0; k < n; ++k) {
    const double x = calibration.a * logits[k] + calibration.b;
    if (!std::isfinite(x)) {
      p[k] = kNegInf;
    } else if (x >= 0) {
      p[k] = 1.0 / (1.0 + std::exp(-x));
    } else {
      const double e = std::exp(x);
      p[k] = e / (1.0 + e);
    }
  }
  BlockScores out;
  const int nr = rows - 2 * margin, nc = cols - 2 * margin;
  out.p.resize(static_cast<size_t>(nr) * nc);
  out.reward.resize(out.p.size());
  const double ln2 = std::log(2.0);
  for (int i = 0; i < nr; ++i) {
    for (int j = 0; j < nc; ++j) {
      const size_t at = static_cast<size_t>(i + margin) * cols + (j + margin);
      const size_t o = static_cast<size_t>(i) * nc + j;
      const double v = p[at];
      if (v == kNegInf) {
        out.p[o] = out.reward[o] = nodata;
        continue;
      }
      const double q = 1.0 - v;
      const double h = -((v > 0 ? v * std::log(v) : 0.0) + (q > 0 ? q * std::log(q) : 0.0)) / ln2;
      out.p[o] = static_cast<float>(v);
      out.reward[o] = static_cast<float>(h);
      ++out.scored;
      out.p_sum += v;
      // A 3 x 3 local maximum (outside the block: -inf).
      const int bi = i + margin, bj = j + margin;
      bool peak = true;
      for (int di = -1; di <= 1 && peak; ++di) {
        for (int dj = -1; dj <= 1; ++dj) {
          const int r = bi + di, c = bj + dj;
          if (r < 0 || r >= rows || c < 0 || c >= cols) continue;
          if (p[static_cast<size_t>(r) * cols + c] > v) {
            peak = false;
            break;
          }
        }
      }
      if (peak) {
        out.peak_row.push_back(bi);
        out.peak_col.push_back(bj);
        out.peak_p.push_back(v);
        out.peak_logit.push_back(logits[at]);
      }
    }
  }
  return out;
}

}  // namespace mound::scene
