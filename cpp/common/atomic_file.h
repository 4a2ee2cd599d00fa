// Atomic file output: write to a temporary file in the same directory, flush, then rename
// over the destination, so a reader never sees a half-written file and a failure leaves
// whatever was there before untouched.
#pragma once

#include <string>

namespace mound {

// Writes `contents` to `path` atomically. Throws InputError if the directory is not
// writable (a user problem), std::runtime_error for other I/O failures.
void WriteFileAtomic(const std::string& path, const std::string& contents);

// Reads a whole file. Throws InputError naming the path if it cannot be read.
std::string ReadFile(const std::string& path);

}  // namespace mound
