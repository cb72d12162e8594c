#pragma once
/// Pinhole camera with Brown-Conrady distortion (OpenCV convention).
#include <array>
#include <vector>

#include <Eigen/Core>

namespace pplvo {

/// Intrinsics of the colour camera; depth is assumed registered to it.
/// fy (or fx) may be negative for mirrored models such as ICL-NUIM: projection and
/// backprojection use the signed values, so geometry stays consistent with the ground truth.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;          // pixels
  std::array<double, 5> distortion{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3
  /// Rolling shutter: rows read top to bottom over this time (s), the middle row at the
  /// frame's stamp; 0 for a global shutter.
  double readout_s = 0;

  bool valid() const;
  bool hasDistortion() const;

  /// Pixel of a point in the camera frame (z > 0 expected). Ignores distortion: features are
  /// undistorted before geometry uses them.
  Eigen::Vector2d project(const Eigen::Vector3d& p_c) const {
    return {fx * p_c.x() / p_c.z() + cx, fy * p_c.y() / p_c.z() + cy};
  }
  /// Point at depth z (metres) seen at undistorted pixel (u, v).
  Eigen::Vector3d backproject(double u, double v, double z) const {
    return {(u - cx) / fx * z, (v - cy) / fy * z, z};
  }
  /// Unit-depth ray (x/z, y/z, 1) through an undistorted pixel.
  Eigen::Vector3d ray(double u, double v) const { return {(u - cx) / fx, (v - cy) / fy, 1.0}; }
  bool inImage(const Eigen::Vector2d& px, double margin = 0.0) const {
    return px.x() >= margin && px.y() >= margin && px.x() <= width - 1 - margin &&
           px.y() <= height - 1 - margin;
  }

  /// Undistorted pixel coordinates of distorted ones (identity when there is no distortion).
  std::vector<Eigen::Vector2d> undistortPixels(const std::vector<Eigen::Vector2d>& px) const;
  Eigen::Vector2d undistortPixel(const Eigen::Vector2d& px) const;
  /// Distorted pixel of an undistorted one (forward model).
  Eigen::Vector2d distortPixel(const Eigen::Vector2d& px) const;

  /// The same camera for an image scaled by `s` (e.g. 0.5 for half resolution).
  PinholeCamera scaled(double s) const;
};

bool operator==(const PinholeCamera& a, const PinholeCamera& b);
inline bool operator!=(const PinholeCamera& a, const PinholeCamera& b) { return !(a == b); }

}  // namespace pplvo
