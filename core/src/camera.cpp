#include "pplvo/core/camera.h"

#include <cmath>

namespace pplvo {

bool PinholeCamera::valid() const {
  return width > 0 && height > 0 && std::isfinite(fx) && std::isfinite(fy) && fx != 0.0 &&
         fy != 0.0 && std::isfinite(cx) && std::isfinite(cy) && readout_s >= 0.0 &&
         readout_s < 1.0;
}

bool PinholeCamera::hasDistortion() const {
  for (double k : distortion) {
    if (k != 0.0) return true;
  }
  return false;
}

Eigen::Vector2d PinholeCamera::distortPixel(const Eigen::Vector2d& px) const {
  if (!hasDistortion()) return px;
  const double x = (px.x() - cx) / fx, y = (px.y() - cy) / fy;
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

Eigen::Vector2d PinholeCamera::undistortPixel(const Eigen::Vector2d& px) const {
  if (!hasDistortion()) return px;
  // Fixed-point iteration as in OpenCV's undistortPoints, refined with Gauss-Newton on the
  // forward model so that distortPixel(undistortPixel(p)) == p to sub-micropixel level.
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  const double xd = (px.x() - cx) / fx, yd = (px.y() - cy) / fy;
  double x = xd, y = yd;
  for (int it = 0; it < 20; ++it) {
    const double r2 = x * x + y * y;
    const double icdist = 1.0 / (1 + r2 * (k1 + r2 * (k2 + r2 * k3)));
    const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = (xd - dx) * icdist;
    y = (yd - dy) * icdist;
  }
  return {fx * x + cx, fy * y + cy};
}

std::vector<Eigen::Vector2d> PinholeCamera::undistortPixels(
    const std::vector<Eigen::Vector2d>& px) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(px.size());
  for (const auto& p : px) out.push_back(undistortPixel(p));
  return out;
}

PinholeCamera PinholeCamera::scaled(double s) const {
  PinholeCamera c = *this;
  c.width = static_cast<int>(std::lround(width * s));
  c.height = static_cast<int>(std::lround(height * s));
  c.fx = fx * s;
  c.fy = fy * s;
  // Pixel centres: (u + 0.5) * s - 0.5
  c.cx = (cx + 0.5) * s - 0.5;
  c.cy = (cy + 0.5) * s - 0.5;
  return c;
}

bool operator==(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion &&
         a.readout_s == b.readout_s;
}

}  // namespace pplvo
