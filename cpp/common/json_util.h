// Validated access to versioned JSON documents (nlohmann::json).
//
// Every accessor takes the field's path as the user would write it ("sites[3].reward") and
// throws InputError with that path in the message, so each bad input is reported as one
// line that names the field.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace mound {

// Parses `text` read from `file`. A syntax error becomes an InputError that names the file,
// line and column and, where it can be found, the key being parsed; e.g. a Python-written
// `NaN` gives "sites.json:7:18: sites value of \"reward\": NaN is not valid JSON ...".
nlohmann::json ParseJson(const std::string& text, const std::string& file);

// Checks "schema" == `schema` and "version" <= `max_version` (integer compare).
// Returns the version found.
int CheckSchema(const nlohmann::json& doc, const std::string& schema, int max_version,
                const std::string& file);

// Field accessors: `obj` must be an object; `path` is the object's own path ("" for root).
const nlohmann::json& RequireField(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path);
double RequireFinite(const nlohmann::json& obj, const std::string& key, const std::string& path);
double RequireNonNegative(const nlohmann::json& obj, const std::string& key,
                          const std::string& path);
std::optional<double> OptionalNonNegative(const nlohmann::json& obj, const std::string& key,
                                          const std::string& path);
std::string RequireString(const nlohmann::json& obj, const std::string& key,
                          const std::string& path);
// A finite number in [lo, hi] (readers bound magnitudes before any arithmetic on them).
double RequireInRange(const nlohmann::json& obj, const std::string& key, const std::string& path,
                      double lo, double hi);
std::optional<double> OptionalInRange(const nlohmann::json& obj, const std::string& key,
                                      const std::string& path, double lo, double hi);
// Exactly `count` finite numbers: the array `a` found at `path`, or the field `key`.
std::vector<double> FiniteNumbers(const nlohmann::json& a, const std::string& path, size_t count);
std::vector<double> RequireNumbers(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path, size_t count);
// A 3x3 matrix as nested arrays of finite numbers, row-major.
std::vector<double> RequireMatrix3(const nlohmann::json& obj, const std::string& key,
                                   const std::string& path);
// An integer in [lo, hi].
int RequireInt(const nlohmann::json& obj, const std::string& key, const std::string& path,
               long long lo, long long hi);
// An identifier: a non-empty string of at most kMaxIdBytes without control characters.
constexpr size_t kMaxIdBytes = 256;
std::string RequireId(const nlohmann::json& obj, const std::string& key, const std::string& path);

// "a.b" or "b" when `path` is empty.
std::string JoinPath(const std::string& path, const std::string& key);

// Formats a number for messages without trailing noise ("1.5", "-3", "nan").
std::string FormatNumber(double v);

}  // namespace mound
