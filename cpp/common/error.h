// Error types and exit codes shared by every tool of the project.
//
// Contract (../shared/INTERFACES.md): exit 0 ok, 2 bad input or usage (one line on stderr
// naming the argument, file, field or line), 1 internal failure (a bug).
#pragma once

#include <stdexcept>
#include <string>

namespace mound {

enum ExitCode : int { kExitOk = 0, kExitInternal = 1, kExitBadInput = 2 };

// Thrown for anything the user can fix: a bad argument, file, field or value. The message
// is one line and names the offending item, e.g. "sites[3].reward: must be >= 0, got -1".
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace mound
