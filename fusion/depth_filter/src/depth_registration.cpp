#include "pplvo/depth_filter/depth_registration.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "forward_warp.h"

namespace pplvo::depth_filter {

void DepthRegistration::build(const PinholeCamera& depth_camera) {
  depth_camera_ = depth_camera;
  built_ = true;
  const int w = depth_camera.width, h = depth_camera.height;
  const size_t n = static_cast<size_t>(w) * h;
  ray_x_.assign(n, std::numeric_limits<double>::quiet_NaN());
  ray_y_.assign(n, std::numeric_limits<double>::quiet_NaN());
  const bool distorted = depth_camera.hasDistortion();
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * w + u;
      if (!distorted) {
        ray_x_[i] = (u - depth_camera.cx) / depth_camera.fx;
        ray_y_[i] = (v - depth_camera.cy) / depth_camera.fy;
        continue;
      }
      const Eigen::Vector2d p = depth_camera.undistortPixel(Eigen::Vector2d(u, v));
      if (!p.allFinite()) continue;
      ray_x_[i] = (p.x() - depth_camera.cx) / depth_camera.fx;
      ray_y_[i] = (p.y() - depth_camera.cy) / depth_camera.fy;
    }
  }
}

DepthWithVariance DepthRegistration::apply(const PinholeCamera& colour, const DepthCamera& depth,
                                           const cv::Mat& depth_m, const SensorModel& model,
                                           const Pose3& T_colour_extra) {
  const PinholeCamera& dc = depth.camera;
  if (depth_m.type() != CV_32FC1 || depth_m.rows != dc.height || depth_m.cols != dc.width) {
    throw std::invalid_argument(
        "DepthRegistration: depth must be CV_32FC1 of the depth camera's size");
  }
  if (!built_ || dc != depth_camera_) build(dc);
  var_d_.create(depth_m.rows, depth_m.cols, CV_32FC1);
  int64_t points = 0;
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* z = depth_m.ptr<float>(v);
    model.varianceRow(z, var_d_.ptr<float>(v), depth_m.cols);
    for (int u = 0; u < depth_m.cols; ++u) points += (z[u] > 0.f && std::isfinite(z[u])) ? 1 : 0;
  }
  const int w = dc.width;
  const auto ray = [&](int u, int v, double* x, double* y) {
    const size_t i = static_cast<size_t>(v) * w + u;
    *x = ray_x_[i];
    *y = ray_y_[i];
    return std::isfinite(*x);
  };
  detail::ForwardWarpOptions options;
  options.source_fx = std::abs(dc.fx);
  options.source_fy = std::abs(dc.fy);
  DepthWithVariance out;
  detail::forwardWarp(depth_m, &var_d_, ray, colour, T_colour_extra * depth.T_c_d, options,
                      &out.depth_m, &out.var_m2);
  out.window_length = 1;
  ++stats_.frames;
  stats_.last_points = points;
  stats_.last_pixels_out = cv::countNonZero(out.depth_m);
  return out;
}

}  // namespace pplvo::depth_filter
