// libFuzzer target: a mound.render job's JSON. The .npy files it names are resolved in a
// folder prepared once with a small valid heightfield and texture (and whatever the job
// names besides is refused by the reader: paths outside it, missing files).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/fuzz_check.h"
#include "common/npy.h"
#include "sim/render_job.h"

namespace {

std::string Dir() {
  static const std::string dir = [] {
    const auto d = std::filesystem::temp_directory_path() /
                   ("mound_render_job_fuzz." + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    mound::WriteNpyFloat32((d / "heightfield.npy").string(), {4, 5}, std::vector<float>(20, 0.5f));
    // A uint8 (2, 2, 3) texture, written by hand (the writer does float32 only).
    std::string header = "{'descr': '|u1', 'fortran_order': False, 'shape': (2, 2, 3), }";
    header += std::string(64 - (10 + header.size() + 1) % 64, ' ') + "\n";
    std::string raw = std::string("\x93NUMPY\x01\x00", 8);
    raw += static_cast<char>(header.size() & 0xff);
    raw += static_cast<char>(header.size() >> 8);
    raw += header + std::string(12, '\x80');
    std::ofstream((d / "texture.npy").string(), std::ios::binary) << raw;
    return d.string();
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string dir = Dir();
  mound::fuzz::ExpectValueOrInputError([&] {
    const auto job = mound::sim::ParseRenderJob(text, "fuzz.json", dir);
    if (job.images.empty()) std::abort();
  });
  return 0;
}
