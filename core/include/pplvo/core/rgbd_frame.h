#pragma once
/// In-memory RGB-D frame and depth maps as the libraries see them (no LCM here).
#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/depth_time_alignment.h"
#include "pplvo/core/geometry.h"

namespace pplvo {

/// A depth camera of its own beside the colour camera, whose depth is not registered to the
/// colour image (docs/cameras.md, "Unregistered depth"): the depth filter registers it
/// (depth_filter::DepthRegistration).
struct DepthCamera {
  PinholeCamera camera;             ///< intrinsics, distortion and image size of the depth images
  Pose3 T_c_d = Pose3::Identity();  ///< maps depth-camera points into the colour camera (m)
};

/// One RGB-D frame: depth registered to the colour camera, or in a depth camera of its own.
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
  /// Unset (the default): depth_m is registered to `camera` (same size and pixels). Set:
  /// depth_m holds this depth camera's image (its size, its raw pixels, z along its axis).
  std::optional<DepthCamera> depth_camera;
};

/// Depth with per-pixel variance (depth filter output).
struct DepthWithVariance {
  cv::Mat depth_m;      ///< CV_32FC1, metres; 0 = missing
  cv::Mat var_m2;       ///< CV_32FC1, m^2; 0 where depth is missing
  int window_length = 1;
  /// The current frame's depth moved to its colour instant (a fused map carries the current
  /// frame's: its own depth comes first in the fusion).
  DepthTimeAlignment time_alignment;
};

/// Converts integer depth units (e.g. TUM's 1/5000 m) to metres. Values of 0, or above
/// max_valid_units (e.g. 65535 used as an invalid marker), become 0 (missing).
cv::Mat depthUnitsToMetres(const cv::Mat& depth_u16, double units_per_metre,
                           int max_valid_units = 65535);
/// Metres to integer units, rounding to nearest; NaN, <= 0 and out-of-range become 0.
cv::Mat depthMetresToUnits(const cv::Mat& depth_m, double units_per_metre);

}  // namespace pplvo
