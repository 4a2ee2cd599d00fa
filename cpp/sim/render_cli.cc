#include "sim/render_cli.h"

#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "common/npy.h"
#include "sim/render.h"
#include "sim/render_job.h"

namespace mound::sim {
namespace {

constexpr const char* kVersion = "mound_render " MOUND_VERSION;  // pyproject.toml's, from CMake

constexpr const char* kUsage =
    "usage: mound_render JOB.json --out DIR [--threads N] [--geometry]\n"
    "       mound_render --version\n"
    "\n"
    "Renders the images of a mound.render job (a heightfield terrain with a texture, a camera\n"
    "and cam_from_world poses; python/mound/sim/site.py writes them) with a z-buffer rasteriser.\n"
    "  --out DIR      where the images go (paths in the job are relative to it)\n"
    "  --threads N    images rendered in parallel (default: the number of cores)\n"
    "  --geometry     also write <image>.depth.npy and <image>.xyz.npy per image\n"
    "--help anywhere on the command line prints this text.\n"
    "Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line naming it).\n";

uint64_t SplitMix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

void WriteImage(const std::string& path, const RenderedImage& im) {
  cv::Mat rgb(im.height, im.width, CV_8UC3, const_cast<unsigned char*>(im.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<unsigned char> buf;
  const std::string ext = std::filesystem::path(path).extension().string();
  std::vector<int> params;
  if (ext == ".png")
    params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  else
    params = {cv::IMWRITE_JPEG_QUALITY, 95};
  if (!cv::imencode(ext, bgr, buf, params)) throw std::runtime_error("cannot encode " + path);
  WriteFileAtomic(path, std::string(buf.begin(), buf.end()));
}

}  // namespace

int RunMoundRender(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return RunTool("mound_render", kUsage, kVersion, args, out, err, [&]() {
    const Args a = ParseArgs(args, 0, {"--out", "--threads"}, {"--geometry"});
    if (a.positional.size() != 1) throw InputError("expected exactly one JOB.json (see --help)");
    if (!a.Has("--out")) throw InputError("--out: the output directory is required");
    const int hw = std::max(1u, std::thread::hardware_concurrency());
    const int threads =
        a.Has("--threads")
            ? static_cast<int>(ParseInt(a.options.at("--threads"), "--threads", 1, 256))
            : hw;
    const bool geometry = a.Has("--geometry");
    const auto t0 = std::chrono::steady_clock::now();
    const RenderJob job = LoadRenderJob(a.positional[0]);
    const double load_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::filesystem::path final_dir(a.options.at("--out"));
    for (size_t k = 0; k < job.images.size(); ++k) {
      std::error_code e;
      if (std::filesystem::is_directory(final_dir / job.images[k].file, e)) {
        throw InputError("images[" + std::to_string(k) +
                         "].file: " + (final_dir / job.images[k].file).string() + " is a folder");
      }
    }
    // All or nothing: the images go to a staging folder inside --out and are moved into
    // place only when every one of them has been written; a failure removes the staging
    // folder (and --out itself if this run created it), so no earlier image is left behind.
    std::error_code ec;
    const bool created_out = !std::filesystem::exists(final_dir, ec);
    std::filesystem::create_directories(final_dir, ec);
    if (ec)
      throw InputError("--out: cannot create " + final_dir.string() + " (" + ec.message() + ")");
    std::string staging_name = (final_dir / ".mound_render.XXXXXX").string();
    if (::mkdtemp(staging_name.data()) == nullptr) {
      throw InputError("--out: cannot write into " + final_dir.string());
    }
    const std::filesystem::path out_dir(staging_name);
    struct Cleanup {
      std::filesystem::path staging, out;
      bool remove_out, armed = true;
      ~Cleanup() {
        if (!armed) return;
        std::error_code e;
        std::filesystem::remove_all(staging, e);
        if (remove_out) std::filesystem::remove(out, e);  // only if empty
      }
    } cleanup{out_dir, final_dir, created_out};
    for (const ImageJob& im : job.images) {
      std::filesystem::create_directories((out_dir / im.file).parent_path(), ec);
      if (ec)
        throw InputError("--out: cannot create " + (final_dir / im.file).parent_path().string());
    }

    std::vector<double> seconds(job.images.size());
    std::vector<double> covered(job.images.size());
    std::atomic<size_t> next{0};
    std::mutex error_mutex;
    std::exception_ptr error;
    auto worker = [&]() {
      for (size_t k = next++; k < job.images.size(); k = next++) {
        try {
          const auto s0 = std::chrono::steady_clock::now();
          RenderSettings rs;
          rs.noise_sigma = job.noise_sigma;
          rs.vignetting = job.vignetting;
          rs.noise_seed = SplitMix(job.seed * 1000003ULL + k);
          rs.keep_geometry = geometry;
          const RenderedImage im = Render(job.scene, job.camera, job.images[k].cam_from_world, rs);
          const std::filesystem::path path = out_dir / job.images[k].file;
          WriteImage(path.string(), im);
          if (geometry) {
            const size_t h = static_cast<size_t>(im.height), w = static_cast<size_t>(im.width);
            WriteNpyFloat32(std::filesystem::path(path).replace_extension(".depth.npy").string(),
                            {h, w}, im.depth_m);
            WriteNpyFloat32(std::filesystem::path(path).replace_extension(".xyz.npy").string(),
                            {h, w, 3}, im.xyz_m);
          }
          covered[k] =
              static_cast<double>(im.covered_px) / (static_cast<double>(im.width) * im.height);
          seconds[k] = std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
        } catch (...) {
          std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
          next = job.images.size();
        }
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::min<int>(threads, static_cast<int>(job.images.size())); ++t)
      pool.emplace_back(worker);
    for (std::thread& t : pool) t.join();
    if (error) std::rethrow_exception(error);
    // Every image is written: move them (and their geometry) into place.
    for (const ImageJob& im : job.images) {
      std::vector<std::filesystem::path> files{im.file};
      if (geometry) {
        files.push_back(std::filesystem::path(im.file).replace_extension(".depth.npy"));
        files.push_back(std::filesystem::path(im.file).replace_extension(".xyz.npy"));
      }
      for (const std::filesystem::path& f : files) {
        std::filesystem::create_directories((final_dir / f).parent_path(), ec);
        std::filesystem::rename(out_dir / f, final_dir / f, ec);
        if (ec) {
          throw std::runtime_error("cannot move " + f.string() + " into " + final_dir.string() +
                                   " (" + ec.message() + ")");
        }
      }
    }
    std::filesystem::remove_all(out_dir, ec);
    cleanup.armed = false;

    nlohmann::json images = nlohmann::json::array();
    for (size_t k = 0; k < job.images.size(); ++k) {
      images.push_back({{"file", job.images[k].file},
                        {"render_s", seconds[k]},
                        {"covered_fraction", covered[k]}});
    }
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    nlohmann::json result = {{"schema", "mound.render_result"},
                             {"version", 1},
                             {"images", images},
                             {"threads", threads},
                             {"load_s", load_s},
                             {"elapsed_s", elapsed}};
    out << result.dump(2) << "\n";
    return static_cast<int>(kExitOk);
  });
}

}  // namespace mound::sim
