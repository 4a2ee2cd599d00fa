// libFuzzer target: a mound.scene_kernel job's JSON. The block it names is resolved in a
// folder prepared once with a small valid block (whatever else the job names is refused by
// the reader: missing files, paths that are not regular files).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/fuzz_check.h"
#include "common/npy.h"
#include "scene/kernel_job.h"
#include "scene/multiscale.h"

namespace {

std::string Dir() {
  static const std::string dir = [] {
    const auto d = std::filesystem::temp_directory_path() /
                   ("mound_scene_kernel_fuzz." + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    std::vector<float> v(2 * 24 * 24);
    for (size_t k = 0; k < v.size(); ++k) v[k] = static_cast<float>((k * 37) % 101);
    mound::WriteNpyFloat32((d / "block.npy").string(), {2, 24, 24}, v);
    return d.string();
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string dir = Dir();
  mound::fuzz::ExpectValueOrInputError([&] {
    const auto job = mound::scene::ParseKernelJob(text, "fuzz.json", dir);
    // A job that loads is scored (the kernel's loops on whatever the reader let through).
    const auto logits = mound::scene::Logits(job.block, job.spec, job.model, job.cells);
    if (logits.size() != static_cast<size_t>(job.cells.rows) * job.cells.cols) std::abort();
  });
  return 0;
}
