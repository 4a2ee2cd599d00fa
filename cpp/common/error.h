// Error types and exit codes shared by every tool of the project.
//
// Contract (../shared/INTERFACES.md, ../shared/STYLE.md): exit 0 ok, 1 internal failure (a
// bug), 2 bad input or usage (one line on stderr naming the argument, file, field or line),
// 3 valid input that allowed no result (a degenerate scene: too little motion or texture;
// the tool still writes its result file with "status": "failed" and the reason).
//
// Three error types keep these apart: InputError (the user can fix it: exit 2),
// NoResultError (nothing is wrong with the input, it just admits no answer: exit 3) and
// InternalError (a violated precondition inside a library: a bug, exit 1).
#pragma once

#include <stdexcept>
#include <string>

namespace mound {

enum ExitCode : int { kExitOk = 0, kExitInternal = 1, kExitBadInput = 2, kExitNoResult = 3 };

// Thrown for anything the user can fix: a bad argument, file, field or value. The message
// is one line and names the offending item, e.g. "sites[3].reward: must be >= 0, got -1".
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(OneLine(what)) {}

  // The message as one line: control characters that an input put into it (a newline in a
  // dtype, a name) are written as \xNN, so stderr still gets exactly one line.
  static std::string OneLine(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (const unsigned char c : s) {
      if (c < 0x20 || c == 0x7f) {
        static const char* kHex = "0123456789abcdef";
        out += "\\x";
        out += kHex[c >> 4];
        out += kHex[c & 15];
      } else {
        out += static_cast<char>(c);
      }
    }
    return out;
  }
};

// Valid input that allowed no result, e.g. two views with fewer than 8 consistent matches.
class NoResultError : public std::runtime_error {
 public:
  explicit NoResultError(const std::string& what) : std::runtime_error(what) {}
};

// A caller broke a library function's precondition (an index out of range): a bug.
class InternalError : public std::logic_error {
 public:
  explicit InternalError(const std::string& what) : std::logic_error(what) {}
};

}  // namespace mound
