// The orienteering instance of the planner: a home node, an end node (== home for a
// closed tour), sites with a reward and a scan cost, and a budget, all lengths in metres
// in the local ENU frame.
//
// Expanded edge cost (../shared/INTERFACES.md): c(i,j) = dist(i,j) + (s_i + s_j) / 2, with
// scan cost 0 at home and end, so a route's cost is its flight length plus the scan cost
// of every site it visits. The expanded costs satisfy the triangle inequality.
#pragma once

#include <string>
#include <vector>

namespace mound::plan {

struct OpNode {
  std::string id;
  double x_m = 0, y_m = 0;
  double reward = 0;
  double scan_cost_m = 0;
};

class OpInstance {
 public:
  // nodes[0] is home. For a path, nodes[1] is the end node; sites follow.
  std::vector<OpNode> nodes;
  int end = 0;  // index of the end node; 0 (== home) for a closed tour
  double budget_m = 0;
  // Optional n*n distances replacing the planar ones (TSPLIB metrics of OPLib files:
  // rounded, ATT, GEO, explicit). Empty: Euclidean from x_m, y_m.
  std::vector<double> dist_matrix;
  // Optional n*n symmetric costs added to every expanded edge: the climbs over the terrain
  // (sites.json `terrain.extra_m`, ../shared/INTERFACES.md). Empty: none.
  std::vector<double> extra_m;

  static constexpr int kHome = 0;
  bool Closed() const { return end == kHome; }
  int Size() const { return static_cast<int>(nodes.size()); }
  int FirstSite() const { return Closed() ? 1 : 2; }
  bool IsSite(int v) const { return v >= FirstSite(); }

  double Dist(int i, int j) const;
  // Paper: the expanded edge cost c_ij = d(i,j) + (c_i + c_j) / 2.
  double Cost(int i, int j) const {
    const double c = Dist(i, j) + 0.5 * (nodes[i].scan_cost_m + nodes[j].scan_cost_m);
    return extra_m.empty() ? c : c + extra_m[static_cast<size_t>(i) * nodes.size() + j];
  }
  // A route runs from home to the end node inclusive (closed: home ... home).
  double RouteCost(const std::vector<int>& route) const;
  double RouteReward(const std::vector<int>& route) const;
  // Empty string if `route` is a valid route within the budget, else the reason.
  std::string CheckRoute(const std::vector<int>& route) const;
  // The planners' comparison: route a collects more reward than b, or the same reward
  // (to a relative 1e-12) for at least 1e-9 m less cost. Costs are passed in because the
  // callers already have them.
  bool Better(const std::vector<int>& a, double cost_a, const std::vector<int>& b,
              double cost_b) const;
};

// Absolute tolerance for budget comparisons: the sum of route costs is recomputed in
// double precision in a fixed order; rounding differences are far below a millimetre.
inline double BudgetSlack(double budget_m) { return 1e-9 * (1.0 + budget_m); }

}  // namespace mound::plan
