#pragma once
/// Depth of a separate depth camera registered into the colour camera, with its variance
/// (issue 23: the paper's rig, a wide-angle colour camera beside a narrower depth camera).
///
/// Each valid depth pixel (u, v) of the depth camera's raw, distorted image is a point
/// p_d = z_d (x, y, 1), (x, y) the pixel's undistorted ray; it is moved into the colour camera,
/// p_c = R_c_d p_d + t_c_d, and lands on the colour camera's undistorted pinhole grid (the grid
/// every later stage reads, as DepthRectifier's output). Where several points land on one
/// pixel the nearest surface wins (occlusion: the depth camera sees around a near object
/// parts of the background the colour camera does not). A depth pixel covers its footprint in
/// the colour image (its angular size |f_c / f_d| z_d / z_c colour pixels per axis, at least
/// its nearest pixel), so a lower-resolution depth camera leaves no sieve of holes; where a
/// denser one lands several points of a surface on a pixel, the pixel takes the one whose
/// footprint holds its centre (the nearest of several noisy samples would be biased towards
/// the camera); one-pixel cracks between two neighbours within 1 % of each other (a surface
/// stretched by the parallax) are closed, larger holes and depth steps stay open: no depth is
/// invented across a discontinuity. The same forward warp moves depth to the colour instant
/// (depth_time_alignment.h); both are one implementation.
///
/// Variance: z_c = (R_c_d p_d + t_c_d)_z = a z_d + t_z with a = r_3 . (x, y, 1) (r_3 the third
/// row of R_c_d), linear in z_d, so var_c = a^2 var_d with var_d the sensor model's variance of
/// the measured z_d (docs/depth_filter.md, "Unregistered depth"). With identity extrinsics
/// a = 1. The sub-pixel displacement of a point to the pixel centre it lands on is not added
/// (at most half a colour pixel, as for DepthRectifier's nearest-neighbour resampling).
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/depth_filter/sensor_model.h"

namespace pplvo::depth_filter {

struct DepthRegistrationStats {
  int64_t frames = 0;
  int64_t last_points = 0;      ///< valid depth pixels of the last input
  int64_t last_pixels_out = 0;  ///< colour pixels with depth in the last output
};

class DepthRegistration {
 public:
  /// `depth_m`: CV_32FC1 of `depth.camera`'s size, metres along the depth camera's optical
  /// axis at its raw pixels (0 = missing; NaN, negative ignored). Returns depth (z along the
  /// colour camera's axis) and variance (m^2) on `colour`'s undistorted pinhole grid, 0 where
  /// missing; window_length 1. `T_colour_extra` is applied after the rig's extrinsics (the
  /// time alignment's motion of the colour camera between the depth and the colour instant).
  /// The depth camera's rays are computed on its first frame and kept while it stays the
  /// same. Throws std::invalid_argument on a depth image that disagrees with depth.camera.
  DepthWithVariance apply(const PinholeCamera& colour, const DepthCamera& depth,
                          const cv::Mat& depth_m, const SensorModel& model,
                          const Pose3& T_colour_extra = Pose3::Identity());

  const DepthRegistrationStats& stats() const { return stats_; }

 private:
  void build(const PinholeCamera& depth_camera);

  PinholeCamera depth_camera_;
  bool built_ = false;
  std::vector<double> ray_x_, ray_y_;  ///< undistorted ray per raw depth pixel (NaN: none)
  cv::Mat var_d_;                      ///< sensor variance of the depth image (reused)
  DepthRegistrationStats stats_;
};

}  // namespace pplvo::depth_filter
