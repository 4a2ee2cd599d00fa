// Command-line helpers shared by the project's tools: "--key value" options after
// positional arguments, strict number parsing, and the exception-to-exit-code wrapper
// (../shared/STYLE.md: 0 ok, 2 bad input or usage with one line naming the problem,
// 1 internal error, 3 valid input that allowed no result).
#pragma once

#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "common/enum_names.h"
#include "common/error.h"

namespace mound {

struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  // "--key" -> value; flags map to ""

  bool Has(const std::string& key) const { return options.count(key) > 0; }
};

// Parses args[begin..]: anything starting with "--" must be in `known` (takes a value) or in
// `flags` (takes none); everything else is positional. Throws InputError otherwise.
Args ParseArgs(const std::vector<std::string>& args, size_t begin,
               const std::vector<std::string>& known, const std::vector<std::string>& flags = {});

// True when --help or -h stands anywhere among the arguments (the usage text then wins over
// any other argument, valid or not).
bool WantsHelp(const std::vector<std::string>& args);

// A finite number / an integer in [lo, hi]; the message names `what` (e.g. "--seed").
double ParseNumber(const std::string& s, const std::string& what);
long long ParseInt(const std::string& s, const std::string& what, long long lo, long long hi);

// The value of option `flag` as one of the enum's names; InputError "--flag: expected a,
// b or c, got 'x'" otherwise. The flag must be present.
template <typename E, size_t N>
E ParseEnum(const Args& a, const std::string& flag, const EnumName<E> (&names)[N]) {
  const std::string& value = a.options.at(flag);
  if (const std::optional<E> e = FromName(value, names)) return *e;
  throw InputError(flag + ": expected " + ExpectedNames(names) + ", got '" + value + "'");
}

// A tool's entry point: --help or -h anywhere prints `usage`, --version as the first
// argument prints `version`; anything else runs `body` under RunGuarded.
int RunTool(const std::string& tool, const std::string& usage, const std::string& version,
            const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
            const std::function<int()>& body);

// Runs `body`, mapping InputError to exit 2, NoResultError to exit 3 and any other
// exception to exit 1, each with one line "<tool>: ..." on `err`.
int RunGuarded(const std::string& tool, std::ostream& err, const std::function<int()>& body);

}  // namespace mound
