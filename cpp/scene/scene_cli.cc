#include "scene/scene_cli.h"

#include <chrono>
#include <cmath>
#include <iostream>

#include <nlohmann/json.hpp>

#include "common/cli_args.h"
#include "common/error.h"
#include "common/npy.h"
#include "scene/kernel_job.h"
#include "scene/multiscale.h"

namespace mound::scene {
namespace {

constexpr const char* kVersion = "mound_scene " MOUND_VERSION;  // pyproject.toml's, from CMake

constexpr const char* kUsage =
    "usage: mound_scene JOB.json [--logits OUT.npy] [--features OUT.npy] [--simd S]\n"
    "       mound_scene --serve [--simd S]\n"
    "       mound_scene --version\n"
    "\n"
    "Scores one block of a scene for `mound scene score`: the multiscale features of each cell\n"
    "and the model's logit, from a mound.scene_kernel job (python/mound/scene/kernel.py\n"
    "writes it beside the block's pixels). Prints {\"cells\", \"scored\", \"seconds\"} on stdout.\n"
    "  --logits OUT.npy    the logits, float64 (rows, cols), NaN where a cell has no features\n"
    "  --features OUT.npy  the features, float64 (rows, cols, F) (tests, diagnostics)\n"
    "  --serve             score streamed jobs from stdin until it ends, the tables kept\n"
    "                      between blocks (python/mound/scene/kernel.py runs one per\n"
    "                      worker thread): a job on one line, its block's raw bytes after\n"
    "                      it; each reply a JSON line and the result's bytes\n"
    "                      (cpp/scene/kernel_job.h)\n"
    "  --simd S            auto (default: AVX2 where the CPU has it), generic or avx2;\n"
    "                      the same results either way\n"
    "--help anywhere on the command line prints this text.\n"
    "Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line naming it).\n";

}  // namespace

int RunMoundScene(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return RunTool("mound_scene", kUsage, kVersion, args, out, err, [&]() {
    const Args a = ParseArgs(args, 0, {"--logits", "--features", "--simd"}, {"--serve"});
    const Simd simd = a.Has("--simd") ? ParseEnum(a, "--simd", kSimdNames) : Simd::kAuto;
    if (a.Has("--serve")) {
      if (!a.positional.empty() || a.Has("--logits") || a.Has("--features")) {
        throw InputError("--serve: takes no JOB.json, --logits or --features");
      }
      std::ios::sync_with_stdio(false);
      return ServeKernelJobs(std::cin, out, simd);
    }
    if (a.positional.size() != 1) throw InputError("expected exactly one JOB.json (see --help)");
    if (!a.Has("--logits") && !a.Has("--features")) {
      throw InputError("--logits or --features: say where the result goes");
    }
    const auto t0 = std::chrono::steady_clock::now();
    const KernelJob job = LoadKernelJob(a.positional[0]);
    const size_t rows = job.cells.rows, cols = job.cells.cols;
    size_t scored = 0;
    Scorer scorer(simd);
    std::vector<double> f, logits;
    if (a.Has("--features")) {
      scorer.Features(job.block, job.spec, job.cells, &f);
      WriteNpyFloat64(a.options.at("--features"),
                      {rows, cols, static_cast<size_t>(job.spec.NumFeatures())}, f);
    }
    if (a.Has("--logits")) {
      scorer.Logits(job.block, job.spec, job.model, job.cells, &logits);
      for (double v : logits) scored += std::isfinite(v) ? 1 : 0;
      WriteNpyFloat64(a.options.at("--logits"), {rows, cols}, logits);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out << nlohmann::json{{"cells", rows * cols},
                          {"scored", scored},
                          {"seconds", seconds},
                          {"simd", SimdName(scorer.simd())}}
               .dump()
        << "\n";
    return 0;
  });
}

}  // namespace mound::scene
