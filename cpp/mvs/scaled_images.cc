#include "mvs/scaled_images.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace mound::mvs {

ScaledImage LoadScaled(const std::string& path, const geometry::CameraModel& cam, int max_size) {
  cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
  if (img.empty()) throw InputError(path + ": cannot read the image");
  if (img.cols != cam.width || img.rows != cam.height) {
    throw InputError(path + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                     " pixels, but the model's camera is " + std::to_string(cam.width) + "x" +
                     std::to_string(cam.height));
  }
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  if (cam.HasDistortion()) {
    cv::Mat dist =
        (cv::Mat_<double>(1, 5) << cam.dist[0], cam.dist[1], cam.dist[2], cam.dist[3], cam.dist[4]);
    cv::Mat u;
    cv::undistort(img, u, K, dist, K);
    img = u;
  }
  ScaledImage s;
  const double scale = std::min(1.0, static_cast<double>(max_size) / std::max(img.cols, img.rows));
  const int w = std::max(1, static_cast<int>(std::lround(img.cols * scale)));
  const int h = std::max(1, static_cast<int>(std::lround(img.rows * scale)));
  if (w != img.cols || h != img.rows) {
    cv::resize(img, s.colour, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  } else {
    s.colour = img;
  }
  cv::Mat grey8;
  cv::cvtColor(s.colour, grey8, cv::COLOR_BGR2GRAY);
  grey8.convertTo(s.grey, CV_32F, 1.0 / 255.0);
  const double sx = static_cast<double>(w) / cam.width, sy = static_cast<double>(h) / cam.height;
  s.camera.width = w;
  s.camera.height = h;
  s.camera.fx = cam.fx * sx;
  s.camera.fy = cam.fy * sy;
  // Pixel centres: (0, 0) is the centre of the top-left pixel at both scales.
  s.camera.cx = (cam.cx + 0.5) * sx - 0.5;
  s.camera.cy = (cam.cy + 0.5) * sy - 0.5;
  return s;
}

std::shared_ptr<const ScaledImage> ScaledImages::Get(int i) const {
  std::shared_ptr<const ScaledImage> fresh;
  std::call_once(once_[i], [&] {
    fresh = Load(i);
    const size_t bytes = fresh->grey.total() * fresh->grey.elemSize() +
                         fresh->colour.total() * fresh->colour.elemSize();
    if (bytes_.fetch_add(bytes) + bytes <= max_bytes_) kept_[i] = fresh;
  });
  if (fresh) return fresh;
  if (kept_[i]) return kept_[i];  // set inside call_once, which orders it before this
  return Load(i);                 // over the bound: read again
}

std::shared_ptr<const ScaledImage> ScaledImages::Load(int i) const {
  ++reads_;
  return std::make_shared<const ScaledImage>(LoadScaled(in_.image_paths[i], in_.camera, max_size_));
}

}  // namespace mound::mvs
