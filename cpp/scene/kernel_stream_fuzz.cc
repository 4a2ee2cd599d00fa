// libFuzzer target: the input of `mound_scene --serve` (streamed kernel jobs: a JSON line,
// then the block's raw bytes, repeated). Whatever the bytes, the server replies, refuses a
// job naming its field, or stops with an InputError; jobs that pass are scored.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "common/fuzz_check.h"
#include "scene/kernel_job.h"
#include "scene/multiscale.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::ostringstream out;
  mound::fuzz::ExpectValueOrInputError(
      [&] { mound::scene::ServeKernelJobs(in, out, mound::scene::Simd::kGeneric); });
  return 0;
}
