#include "common/cli_args.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "common/error.h"

namespace mound {

Args ParseArgs(const std::vector<std::string>& args, size_t begin,
               const std::vector<std::string>& known, const std::vector<std::string>& flags) {
  Args a;
  for (size_t i = begin; i < args.size(); ++i) {
    const std::string& s = args[i];
    if (s.rfind("--", 0) != 0) {
      a.positional.push_back(s);
    } else if (std::find(flags.begin(), flags.end(), s) != flags.end()) {
      a.options[s] = "";
    } else if (std::find(known.begin(), known.end(), s) != known.end()) {
      if (i + 1 >= args.size()) throw InputError(s + ": missing value");
      a.options[s] = args[++i];
    } else {
      throw InputError(s + ": unknown option (see --help)");
    }
  }
  return a;
}

bool WantsHelp(const std::vector<std::string>& args) {
  return std::any_of(args.begin(), args.end(),
                     [](const std::string& s) { return s == "--help" || s == "-h"; });
}

double ParseNumber(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) {
    throw InputError(what + ": expected a finite number, got '" + s + "'");
  }
  return v;
}

long long ParseInt(const std::string& s, const std::string& what, long long lo, long long hi) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || v < lo || v > hi) {
    throw InputError(what + ": expected an integer in [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "], got '" + s + "'");
  }
  return v;
}

int RunGuarded(const std::string& tool, std::ostream& err, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    err << tool << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const NoResultError& e) {
    err << tool << ": no result: " << e.what() << "\n";
    return kExitNoResult;
  } catch (const std::exception& e) {
    err << tool << ": internal error (a bug, please report): " << e.what() << "\n";
    return kExitInternal;
  }
}

int RunTool(const std::string& tool, const std::string& usage, const std::string& version,
            const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
            const std::function<int()>& body) {
  if (WantsHelp(args)) {
    out << usage;
    return kExitOk;
  }
  if (!args.empty() && args[0] == "--version") {
    out << version << "\n";
    return kExitOk;
  }
  return RunGuarded(tool, err, body);
}

}  // namespace mound
