#include "pplvo/depth_filter/depth_rectification.h"

#include <cmath>
#include <stdexcept>

namespace pplvo::depth_filter {

void DepthRectifier::build(const PinholeCamera& camera) {
  camera_ = camera;
  built_ = true;
  source_.clear();
  if (!camera.hasDistortion()) return;
  const int w = camera.width, h = camera.height;
  source_.assign(static_cast<size_t>(w) * h, -1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d raw = camera.distortPixel(Eigen::Vector2d(u, v));
      if (!raw.allFinite()) continue;
      const long ur = std::lround(raw.x()), vr = std::lround(raw.y());
      if (ur < 0 || vr < 0 || ur >= w || vr >= h) continue;
      source_[static_cast<size_t>(v) * w + u] = static_cast<int32_t>(vr * w + ur);
    }
  }
}

cv::Mat DepthRectifier::apply(const PinholeCamera& camera, const cv::Mat& depth_m) {
  if (!built_ || camera != camera_) build(camera);
  if (source_.empty()) return depth_m;
  if (depth_m.type() != CV_32FC1 || depth_m.rows != camera.height ||
      depth_m.cols != camera.width) {
    throw std::invalid_argument("DepthRectifier: depth must be CV_32FC1 of the camera's size");
  }
  cv::Mat out(depth_m.rows, depth_m.cols, CV_32FC1);
  const cv::Mat in = depth_m.isContinuous() ? depth_m : depth_m.clone();
  const float* src = in.ptr<float>();
  float* dst = out.ptr<float>();
  const size_t n = source_.size();
  for (size_t i = 0; i < n; ++i) dst[i] = source_[i] >= 0 ? src[source_[i]] : 0.0f;
  return out;
}

}  // namespace pplvo::depth_filter
