#pragma once
/// Features of one frame as the frontend produces them and the estimator consumes them.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/depth_time_alignment.h"
#include "pplvo/core/primitives.h"

namespace pplvo {

/// A keypoint at undistorted pixel `px`; `point` is valid when has_3d (camera frame).
struct PointFeature {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();
  float response = 0, size_px = 0, angle_deg = -1;
  int octave = 0;
  bool has_3d = false;
  Point3WithCov point;
};

/// A 2D line segment (undistorted endpoints) with its normalised equation
/// a u + b v + c = 0, a^2 + b^2 = 1; `line` is valid when has_3d (camera frame).
struct LineFeature {
  Eigen::Vector2d px1 = Eigen::Vector2d::Zero(), px2 = Eigen::Vector2d::Zero();
  Eigen::Vector3d eq = Eigen::Vector3d::Zero();
  bool has_3d = false;
  Line3WithCov line;
  int n_inliers = 0;
};

/// A plane segment fitted in the camera frame; `label` is its value in plane_labels.
struct PlaneFeature {
  PlaneWithCov plane;
  int n_points = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  int label = 0;
};

struct FrameFeatures {
  int64_t utime = 0;
  int64_t seq = -1;
  std::string stamp;
  PinholeCamera camera;
  std::vector<PointFeature> points;
  cv::Mat point_descriptors;  ///< one row per point (CV_8U for binary, CV_32F for float)
  std::vector<LineFeature> lines;
  cv::Mat line_descriptors;   ///< one row per line (CV_8U binary LBD)
  std::vector<PlaneFeature> planes;
  cv::Mat plane_labels;       ///< CV_8UC1 per pixel: 0 = none, else PlaneFeature::label
  /// How the depth the planes (and lifted points and lines) were measured on was moved.
  DepthTimeAlignment depth_time_alignment;
};

/// Correspondences between a previous (reference) frame and the current one:
/// each pair is (index in previous, index in current).
struct FeatureMatches {
  std::vector<std::pair<int, int>> points, lines, planes;
};

}  // namespace pplvo
