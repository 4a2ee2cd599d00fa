// Atomic file output: write to a temporary file in the same directory, flush, then rename
// over the destination, so a reader never sees a half-written file and a failure leaves
// whatever was there before untouched.
#pragma once

#include <cstddef>
#include <string>

namespace mound {

// Writes `contents` to `path` atomically. Throws InputError if the directory is not
// writable (a user problem), std::runtime_error for other I/O failures.
void WriteFileAtomic(const std::string& path, const std::string& contents);

// The most ReadFile accepts unless told otherwise (1 GiB): far above any input of ours.
constexpr size_t kMaxReadBytes = size_t{1} << 30;

// Reads a whole file. Throws InputError naming the path if it cannot be read or holds
// more than `max_bytes` (an endless device, a runaway file).
std::string ReadFile(const std::string& path, size_t max_bytes = kMaxReadBytes);

// A data file named inside a job file: `rel` absolute, or relative to the job's folder
// `base`. It must exist and be a regular file (not a device, a pipe or a folder), so that an
// endless input such as /dev/zero is refused before it is read; InputError "where: ..."
// otherwise.
std::string ResolveDataFile(const std::string& base, const std::string& rel,
                            const std::string& where);

}  // namespace mound
