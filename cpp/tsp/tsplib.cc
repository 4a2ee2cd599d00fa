#include "tsp/tsplib.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <sstream>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"

namespace mound::tsp {
namespace {

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Streams whitespace-separated numbers across lines, tracking the line for errors.
class NumberReader {
 public:
  NumberReader(const std::vector<std::string>& lines, size_t start, const std::string& source)
      : lines_(lines), line_(start), source_(source) {}

  double Next(const char* what) {
    for (;;) {
      std::string tok;
      if (ss_ >> tok) {
        char* end = nullptr;
        const double v = std::strtod(tok.c_str(), &end);
        if (end == tok.c_str() || *end != '\0' || !std::isfinite(v)) {
          throw InputError(Where() + ": expected a number for " + what + ", got '" + tok + "'");
        }
        return v;
      }
      if (line_ >= lines_.size()) {
        throw InputError(source_ + ": unexpected end of file while reading " + what);
      }
      ss_.clear();
      ss_.str(lines_[line_++]);
    }
  }
  size_t line() const { return line_; }  // index of the next unread line
  std::string Where() const { return source_ + ":" + std::to_string(line_); }

 private:
  const std::vector<std::string>& lines_;
  size_t line_;
  const std::string& source_;
  std::istringstream ss_;
};

// Bounds checked before any allocation or arithmetic. Coordinates within 10^9 keep every
// distance below 3 * 10^9 and a tour of 10^6 nodes, scaled by the ascent's precision
// (100), below 10^18 < 2^63; explicit weights within 10^9 likewise. An explicit matrix of
// 10^4 nodes is 800 MB of 64-bit costs: the most this reader builds.
constexpr long kMaxDimension = 1000000;
constexpr long kMaxExplicitDimension = 10000;
constexpr double kMaxCoordinate = 1e9;
constexpr double kMaxWeight = 1e9;
constexpr double kMaxScore = 1e9;
constexpr double kMaxCostLimit = 1e15;

// A 1-based node id read as a number: an integer in 1..n, returned 0-based.
int NodeIndex(double v, int n, const std::string& where, const char* what) {
  if (!(v >= 1 && v <= n) || v != std::floor(v)) {
    throw InputError(where + ": " + what + " " + FormatNumber(v) + " is not a node id in 1.." +
                     std::to_string(n));
  }
  return static_cast<int>(v) - 1;
}

double Bounded(double v, double lo, double hi, const std::string& where, const char* what) {
  if (v < lo || v > hi) {
    throw InputError(where + ": " + what + " " + FormatNumber(v) + " outside [" + FormatNumber(lo) +
                     ", " + FormatNumber(hi) + "]");
  }
  return v;
}

// A node section: `n` records "id value...", each id once; read_values(0-based id) reads
// the rest of a record.
template <typename F>
void ReadNodeRecords(NumberReader& r, int n, F&& read_values) {
  std::vector<bool> seen(n, false);
  for (int k = 0; k < n; ++k) {
    const int idx = NodeIndex(r.Next("node id"), n, r.Where(), "node id");
    if (seen[idx]) throw InputError(r.Where() + ": repeated node id " + std::to_string(idx + 1));
    seen[idx] = true;
    read_values(idx);
  }
}

}  // namespace

namespace {

// The numbers of an EDGE_WEIGHT_SECTION (from line `*i` on, which it moves past) in file
// order: as many as `format` holds for `n` nodes.
std::vector<Cost> ReadEdgeWeights(const std::vector<std::string>& lines, size_t* i,
                                  const std::string& format, long long n, size_t lineno,
                                  const std::string& source) {
  long long count = 0;
  if (format == "FULL_MATRIX")
    count = n * n;
  else if (format == "UPPER_ROW" || format == "LOWER_ROW")
    count = n * (n - 1) / 2;
  else if (format == "UPPER_DIAG_ROW" || format == "LOWER_DIAG_ROW")
    count = n * (n + 1) / 2;
  else
    throw InputError(source + ": EDGE_WEIGHT_FORMAT " + format + " not supported");
  if (n > kMaxExplicitDimension) {
    throw InputError(source + ":" + std::to_string(lineno) + ": an explicit matrix of " +
                     std::to_string(n) + " nodes is more than this reader builds (at most " +
                     std::to_string(kMaxExplicitDimension) + ")");
  }
  NumberReader r(lines, *i, source);
  std::vector<Cost> weights;
  // Grown as the numbers come (not sized from DIMENSION): a short file fails at its end.
  for (long long k = 0; k < count; ++k) {
    const double w = Bounded(r.Next("edge weight"), 0, kMaxWeight, r.Where(), "edge weight");
    weights.push_back(static_cast<Cost>(std::llround(w)));
  }
  *i = r.line();
  return weights;
}

// The n x n matrix of the weights as `format` lays them out (FULL_MATRIX must be
// symmetric).
std::vector<Cost> SymmetricMatrix(const std::vector<Cost>& weights, const std::string& format,
                                  int n, const std::string& source) {
  std::vector<Cost> m(static_cast<size_t>(n) * n, 0);
  size_t k = 0;
  auto set = [&](int a, int b) {
    m[static_cast<size_t>(a) * n + b] = weights[k];
    m[static_cast<size_t>(b) * n + a] = weights[k];
    ++k;
  };
  if (format == "FULL_MATRIX") {
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) m[static_cast<size_t>(a) * n + b] = weights[k++];
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < a; ++b)
        if (m[static_cast<size_t>(a) * n + b] != m[static_cast<size_t>(b) * n + a])
          throw InputError(source + ": FULL_MATRIX is not symmetric");
  } else if (format == "UPPER_ROW") {
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) set(a, b);
  } else if (format == "LOWER_ROW") {
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < a; ++b) set(a, b);
  } else if (format == "UPPER_DIAG_ROW") {
    for (int a = 0; a < n; ++a)
      for (int b = a; b < n; ++b) set(a, b);
  } else {  // LOWER_DIAG_ROW
    for (int a = 0; a < n; ++a)
      for (int b = 0; b <= a; ++b) set(a, b);
  }
  return m;
}

