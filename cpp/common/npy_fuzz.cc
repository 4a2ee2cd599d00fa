// libFuzzer target: .npy bytes -> array (the header once overflowed the stack in std::regex).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "common/fuzz_check.h"
#include "common/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  mound::fuzz::ExpectValueOrInputError([&] {
    const mound::NpyArray a = mound::ParseNpy(in, "fuzz.npy");
    const auto v = a.AsDouble();
    if (v.size() != a.Count()) std::abort();
  });
  return 0;
}
