#include "pplvo/core/rgbd_frame.h"

#include <cmath>
#include <stdexcept>

namespace pplvo {

cv::Mat depthUnitsToMetres(const cv::Mat& depth_u16, double units_per_metre,
                           int max_valid_units) {
  if (depth_u16.type() != CV_16UC1) throw std::invalid_argument("depth must be CV_16UC1");
  if (!(units_per_metre > 0)) throw std::invalid_argument("depth scale must be positive");
  cv::Mat out(depth_u16.size(), CV_32FC1);
  const float inv = static_cast<float>(1.0 / units_per_metre);
  for (int r = 0; r < depth_u16.rows; ++r) {
    const uint16_t* in = depth_u16.ptr<uint16_t>(r);
    float* o = out.ptr<float>(r);
    for (int c = 0; c < depth_u16.cols; ++c) {
      const int d = in[c];
      o[c] = (d > 0 && d <= max_valid_units && d < 65535) ? d * inv : 0.0f;
    }
  }
  return out;
}

cv::Mat depthMetresToUnits(const cv::Mat& depth_m, double units_per_metre) {
  if (depth_m.type() != CV_32FC1) throw std::invalid_argument("depth must be CV_32FC1");
  cv::Mat out(depth_m.size(), CV_16UC1);
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* in = depth_m.ptr<float>(r);
    uint16_t* o = out.ptr<uint16_t>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      const double units = std::isfinite(in[c]) ? std::round(in[c] * units_per_metre) : 0.0;
      o[c] = (units > 0 && units < 65535) ? static_cast<uint16_t>(units) : 0;
    }
  }
  return out;
}

}  // namespace pplvo
