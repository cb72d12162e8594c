#pragma once
/// In-memory RGB-D frame and depth maps as the libraries see them (no LCM here).
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"

namespace pplvo {

/// One registered RGB-D frame.
struct RgbdFrame {
  int64_t utime = 0;    ///< capture time of the colour image, microseconds
  /// Capture time of the depth image, same clock; 0 = the same instant as `utime`. Free-running
  /// sensors (Kinect v1, TUM fr1/fr2) deliver depth up to half a frame apart from colour.
  int64_t depth_utime = 0;
  int64_t seq = 0;      ///< frame number from the source
  std::string stamp;    ///< source timestamp text, verbatim
  PinholeCamera camera;
  cv::Mat bgr;          ///< CV_8UC3 colour (or CV_8UC1 grey)
  cv::Mat depth_m;      ///< CV_32FC1 depth in metres; 0 = no measurement
};

/// Depth with per-pixel variance (depth filter output).
struct DepthWithVariance {
  cv::Mat depth_m;      ///< CV_32FC1, metres; 0 = missing
  cv::Mat var_m2;       ///< CV_32FC1, m^2; 0 where depth is missing
  int window_length = 1;
};

/// Converts integer depth units (e.g. TUM's 1/5000 m) to metres. Values of 0, or above
/// max_valid_units (e.g. 65535 used as an invalid marker), become 0 (missing).
cv::Mat depthUnitsToMetres(const cv::Mat& depth_u16, double units_per_metre,
                           int max_valid_units = 65535);
/// Metres to integer units, rounding to nearest; NaN, <= 0 and out-of-range become 0.
cv::Mat depthMetresToUnits(const cv::Mat& depth_m, double units_per_metre);

}  // namespace pplvo
