#pragma once
/// Small analytic test scene (used until the shared synthetic generator is available): a wall
/// (plane z_w = 3 m), a static box in front of it, optionally a box moving towards the camera,
/// seen by a camera moving a few cm and degrees. Noise: Kinect model of paper eq. (1) plus
/// disparity quantisation (1/8 px, f*b = fx * 0.075 m), and edge dropout. Deterministic for a given
/// seed.
#include <cstdint>
#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::depth_filter::test {

enum Label : uint8_t { kNone = 0, kWall = 1, kBox = 2, kMoving = 3 };

struct SceneOptions {
  int width = 640, height = 480;
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  uint64_t seed = 7;
  double sigma_z_coeff_per_m = 1.425e-3;  ///< paper eq. (1)
  bool noise = true;
  bool quantise_disparity = true;
  bool moving_object = false;
  /// Drop pixels next to a depth jump > 0.1 m (3x3), as structured-light sensors (and the
  /// shared synthetic generator's edge_dropout) do.
  bool edge_dropout = true;
  double moving_speed_m_per_frame = 0.02;  ///< towards the camera
};

struct SceneFrame {
  cv::Mat depth_m;       ///< noisy, CV_32FC1
  cv::Mat depth_true_m;  ///< noiseless
  cv::Mat label;         ///< CV_8UC1 Label of the surface hit
  Pose3 T_w_c = Pose3::Identity();
};

class AnalyticScene {
 public:
  explicit AnalyticScene(const SceneOptions& options = SceneOptions());
  PinholeCamera camera() const;
  Pose3 pose(int i) const;
  SceneFrame render(int i) const;
  /// Wall plane in the world frame, [n; d] with n.p + d = 0.
  Eigen::Vector4d wallPlaneW() const { return {0, 0, -1, 3.0}; }

 private:
  SceneOptions options_;
};

}  // namespace pplvo::depth_filter::test
