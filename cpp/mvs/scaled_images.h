// The images of a dense run at the depth-map scale (mvs-private: OpenCV types): read,
// undistorted and scaled once each, and shared by every depth map they serve while they
// fit in a memory bound. The sweep works on these; it does no image I/O of its own.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "mvs/dense.h"

namespace mound::mvs {

// An image at the depth-map scale: distortion removed, downscaled, grey 0..1 and colour.
struct ScaledImage {
  cv::Mat grey;    // CV_32F
  cv::Mat colour;  // CV_8UC3, BGR
  geometry::CameraModel camera;
};

// Reads the image at `path` (InputError when unreadable or not the camera's size),
// removes the camera's distortion and scales it to at most `max_size` pixels a side.
ScaledImage LoadScaled(const std::string& path, const geometry::CameraModel& cam, int max_size);

// The scaled images of a run, each read once and shared while they fit in `max_bytes`;
// thread-safe.
class ScaledImages {
 public:
  ScaledImages(const DenseInput& in, int max_size, size_t max_bytes)
      : in_(in),
        max_size_(max_size),
        max_bytes_(max_bytes),
        once_(in.image_paths.size()),
        kept_(in.image_paths.size()) {}
  std::shared_ptr<const ScaledImage> Get(int i) const;
  int reads() const { return reads_.load(); }

 private:
  std::shared_ptr<const ScaledImage> Load(int i) const;
  const DenseInput& in_;
  const int max_size_;
  const size_t max_bytes_;
  mutable std::vector<std::once_flag> once_;
  mutable std::vector<std::shared_ptr<const ScaledImage>> kept_;
  mutable std::atomic<size_t> bytes_{0};
  mutable std::atomic<int> reads_{0};
};

}  // namespace mound::mvs
