#include "common/json_util.h"

#include <cmath>
#include <cstdio>
#include <regex>

#include "common/error.h"

namespace mound {
namespace {

// Line and column (1-based) of byte offset `pos` in `text`.
std::pair<int, int> LineColumn(const std::string& text, size_t pos) {
  int line = 1, col = 1;
  for (size_t i = 0; i < pos && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return {line, col};
}

// The last `"key":` before `pos`, if any: names the field a syntax error happened in.
std::string LastKeyBefore(const std::string& text, size_t pos) {
  static const std::regex kKey("\"([^\"\\\\]{1,64})\"\\s*:");
  // Only the last few KiB: enough to find the key, and bounded work on a huge file.
  const size_t end = std::min(pos, text.size());
  const size_t begin = end > 4096 ? end - 4096 : 0;
  const std::string head = text.substr(begin, end - begin);
  std::string last;
  for (auto it = std::sregex_iterator(head.begin(), head.end(), kKey); it != std::sregex_iterator();
       ++it) {
    last = (*it)[1].str();
  }
  return last;
}

}  // namespace

std::string JoinPath(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string FormatNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

nlohmann::json ParseJson(const std::string& text, const std::string& file) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const size_t pos = e.byte > 0 ? e.byte - 1 : 0;
    const auto [line, col] = LineColumn(text, pos);
    std::string where = file + ":" + std::to_string(line) + ":" + std::to_string(col) + ": ";
    const std::string key = LastKeyBefore(text, pos);
    std::string hint = "not valid JSON";
    const std::string rest = text.substr(pos, 9);
    if (rest.rfind("NaN", 0) == 0 || rest.rfind("Infinity", 0) == 0 ||
        rest.rfind("-Infinity", 0) == 0) {
      hint = "NaN/Infinity is not valid JSON; values must be finite numbers";
    }
    if (!key.empty()) where += "field \"" + key + "\": ";
    throw InputError(where + hint);
  } catch (const nlohmann::json::exception& e) {
    // e.g. out_of_range for 1e400: a number that is not finite in double precision.
    throw InputError(file + ": not valid JSON (" + e.what() + ")");
  }
}

int CheckSchema(const nlohmann::json& doc, const std::string& schema, int max_version,
                const std::string& file) {
  if (!doc.is_object()) throw InputError(file + ": top level must be a JSON object");
  const std::string got = RequireString(doc, "schema", "");
  if (got != schema) {
    throw InputError("schema: expected \"" + schema + "\", got \"" + got + "\" in " + file);
  }
  const nlohmann::json& v = RequireField(doc, "version", "");
  if (!v.is_number_integer()) throw InputError("version: must be an integer in " + file);
  const int version = v.get<int>();
  if (version < 1 || version > max_version) {
    throw InputError("version: unsupported " + schema + " version " + std::to_string(version) +
                     " (this build reads 1.." + std::to_string(max_version) + ") in " + file);
  }
  return version;
}

const nlohmann::json& RequireField(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path) {
  if (!obj.is_object()) {
    throw InputError((path.empty() ? std::string("document") : path) + ": must be an object");
  }
  auto it = obj.find(key);
  if (it == obj.end() || it->is_null()) {
    throw InputError(JoinPath(path, key) + ": missing required field");
  }
  return *it;
}

double RequireFinite(const nlohmann::json& obj, const std::string& key, const std::string& path) {
  const nlohmann::json& v = RequireField(obj, key, path);
  if (!v.is_number()) throw InputError(JoinPath(path, key) + ": must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) {
    throw InputError(JoinPath(path, key) + ": must be finite, got " + FormatNumber(d));
  }
  return d;
}

double RequireInRange(const nlohmann::json& obj, const std::string& key, const std::string& path,
                      double lo, double hi) {
  const double d = RequireFinite(obj, key, path);
  if (d < lo || d > hi) {
    throw InputError(JoinPath(path, key) + ": must be in [" + FormatNumber(lo) + ", " +
                     FormatNumber(hi) + "], got " + FormatNumber(d));
  }
  return d;
}

std::optional<double> OptionalInRange(const nlohmann::json& obj, const std::string& key,
                                      const std::string& path, double lo, double hi) {
  auto it = obj.find(key);
  if (it == obj.end() || it->is_null()) return std::nullopt;
  return RequireInRange(obj, key, path, lo, hi);
}

double RequireNonNegative(const nlohmann::json& obj, const std::string& key,
                          const std::string& path) {
  const double d = RequireFinite(obj, key, path);
  if (d < 0) throw InputError(JoinPath(path, key) + ": must be >= 0, got " + FormatNumber(d));
  return d;
}

std::optional<double> OptionalNonNegative(const nlohmann::json& obj, const std::string& key,
                                          const std::string& path) {
  auto it = obj.find(key);
  if (it == obj.end() || it->is_null()) return std::nullopt;
  return RequireNonNegative(obj, key, path);
}

std::string RequireString(const nlohmann::json& obj, const std::string& key,
                          const std::string& path) {
  const nlohmann::json& v = RequireField(obj, key, path);
  if (!v.is_string()) throw InputError(JoinPath(path, key) + ": must be a string");
  std::string s = v.get<std::string>();
  if (s.empty()) throw InputError(JoinPath(path, key) + ": must not be empty");
  return s;
}

std::string RequireId(const nlohmann::json& obj, const std::string& key, const std::string& path) {
  std::string s = RequireString(obj, key, path);
  if (s.size() > kMaxIdBytes) {
    throw InputError(JoinPath(path, key) + ": longer than " + std::to_string(kMaxIdBytes) +
                     " bytes");
  }
  for (unsigned char c : s) {
    if (c < 0x20 || c == 0x7f) {
      throw InputError(JoinPath(path, key) + ": control character in an id");
    }
  }
  return s;
}

// The array `a` found at `path`: exactly `count` finite numbers.
std::vector<double> FiniteNumbers(const nlohmann::json& a, const std::string& path, size_t count) {
  if (!a.is_array() || a.size() != count) {
    throw InputError(path + ": expected an array of " + std::to_string(count) + " numbers");
  }
  std::vector<double> out;
  for (size_t i = 0; i < count; ++i) {
    if (!a[i].is_number() || !std::isfinite(a[i].get<double>())) {
      throw InputError(path + "[" + std::to_string(i) + "]: expected a finite number");
    }
    out.push_back(a[i].get<double>());
  }
  return out;
}

std::vector<double> RequireNumbers(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path, size_t count) {
  return FiniteNumbers(RequireField(obj, key, path), JoinPath(path, key), count);
}

// A 3x3 matrix as nested arrays, row-major.
std::vector<double> RequireMatrix3(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path) {
  const nlohmann::json& m = RequireField(obj, key, path);
  const std::string p = JoinPath(path, key);
  if (!m.is_array() || m.size() != 3) throw InputError(p + ": expected a 3x3 array of numbers");
  std::vector<double> out;
  for (size_t r = 0; r < 3; ++r) {
    const std::vector<double> row = FiniteNumbers(m[r], p + "[" + std::to_string(r) + "]", 3);
    out.insert(out.end(), row.begin(), row.end());
  }
  return out;
}

int RequireInt(const nlohmann::json& obj, const std::string& key, const std::string& path,
               long long lo, long long hi) {
  const nlohmann::json& v = RequireField(obj, key, path);
  if (!v.is_number_integer() || v.get<long long>() < lo || v.get<long long>() > hi) {
    throw InputError(JoinPath(path, key) + ": expected an integer in [" + std::to_string(lo) +
                     ", " + std::to_string(hi) + "]");
  }
  return static_cast<int>(v.get<long long>());
}

}  // namespace mound
