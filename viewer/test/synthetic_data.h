#pragma once
// Small analytic test data for the viewer tests (no LCM): a textured image, a tilted-plane
// depth map, a few features with two plane segments, and a moving camera.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "pplvo/core/features.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo {
namespace viewer {
namespace testdata {

constexpr int kWidth = 320, kHeight = 240;

inline PinholeCamera camera() {
  PinholeCamera c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = 267.7;
  c.fy = 269.6;
  c.cx = 160.0;
  c.cy = 120.0;
  return c;
}

/// A smooth grey-brown image (little texture, so drawn features stand out) and depth
/// z = 1.5 + 0.004 u + 0.002 v metres with a missing band on the left.
inline RgbdFrame frame(int64_t seq) {
  RgbdFrame f;
  f.seq = seq;
  f.utime = 1000000 + seq * 33333;
  f.stamp = std::to_string(1341845688.0 + seq / 30.0);
  f.camera = camera();
  f.bgr = cv::Mat(kHeight, kWidth, CV_8UC3);
  f.depth_m = cv::Mat(kHeight, kWidth, CV_32FC1);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      f.bgr.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<uint8_t>(60 + u / 4), static_cast<uint8_t>(80 + v / 4),
                    static_cast<uint8_t>(100 + ((u + seq) % 40)));
      f.depth_m.at<float>(v, u) = u < 10 ? 0.f : static_cast<float>(1.5 + 0.004 * u + 0.002 * v);
    }
  }
  return f;
}

/// Three points (one with has_3d when lifted), two lines, two planes (labels 1 and 2 on the
/// left and right lower quarters).
inline FrameFeatures features(int64_t seq, bool lifted) {
  FrameFeatures ff;
  ff.seq = seq;
  ff.utime = 1000000 + seq * 33333;
  ff.stamp = std::to_string(1341845688.0 + seq / 30.0);
  ff.camera = camera();
  for (const auto& px :
       {Eigen::Vector2d(80, 60), Eigen::Vector2d(240, 60), Eigen::Vector2d(160, 100)}) {
    PointFeature p;
    p.px = px;
    p.response = 10;
    p.size_px = 7;
    ff.points.push_back(p);
  }
  if (lifted) {
    PointFeature& p = ff.points[0];
    p.has_3d = true;
    p.point.p = Eigen::Vector3d(-0.5, -0.4, 1.8);
    p.point.cov = Eigen::Matrix3d::Identity() * 1e-4;
  }
  LineFeature l;
  l.px1 = Eigen::Vector2d(20, 20);
  l.px2 = Eigen::Vector2d(300, 40);
  l.eq = Eigen::Vector3d(0, 1, -20);
  ff.lines.push_back(l);
  l.px1 = Eigen::Vector2d(40, 200);
  l.px2 = Eigen::Vector2d(120, 140);
  ff.lines.push_back(l);
  ff.plane_labels = cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  ff.plane_labels(cv::Rect(0, 160, 150, 80)).setTo(1);
  ff.plane_labels(cv::Rect(170, 160, 150, 80)).setTo(2);
  for (int label = 1; label <= 2; ++label) {
    PlaneFeature pl;
    pl.label = label;
    pl.n_points = 150 * 80;
    pl.plane.hessian = Eigen::Vector4d(0, -1, 0, 0.5);
    pl.plane.cov = Eigen::Matrix4d::Identity() * 1e-6;
    ff.planes.push_back(pl);
  }
  return ff;
}

inline FramePose pose(int64_t seq) {
  FramePose p;
  p.seq = seq;
  p.utime = 1000000 + seq * 33333;
  p.stamp = std::to_string(1341845688.0 + seq / 30.0);
  p.status = seq == 0 ? TrackingStatus::kFirstFrame : TrackingStatus::kTracking;
  const double a = 0.1 * static_cast<double>(seq);
  p.T_w_c =
      makePose(Eigen::Vector3d(0.3 * std::sin(a), -0.02 * a, 0.3 * (1 - std::cos(a)) + 0.05 * a),
               Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * a, Eigen::Vector3d::UnitY())));
  p.n_point_matches = 120 + static_cast<int>(seq);
  p.n_line_matches = 30;
  p.n_plane_matches = 2;
  p.iterations = 5;
  p.final_cost = 12.5;
  p.max_translation_variance_m2 = 1e-5;
  return p;
}

/// Fused depth = the frame's depth with variance (0.0012 + 0.0019 (z - 0.4)^2)^2 (paper's
/// sensor model, used here only to make a varying image).
inline DepthWithVariance fused(int64_t seq) {
  const RgbdFrame f = frame(seq);
  DepthWithVariance d;
  d.depth_m = f.depth_m.clone();
  d.var_m2 = cv::Mat(f.depth_m.size(), CV_32FC1, cv::Scalar(0));
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const float z = d.depth_m.at<float>(v, u);
      if (z > 0) {
        const double s = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        d.var_m2.at<float>(v, u) = static_cast<float>(s * s);
      }
    }
  }
  d.window_length = static_cast<int>(std::min<int64_t>(seq + 1, 5));
  return d;
}

/// Mean per-channel variance of an image region (grey level variance summed over channels).
inline double regionVariance(const cv::Mat& img) {
  cv::Scalar mean, stddev;
  cv::meanStdDev(img, mean, stddev);
  return stddev[0] * stddev[0] + stddev[1] * stddev[1] + stddev[2] * stddev[2];
}

}  // namespace testdata
}  // namespace viewer
}  // namespace pplvo