// The metric EDGE_WEIGHT_TYPE names.
Metric MetricOf(const std::string& ewt, const std::string& source) {
  Metric metric;
  if (ewt == "EUC_2D")
    metric = Metric::kEuc2D;
  else if (ewt == "CEIL_2D")
    metric = Metric::kCeil2D;
  else if (ewt == "ATT")
    metric = Metric::kAtt;
  else if (ewt == "GEO")
    metric = Metric::kGeo;
  else if (ewt.empty())
    throw InputError(source + ": EDGE_WEIGHT_TYPE missing");
  else
    throw InputError(source + ": EDGE_WEIGHT_TYPE " + ewt + " not supported");
  return metric;
}

}  // namespace

TsplibInstance ParseTsplib(const std::string& text, const std::string& source) {
  std::vector<std::string> lines;
  {
    std::istringstream in(text);
    std::string l;
    while (std::getline(in, l)) lines.push_back(l);
  }
  TsplibInstance inst;
  std::string format = "FULL_MATRIX";
  std::vector<double> x, y;
  std::vector<Cost> weights;  // as read, in file order
  bool have_coords = false, have_weights = false;

  size_t i = 0;
  auto need_dim = [&](size_t line) {
    if (inst.dimension <= 0) {
      throw InputError(source + ":" + std::to_string(line) + ": DIMENSION must come first");
    }
  };
  while (i < lines.size()) {
    const std::string line = Trim(lines[i]);
    const size_t lineno = i + 1;
    ++i;
    if (line.empty()) continue;
    std::string key = line, value;
    const auto colon = line.find(':');
    if (colon != std::string::npos) {
      key = Trim(line.substr(0, colon));
      value = Trim(line.substr(colon + 1));
    }
    if (key == "EOF") break;
    if (key == "NAME") {
      inst.name = value;
    } else if (key == "TYPE") {
      inst.type = value;
      if (value != "TSP" && value != "OP") {
        throw InputError(source + ":" + std::to_string(lineno) + ": TYPE " + value +
                         " not supported (symmetric TSP or OP only)");
      }
    } else if (key == "DIMENSION") {
      char* end = nullptr;
      errno = 0;
      const long d = std::strtol(value.c_str(), &end, 10);
      if (end == value.c_str() || *end != '\0' || errno != 0 || d < 1 || d > kMaxDimension) {
        throw InputError(source + ":" + std::to_string(lineno) + ": bad DIMENSION '" + value +
                         "' (1.." + std::to_string(kMaxDimension) + ")");
      }
      if (inst.dimension > 0) {
        throw InputError(source + ":" + std::to_string(lineno) + ": DIMENSION given twice");
      }
      inst.dimension = static_cast<int>(d);
    } else if (key == "EDGE_WEIGHT_TYPE") {
      inst.edge_weight_type = value;
    } else if (key == "EDGE_WEIGHT_FORMAT") {
      format = value;
    } else if (key == "COST_LIMIT") {
      char* end = nullptr;
      const double c = std::strtod(value.c_str(), &end);
      if (end == value.c_str() || *end != '\0' || !(c >= 0 && c <= kMaxCostLimit)) {
        throw InputError(source + ":" + std::to_string(lineno) + ": bad COST_LIMIT '" + value +
                         "' (a number in [0, 1e15])");
      }
      inst.cost_limit = c;
    } else if (key == "NODE_COORD_SECTION") {
      need_dim(lineno);
      NumberReader r(lines, i, source);
      x.assign(inst.dimension, 0);
      y.assign(inst.dimension, 0);
      ReadNodeRecords(r, inst.dimension, [&](int idx) {
        x[idx] = Bounded(r.Next("x coordinate"), -kMaxCoordinate, kMaxCoordinate, r.Where(),
                         "x coordinate");
        y[idx] = Bounded(r.Next("y coordinate"), -kMaxCoordinate, kMaxCoordinate, r.Where(),
                         "y coordinate");
      });
      i = r.line();
      have_coords = true;
    } else if (key == "EDGE_WEIGHT_SECTION") {
      need_dim(lineno);
      weights = ReadEdgeWeights(lines, &i, format, inst.dimension, lineno, source);
      have_weights = true;
    } else if (key == "NODE_SCORE_SECTION") {
      need_dim(lineno);
      NumberReader r(lines, i, source);
      inst.scores.assign(inst.dimension, 0);
      ReadNodeRecords(r, inst.dimension, [&](int idx) {
        inst.scores[idx] = Bounded(r.Next("score"), 0, kMaxScore, r.Where(), "score");
      });
      i = r.line();
    } else if (key == "DEPOT_SECTION") {
      need_dim(lineno);
      NumberReader r(lines, i, source);
      inst.depot = NodeIndex(r.Next("depot"), inst.dimension, r.Where(), "depot");
      if (r.Next("depot terminator") != -1) {
        throw InputError(r.Where() + ": DEPOT_SECTION: one depot then -1 expected");
      }
      i = r.line();
    } else if (key == "DISPLAY_DATA_SECTION") {
      need_dim(lineno);
      NumberReader r(lines, i, source);
      for (int k = 0; k < 3 * inst.dimension; ++k) r.Next("display data");
      i = r.line();
    } else if (key == "COMMENT" || key == "DISPLAY_DATA_TYPE" || key == "NODE_COORD_TYPE" ||
               key == "TSPSOL" || key == "TSP_SOLUTION" || key == "CAPACITY") {
      continue;  // informational (TSPSOL/TSP_SOLUTION: a TSP length noted in OPLib files)
    } else {
      throw InputError(source + ":" + std::to_string(lineno) + ": unknown keyword '" + key + "'");
    }
  }
  if (inst.dimension <= 0) throw InputError(source + ": DIMENSION missing");
  if (inst.type.empty()) inst.type = "TSP";
  const std::string& ewt = inst.edge_weight_type;
  if (ewt == "EXPLICIT") {
    if (!have_weights) throw InputError(source + ": EDGE_WEIGHT_SECTION missing");
    const int n = inst.dimension;
    inst.problem = std::make_unique<MatrixProblem>(n, SymmetricMatrix(weights, format, n, source));
  } else {
    const Metric metric = MetricOf(ewt, source);
    if (!have_coords) throw InputError(source + ": NODE_COORD_SECTION missing");
    inst.problem = std::make_unique<CoordProblem>(metric, std::move(x), std::move(y));
  }
  return inst;
}

TsplibInstance ReadTsplib(const std::string& path) { return ParseTsplib(ReadFile(path), path); }

std::vector<int> ReadTsplibTour(const std::string& path) {
  const std::string text = ReadFile(path);
  std::istringstream in(text);
  std::string line;
  bool in_section = false;
  std::vector<int> tour;
  while (std::getline(in, line)) {
    line = Trim(line);
    if (!in_section) {
      if (line == "TOUR_SECTION") in_section = true;
      continue;
    }
    std::istringstream ls(line);
    long v;
    while (ls >> v) {
      if (v == -1) return tour;
      tour.push_back(static_cast<int>(v) - 1);
    }
  }
  if (!in_section) throw InputError(path + ": TOUR_SECTION missing");
  return tour;
}

}  // namespace mound::tsp
