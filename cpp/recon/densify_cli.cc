#include "recon/densify_cli.h"

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/timing.h"
#include "recon/densify.h"

namespace mound::recon {

int RunDensify(const std::vector<std::string>& args) {
  const Args a =
      ParseArgs(args, 1,
                {"--out", "--resolution-m", "--threads", "--max-image-size", "--images",
                 "--source-views", "--window", "--min-ncc", "--min-consistent", "--max-step-px"});
  if (a.positional.size() != 1)
    throw InputError("densify: expected exactly one RECON_DIR (see --help)");
  if (!a.Has("--out")) throw InputError("--out: the output directory is required");
  const std::string dir = a.positional[0], out = a.options.at("--out");
  mvs::DenseOptions o;
  o.threads = a.Has("--threads")
                  ? static_cast<int>(ParseInt(a.options.at("--threads"), "--threads", 1, 256))
                  : DefaultThreads();
  if (a.Has("--resolution-m"))
    o.resolution_m = ParseNumber(a.options.at("--resolution-m"), "--resolution-m");
  if (a.Has("--max-image-size"))
    o.max_image_size = static_cast<int>(
        ParseInt(a.options.at("--max-image-size"), "--max-image-size", 32, 100000));
  if (a.Has("--source-views"))
    o.source_views =
        static_cast<int>(ParseInt(a.options.at("--source-views"), "--source-views", 1, 64));
  o.best_views = std::min(o.best_views, o.source_views);
  if (a.Has("--window"))
    o.window = static_cast<int>(ParseInt(a.options.at("--window"), "--window", 3, 99));
  if (a.Has("--max-step-px"))
    o.max_step_px = ParseNumber(a.options.at("--max-step-px"), "--max-step-px");
  if (a.Has("--min-ncc")) o.min_ncc = ParseNumber(a.options.at("--min-ncc"), "--min-ncc");
  if (a.Has("--min-consistent"))
    o.min_consistent =
        static_cast<int>(ParseInt(a.options.at("--min-consistent"), "--min-consistent", 1, 64));
  o.Check();

  DensifyOptions d;
  d.recon_dir = dir;
  if (a.Has("--images")) d.images_dir = a.options.at("--images");
  d.dense = o;
  DensifyResult res = Densify(d);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError("--out: cannot create " + out + ": " + ec.message());
  nlohmann::json& doc = res.doc;
  if (doc["status"] != "ok") {
    WriteFileAtomic(out + "/dense.json", doc.dump(1) + "\n");
    throw NoResultError(doc["reason"].get<std::string>());
  }
  const auto t0 = Clock::now();
  geometry::WritePly(out + "/dense.ply", res.cloud);
  doc["timings_s"]["write"] = Since(t0);
  WriteFileAtomic(out + "/dense.json", doc.dump(1) + "\n");
  std::cerr << "mound_recon densify: " << doc["images"].size() << " depth maps, "
            << res.cloud.xyz.size() << " points at " << o.resolution_m << " m, "
            << doc["timings_s"]["depth_maps"].get<double>() +
                   doc["timings_s"]["fusion"].get<double>()
            << " s\n";
  return kExitOk;
}

}  // namespace mound::recon
