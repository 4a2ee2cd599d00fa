#include "sfm/retrieval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "common/error.h"

namespace mound::sfm {
namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// RootSIFT (Arandjelovic and Zisserman 2012): L1-normalised, square-rooted; Euclidean
// distances then compare as the Hellinger kernel does.
RowMatrix RootSift(const Eigen::Matrix<float, Eigen::Dynamic, 128, Eigen::RowMajor>& d) {
  RowMatrix r = d.cwiseAbs();
  for (Eigen::Index i = 0; i < r.rows(); ++i) {
    const float l1 = r.row(i).sum();
    if (l1 > 0) r.row(i) /= l1;
  }
  return r.cwiseSqrt();
}

// Index of the nearest centre of each row of `x` (squared L2 via dot products).
std::vector<int> Assign(const RowMatrix& x, const RowMatrix& centres) {
  const Eigen::VectorXf cn = centres.rowwise().squaredNorm();
  const RowMatrix dots = x * centres.transpose();
  std::vector<int> out(static_cast<size_t>(x.rows()));
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    Eigen::Index best = 0;
    (cn.transpose() - 2 * dots.row(i)).minCoeff(&best);
    out[static_cast<size_t>(i)] = static_cast<int>(best);
  }
  return out;
}

RowMatrix Codebook(const RowMatrix& sample, const RetrievalOptions& o) {
  const Eigen::Index n = sample.rows();
  const int k = static_cast<int>(std::min<Eigen::Index>(o.words, n));
  std::mt19937_64 rng(o.seed);
  // k-means++ seeding.
  RowMatrix centres(k, sample.cols());
  centres.row(0) = sample.row(static_cast<Eigen::Index>(rng() % static_cast<uint64_t>(n)));
  Eigen::VectorXf d2 = (sample.rowwise() - centres.row(0)).rowwise().squaredNorm();
  for (int c = 1; c < k; ++c) {
    const double total = d2.cast<double>().sum();
    Eigen::Index pick = 0;
    if (total > 0) {
      double u = std::uniform_real_distribution<double>(0, total)(rng);
      for (pick = 0; pick + 1 < n; ++pick) {
        u -= d2[pick];
        if (u <= 0) break;
      }
    } else {
      pick = static_cast<Eigen::Index>(rng() % static_cast<uint64_t>(n));
    }
    centres.row(c) = sample.row(pick);
    d2 = d2.cwiseMin((sample.rowwise() - centres.row(c)).rowwise().squaredNorm());
  }
  // Lloyd iterations; an empty cluster keeps its centre.
  for (int it = 0; it < o.iterations; ++it) {
    const std::vector<int> a = Assign(sample, centres);
    RowMatrix sum = RowMatrix::Zero(k, sample.cols());
    std::vector<int> count(static_cast<size_t>(k), 0);
    for (Eigen::Index i = 0; i < n; ++i) {
      sum.row(a[static_cast<size_t>(i)]) += sample.row(i);
      ++count[static_cast<size_t>(a[static_cast<size_t>(i)])];
    }
    for (int c = 0; c < k; ++c) {
      if (count[static_cast<size_t>(c)] > 0)
        centres.row(c) = sum.row(c) / static_cast<float>(count[static_cast<size_t>(c)]);
    }
  }
  return centres;
}

}  // namespace

Eigen::MatrixXf GlobalDescriptors(const std::vector<ImageFeatures>& features,
                                  const RetrievalOptions& o) {
  if (o.words < 1 || o.sample_per_image < 1 || o.iterations < 0) {
    throw InputError("retrieval: words, sample_per_image must be >= 1 and iterations >= 0");
  }
  const int n = static_cast<int>(features.size());
  std::vector<RowMatrix> root(static_cast<size_t>(n));
  Eigen::Index sample_rows = 0;
  for (int i = 0; i < n; ++i) {
    root[static_cast<size_t>(i)] = RootSift(features[static_cast<size_t>(i)].descriptors);
    sample_rows += std::min<Eigen::Index>(root[static_cast<size_t>(i)].rows(), o.sample_per_image);
  }
  Eigen::MatrixXf out = Eigen::MatrixXf::Zero(n, 128 * static_cast<Eigen::Index>(o.words));
  if (sample_rows == 0) return out;
  // The sample: evenly spaced descriptors of every image (deterministic).
  RowMatrix sample(sample_rows, 128);
  Eigen::Index at = 0;
  for (const RowMatrix& r : root) {
    const Eigen::Index take = std::min<Eigen::Index>(r.rows(), o.sample_per_image);
    for (Eigen::Index s = 0; s < take; ++s) sample.row(at++) = r.row(s * r.rows() / take);
  }
  const RowMatrix centres = Codebook(sample, o);
  const Eigen::Index k = centres.rows();
  for (int i = 0; i < n; ++i) {
    const RowMatrix& r = root[static_cast<size_t>(i)];
    if (r.rows() == 0) continue;
    const std::vector<int> a = Assign(r, centres);
    RowMatrix v = RowMatrix::Zero(k, 128);
    for (Eigen::Index m = 0; m < r.rows(); ++m) {
      const int c = a[static_cast<size_t>(m)];
      v.row(c) += r.row(m) - centres.row(c);
    }
    for (Eigen::Index c = 0; c < k; ++c) {
      const float norm = v.row(c).norm();
      if (norm > 0) v.row(c) /= norm;
    }
    v = v.unaryExpr([](float x) { return std::copysign(std::sqrt(std::abs(x)), x); });
    const float norm = v.norm();
    if (norm > 0) v /= norm;
    out.row(i).head(k * 128) = Eigen::Map<const Eigen::RowVectorXf>(v.data(), k * 128);
  }
  return out;
}

std::vector<std::vector<int>> MostSimilar(const Eigen::MatrixXf& global, int k) {
  const int n = static_cast<int>(global.rows());
  const Eigen::MatrixXf s = global * global.transpose();
  std::vector<std::vector<int>> out(static_cast<size_t>(n));
  const int take = std::clamp(k, 0, std::max(0, n - 1));
  for (int i = 0; i < n; ++i) {
    std::vector<int> others;
    for (int j = 0; j < n; ++j)
      if (j != i) others.push_back(j);
    std::partial_sort(others.begin(), others.begin() + take, others.end(),
                      [&](int a, int b) { return s(i, a) != s(i, b) ? s(i, a) > s(i, b) : a < b; });
    others.resize(static_cast<size_t>(take));
    out[static_cast<size_t>(i)] = std::move(others);
  }
  return out;
}

}  // namespace mound::sfm
