// sites.json -> OpInstance, and a plan -> plan.json (contract: ../shared/INTERFACES.md).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "plan/op_instance.h"

namespace mound::plan {

struct SitesFile {
  OpInstance instance;
  std::string path;
  nlohmann::json origin;  // null when absent
  nlohmann::json scan;    // the scan the scan costs came from (carried along), null when absent
  double takeoff_landing_m = 0;  // the home and end nodes' cost (see ParseSites)
  bool budget_in_file = false;   // false: BUDGET came from the command line
  // `terrain` of the file (without its matrix), null when absent. Its extra_m is in
  // instance.extra_m; a path's constant climb cost path_offset_m is taken off
  // instance.budget_m here and added back to the costs PlanToJson reports.
  nlohmann::json terrain;
  double path_offset_m = 0;
};

// Reads and validates a mound.sites v1 document. `budget_override` (the command-line
// BUDGET) replaces budget_m. Throws InputError naming the field for every defect:
// missing fields, non-finite or negative values, duplicate ids, unknown version, empty
// site list, a budget that cannot even leave home. `takeoff_landing_m` (optional, >= 0:
// the climb after take-off and the descent to land, flown once per tour) becomes the
// scan cost of the home and end nodes, so that every route pays it exactly once: a closed
// tour pays home's half twice, a path home's and end's halves.
SitesFile ReadSites(const std::string& path, std::optional<double> budget_override);
SitesFile ParseSites(const std::string& text, const std::string& path,
                     std::optional<double> budget_override);

struct PlanSummary {
  std::string algo;
  std::vector<int> route;
  double elapsed_s = 0;
  uint64_t seed = 0;
  nlohmann::json solver;  // algorithm statistics
  // Several flights (route is then the first); empty: one flight, `route`.
  std::vector<std::vector<int>> flights;
};

nlohmann::json PlanToJson(const SitesFile& sites, const PlanSummary& plan);

}  // namespace mound::plan
