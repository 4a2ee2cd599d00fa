// Dense multi-view stereo on a calibrated, posed image set (the sparse model of
// `mound_recon reconstruct`): per-image depth maps by plane sweeping, then their fusion
// into one dense cloud. CPU only; OpenCV is private to this library (Eigen in and out).
//
// Depth maps (PlaneSweepDepthMap): for every reference image the source views are chosen
// from the sparse model (MVSNet's view score, Yao et al. 2018: the points both see,
// weighted by a piecewise Gaussian of their triangulation angle around 5 degrees). The
// scene is swept by planes normal to `up` (Collins 1996; Gallup et al. 2007 sweep along
// the ground's normal for aerial views), spaced so that no source pixel moves by more
// than `max_step_px` between two planes, between the heights the sparse points seen by
// the image span. For each plane every source image is warped into the reference by the
// plane's homography, and the zero-mean normalised cross-correlation (NCC) over a square
// window is computed with box filters; a pixel's score is the mean of its best
// `best_views` NCCs (occlusion-robust, Kang et al. 2001). The best plane is refined by a
// parabola through its neighbours' scores; pixels with too little texture or a low score
// are dropped.
//
// Fusion (FuseDepthMaps): a pixel's point survives when its depth is confirmed by at least
// `min_consistent` source depth maps (forward-backward projection within
// `max_reprojection_px` and a depth difference within `max_relative_depth`, as in
// COLMAP's and MVSNet's fusion); it becomes the mean of the agreeing points, its normal the
// cross product of its depth map's gradients (facing the camera), its colour the
// reference pixel's. Points are then merged on a voxel grid of `resolution_m`.
//
// Frames: cam_from_world (OpenCV camera axes); all lengths in the model's units (metres
// for a georeferenced model).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"

namespace mound::mvs {

// The defaults of max_image_size and resolution_m are the clouds the shipped verdict
// models were trained on (their cloud_settings): `mound_recon densify` with no option
// makes a cloud the dense model judges; the survey and the grids pass none either.
struct DenseOptions {
  int max_image_size = 320;  // longer side of the depth maps (pixels; images downscaled)
  int source_views = 4;      // source views per reference image
  int best_views = 2;        // a hypothesis's score: mean NCC of its best views
  int window = 7;            // NCC window side, pixels at the depth-map scale (odd)
  double max_step_px = 2.0;  // plane spacing: largest shift of a source pixel (the
                             // parabola through the scores refines between planes)
  int min_planes = 16, max_planes = 256;
  double min_ncc = 0.4;              // best score accepted
  double min_texture = 0.01;         // the reference window's intensity std (0..1 scale)
  int min_consistent = 2;            // source depth maps that must confirm a point
  double max_reprojection_px = 1.0;  // forward-backward, depth-map pixels
  double max_relative_depth = 0.01;
  double resolution_m = 0.25;                     // voxel of the fused cloud (>= 1 mm)
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // sweep-plane normal (the ground's)
  int threads = 1;
  int image_cache_mb = 1024;  // images kept decoded and scaled (ComputeDepthMaps)
  // InputError naming the option as a CLI user writes it ("--window: ...") when unusable.
  void Check() const;
};

struct DenseInput {
  geometry::CameraModel camera;                   // one camera for all images
  std::vector<std::string> image_paths;           // registered images only
  std::vector<geometry::Rigid3d> cam_from_world;  // one per image
  std::vector<Eigen::Vector3d> sparse_points;     // the sparse model (view choice, depth range)
};

// One image's depth map at the depth-map scale: depth along the optical axis (0: none).
struct DepthMap {
  int width = 0, height = 0;
  geometry::CameraModel camera;  // pinhole (distortion removed), at this scale
  geometry::Rigid3d cam_from_world, world_from_cam;
  std::vector<float> depth;  // row-major
  std::vector<std::array<uint8_t, 3>> rgb;
  std::vector<int> sources;               // indices of the source images
  double height_min = 0, height_max = 0;  // swept range along `up`
  int planes = 0;
  int valid = 0;  // pixels with a depth
  double seconds = 0;

  float At(int x, int y) const { return depth[static_cast<size_t>(y) * width + x]; }
  // The world point of pixel (x, y) at depth d.
  Eigen::Vector3d Unproject(double x, double y, double d) const;
};

struct DenseCloud {
  std::vector<Eigen::Vector3d> xyz, normal;
  std::vector<std::array<uint8_t, 3>> rgb;
  std::vector<int> support;            // fused pixels merged into the point
  std::vector<int> consistent_pixels;  // per image, pixels that passed the consistency check
};

// The heights an image's planes sweep, from the heights of the sparse points it sees
// (>= 1): their 1st to 99th percentile, widened through every point that continues the
// points beyond it without a gap wider than half that span (a mound's top, a pit's
// floor: a few points, but each near the next), not to a stray point beyond such a gap;
// then padded by a tenth of the span, or by 1 % of `camera_height` above the percentiles'
// middle when that is more. The percentiles alone cut a tumulus's top out of the sweep:
// its few points lie above the 99th.
std::pair<double, double> SweptHeightRange(std::vector<double> heights, double camera_height);

// The source views of every image (`count` per image, best first) by the view score.
std::vector<std::vector<int>> SelectSourceViews(const DenseInput& in, int count);

// The depth map of image `ref` (throws InputError when an image cannot be read).
DepthMap PlaneSweepDepthMap(const DenseInput& in, int ref, const std::vector<int>& sources,
                            const DenseOptions& o);

// The depth maps of all images on `o.threads` threads (one image per thread; OpenCV's own
// threads are held at one meanwhile). Each image is read, undistorted and scaled once and
// shared by every depth map it serves (as reference or source), up to `o.image_cache_mb`
// of them; beyond that an image is read again where it is needed. `images_read`, when
// given, counts the reads.
std::vector<DepthMap> ComputeDepthMaps(const DenseInput& in,
                                       const std::vector<std::vector<int>>& sources,
                                       const DenseOptions& o, int* images_read = nullptr);

// Consistency filter and fusion of all depth maps (DepthMap::sources names the views each
// is checked against).
DenseCloud FuseDepthMaps(const std::vector<DepthMap>& maps, const DenseOptions& o);

}  // namespace mound::mvs
