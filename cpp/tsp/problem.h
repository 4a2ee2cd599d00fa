// A symmetric TSP instance: n nodes, an integer distance D(i, j), optional fixed edges.
//
// Costs are integers (GainType in LKH is long long): TSPLIB distances are integers by
// definition, and callers with real-valued costs (the orienteering planner) scale them
// first, so that every gain comparison in the search is exact.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace mound::tsp {

using Cost = int64_t;

class Problem {
 public:
  virtual ~Problem() = default;
  virtual int Size() const = 0;
  virtual Cost Dist(int i, int j) const = 0;

  // Edges every tour must contain, each node in at most one (a matching). Used for the
  // end->home edge of an s-t path; the search never removes a fixed edge.
  const std::vector<std::pair<int, int>>& FixedEdges() const { return fixed_edges_; }
  void AddFixedEdge(int a, int b);  // throws std::invalid_argument if not a matching

 private:
  std::vector<std::pair<int, int>> fixed_edges_;
};

// Full matrix of distances (EXPLICIT instances, small planner subsets).
class MatrixProblem : public Problem {
 public:
  MatrixProblem(int n, std::vector<Cost> row_major);
  int Size() const override { return n_; }
  Cost Dist(int i, int j) const override { return d_[static_cast<size_t>(i) * n_ + j]; }

 private:
  int n_;
  std::vector<Cost> d_;
};

// TSPLIB metrics on node coordinates (TSPLIB95 documentation, section 2).
enum class Metric { kEuc2D, kCeil2D, kAtt, kGeo };

class CoordProblem : public Problem {
 public:
  CoordProblem(Metric metric, std::vector<double> x, std::vector<double> y);
  int Size() const override { return static_cast<int>(x_.size()); }
  Cost Dist(int i, int j) const override;

 private:
  Metric metric_;
  std::vector<double> x_, y_;
  std::vector<double> lat_, lon_;  // radians, GEO only
};

// Length of a closed tour (a permutation of 0..n-1) under `p`.
Cost TourLength(const Problem& p, const std::vector<int>& tour);

}  // namespace mound::tsp
