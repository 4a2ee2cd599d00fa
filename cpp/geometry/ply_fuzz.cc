// libFuzzer target: PLY bytes (ASCII and binary) -> point cloud.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "common/fuzz_check.h"
#include "geometry/ply.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  mound::fuzz::ExpectValueOrInputError([&] {
    const mound::geometry::PlyCloud c = mound::geometry::ParsePly(in, "fuzz.ply");
    if (!c.rgb.empty() && c.rgb.size() != c.xyz.size()) std::abort();
  });
  return 0;
}
