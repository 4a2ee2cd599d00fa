// TSPLIB95 reader (Reinelt 1991): TYPE TSP (and OP, as used by OPLib), EDGE_WEIGHT_TYPE
// EUC_2D, CEIL_2D, ATT, GEO and EXPLICIT (FULL_MATRIX, UPPER_ROW, LOWER_ROW,
// UPPER_DIAG_ROW, LOWER_DIAG_ROW). "KEY: value" and "KEY : value" are both accepted.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tsp/problem.h"

namespace mound::tsp {

struct TsplibInstance {
  std::string name;
  std::string type;              // "TSP" or "OP"
  std::string edge_weight_type;  // as written in the file
  int dimension = 0;
  std::unique_ptr<Problem> problem;
  // OPLib extensions (TYPE: OP): score per node and the tour length limit.
  std::vector<double> scores;
  double cost_limit = -1;
  int depot = 0;  // 0-based
};

// Parses TSPLIB text; `source` names the file in error messages. Throws InputError with
// "FILE:LINE: ..." on malformed input.
TsplibInstance ParseTsplib(const std::string& text, const std::string& source);
TsplibInstance ReadTsplib(const std::string& path);

// Reads a TSPLIB .tour file (TOUR_SECTION, 1-based ids, -1 terminated) as 0-based ids.
std::vector<int> ReadTsplibTour(const std::string& path);

}  // namespace mound::tsp
