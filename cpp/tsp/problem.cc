#include "tsp/problem.h"

#include <cmath>
#include <stdexcept>

namespace mound::tsp {

void Problem::AddFixedEdge(int a, int b) {
  if (a == b || a < 0 || b < 0 || a >= Size() || b >= Size()) {
    throw std::invalid_argument("fixed edge out of range");
  }
  for (const auto& [u, v] : fixed_edges_) {
    if (u == a || u == b || v == a || v == b) {
      throw std::invalid_argument("fixed edges must form a matching");
    }
  }
  fixed_edges_.emplace_back(a, b);
}

MatrixProblem::MatrixProblem(int n, std::vector<Cost> row_major) : n_(n), d_(std::move(row_major)) {
  if (n < 0 || d_.size() != static_cast<size_t>(n) * n) {
    throw std::invalid_argument("matrix size does not match dimension");
  }
}

namespace {
constexpr double kGeoPi = 3.141592;  // TSPLIB95 uses this truncated value on purpose.
constexpr double kEarthRadiusKm = 6378.388;

double GeoToRadians(double v) {
  // TSPLIB95: DDD.MM format; degrees are the integer part (truncated, as in the reference
  // implementation and LKH), minutes the rest.
  const double deg = std::trunc(v);
  const double min = v - deg;
  return kGeoPi * (deg + 5.0 * min / 3.0) / 180.0;
}
}  // namespace

CoordProblem::CoordProblem(Metric metric, std::vector<double> x, std::vector<double> y)
    : metric_(metric), x_(std::move(x)), y_(std::move(y)) {
  if (x_.size() != y_.size()) throw std::invalid_argument("x/y size mismatch");
  if (metric_ == Metric::kGeo) {
    lat_.resize(x_.size());
    lon_.resize(x_.size());
    for (size_t i = 0; i < x_.size(); ++i) {
      lat_[i] = GeoToRadians(x_[i]);
      lon_[i] = GeoToRadians(y_[i]);
    }
  }
}

Cost CoordProblem::Dist(int i, int j) const {
  const double dx = x_[i] - x_[j], dy = y_[i] - y_[j];
  switch (metric_) {
    case Metric::kEuc2D:
      return static_cast<Cost>(std::sqrt(dx * dx + dy * dy) + 0.5);
    case Metric::kCeil2D:
      return static_cast<Cost>(std::ceil(std::sqrt(dx * dx + dy * dy)));
    case Metric::kAtt: {
      const double r = std::sqrt((dx * dx + dy * dy) / 10.0);
      const Cost t = static_cast<Cost>(r + 0.5);
      return static_cast<double>(t) < r ? t + 1 : t;
    }
    case Metric::kGeo: {
      if (i == j) return 0;
      const double q1 = std::cos(lon_[i] - lon_[j]);
      const double q2 = std::cos(lat_[i] - lat_[j]);
      const double q3 = std::cos(lat_[i] + lat_[j]);
      return static_cast<Cost>(
          kEarthRadiusKm * std::acos(0.5 * ((1.0 + q1) * q2 - (1.0 - q1) * q3)) + 1.0);
    }
  }
  return 0;
}

Cost TourLength(const Problem& p, const std::vector<int>& tour) {
  Cost sum = 0;
  const size_t n = tour.size();
  for (size_t i = 0; i < n; ++i) sum += p.Dist(tour[i], tour[(i + 1) % n]);
  return sum;
}

}  // namespace mound::tsp
