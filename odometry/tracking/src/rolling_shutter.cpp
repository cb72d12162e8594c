#include "pplvo/tracking/rolling_shutter.h"

#include <Eigen/Geometry>
#include <cmath>

#include "pplvo/features/line_extractor.h"

namespace pplvo::tracking {

namespace {

Eigen::Matrix3d rotationAt(const Eigen::Vector3d& w, double tau) {
  const double angle = w.norm() * tau;
  if (!(std::abs(angle) > 0)) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w.normalized()).toRotationMatrix();
}

/// The pixel `px` turned by R about the camera centre; `px` itself when it leaves the front.
Eigen::Vector2d turnedPixel(const PinholeCamera& camera, const Eigen::Matrix3d& R,
                            const Eigen::Vector2d& px) {
  const Eigen::Vector3d ray = R * camera.ray(px.x(), px.y());
  return ray.z() > 1e-9 ? camera.project(ray) : px;
}

}  // namespace

Eigen::Vector3d angularVelocity(const Pose3& T_curr_prev, double interval_s) {
  if (!(interval_s > 0) || !std::isfinite(interval_s)) return Eigen::Vector3d::Zero();
  // The camera turned by R_prev_curr = R_curr_prev^T in its own frame.
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(T_curr_prev.linear().transpose()));
  const Eigen::Vector3d w = aa.angle() * aa.axis() / interval_s;
  return w.allFinite() ? w : Eigen::Vector3d::Zero();
}

double rowTime(const PinholeCamera& camera, double v) {
  if (!(camera.readout_s > 0) || camera.height < 2) return 0.0;
  return (v - 0.5 * (camera.height - 1)) * camera.readout_s / (camera.height - 1);
}

void compensateRollingShutter(FrameFeatures& frame, const Eigen::Vector3d& angular_velocity) {
  const PinholeCamera& camera = frame.camera;
  if (!(camera.readout_s > 0) || !(angular_velocity.norm() > 0)) return;
  for (PointFeature& p : frame.points) {
    if (!p.px.allFinite()) continue;
    const Eigen::Matrix3d R = rotationAt(angular_velocity, rowTime(camera, p.px.y()));
    p.px = turnedPixel(camera, R, p.px);
    if (p.has_3d) {
      p.point.p = R * p.point.p;
      p.point.cov = R * p.point.cov * R.transpose();
    }
  }
  for (LineFeature& l : frame.lines) {
    if (!l.px1.allFinite() || !l.px2.allFinite()) continue;
    const Eigen::Matrix3d R1 = rotationAt(angular_velocity, rowTime(camera, l.px1.y()));
    const Eigen::Matrix3d R2 = rotationAt(angular_velocity, rowTime(camera, l.px2.y()));
    l.px1 = turnedPixel(camera, R1, l.px1);
    l.px2 = turnedPixel(camera, R2, l.px2);
    const Eigen::Vector3d eq = features::lineEquation(l.px1, l.px2);
    if (eq.allFinite()) l.eq = eq;
    if (l.has_3d) {
      l.line.p1 = R1 * l.line.p1;
      l.line.p2 = R2 * l.line.p2;
      l.line.cov1 = R1 * l.line.cov1 * R1.transpose();
      l.line.cov2 = R2 * l.line.cov2 * R2.transpose();
    }
  }
}

}  // namespace pplvo::tracking
