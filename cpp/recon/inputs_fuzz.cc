// libFuzzer target: the 3-D stage's camera (mound.camera JSON or K.txt) and GPS
// (mound.poses) readers. The first byte picks the reader.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "common/fuzz_check.h"
#include "recon/inputs.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  mound::fuzz::ExpectValueOrInputError([&] {
    if (data[0] % 2 == 0) {
      const auto c = mound::recon::ParseCamera(text, "camera.json", 640, 480);
      if (!(c.fx > 0 && c.fy > 0)) std::abort();
    } else {
      const std::vector<std::string> files = {"0000.png", "0001.png", "0002.png"};
      mound::recon::ParseGpsPoses(text, "poses.json", files);
    }
  });
  return 0;
}
