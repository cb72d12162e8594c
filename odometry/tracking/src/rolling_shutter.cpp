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

/// The point read at pixel `px` by the camera at [R, t] from the stamp's, whose depth at the
/// stamp is `z`: on that camera's ray, X = t + s R d(px) with X_z = z.
Eigen::Vector3d pointAtStampDepth(const PinholeCamera& camera, const Eigen::Matrix3d& R,
                                  const Eigen::Vector3d& t, const Eigen::Vector2d& px, double z) {
  const Eigen::Vector3d ray = R * camera.ray(px.x(), px.y());
  return t + (z - t.z()) / ray.z() * ray;
}

/// Its projection; `px` itself when the point is not in front of the camera.
Eigen::Vector2d stampPixel(const PinholeCamera& camera, const Eigen::Vector3d& X,
                           const Eigen::Vector2d& px) {
  return X.z() > 1e-9 && X.allFinite() ? camera.project(X) : px;
}

}  // namespace

Eigen::Vector3d angularVelocity(const Pose3& T_curr_prev, double interval_s) {
  if (!(interval_s > 0) || !std::isfinite(interval_s)) return Eigen::Vector3d::Zero();
  // The camera turned by R_prev_curr = R_curr_prev^T in its own frame.
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(T_curr_prev.linear().transpose()));
  const Eigen::Vector3d w = aa.angle() * aa.axis() / interval_s;
  return w.allFinite() ? w : Eigen::Vector3d::Zero();
}

Eigen::Vector3d linearVelocity(const Pose3& T_curr_prev, double interval_s) {
  if (!(interval_s > 0) || !std::isfinite(interval_s)) return Eigen::Vector3d::Zero();
  // The camera moved by t_prev_curr (its new centre in its old frame).
  const Eigen::Vector3d v =
      -(T_curr_prev.linear().transpose() * T_curr_prev.translation()) / interval_s;
  return v.allFinite() ? v : Eigen::Vector3d::Zero();
}

CameraVelocity cameraVelocity(const Pose3& T_curr_prev, double interval_s) {
  return {angularVelocity(T_curr_prev, interval_s), linearVelocity(T_curr_prev, interval_s)};
}

double rowTime(const PinholeCamera& camera, double v) {
  if (!(camera.readout_s > 0) || camera.height < 2) return 0.0;
  return (v - 0.5 * (camera.height - 1)) * camera.readout_s / (camera.height - 1);
}

void compensateRollingShutter(FrameFeatures& frame, const CameraVelocity& velocity) {
  compensateRollingShutter(frame, velocity, frame.camera.readout_s);
}

void compensateRollingShutter(FrameFeatures& frame, const CameraVelocity& velocity,
                              double readout_s) {
  PinholeCamera camera = frame.camera;
  camera.readout_s = readout_s;
  if (!(camera.readout_s > 0) || !(velocity.angular.norm() > 0 || velocity.linear.norm() > 0)) {
    return;
  }
  for (PointFeature& p : frame.points) {
    if (!p.px.allFinite()) continue;
    const double tau = rowTime(camera, p.px.y());
    const Eigen::Matrix3d R = rotationAt(velocity.angular, tau);
    if (!p.has_3d) {
      p.px = turnedPixel(camera, R, p.px);
      continue;
    }
    const double z = p.point.p.z();
    const Eigen::Vector3d X = pointAtStampDepth(camera, R, tau * velocity.linear, p.px, z);
    if (!(X.z() > 1e-9) || !X.allFinite()) continue;
    // Moved as the point read on the pixel's ray at its depth is (the same point when the
    // lifting put it on that ray).
    p.point.p += X - z * camera.ray(p.px.x(), p.px.y());
    p.point.cov = R * p.point.cov * R.transpose();
    p.px = camera.project(X);
  }
  for (LineFeature& l : frame.lines) {
    if (!l.px1.allFinite() || !l.px2.allFinite()) continue;
    const double tau1 = rowTime(camera, l.px1.y()), tau2 = rowTime(camera, l.px2.y());
    const Eigen::Matrix3d R1 = rotationAt(velocity.angular, tau1);
    const Eigen::Matrix3d R2 = rotationAt(velocity.angular, tau2);
    if (l.has_3d) {
      // Each image end at the depth of the fitted segment's end on its side; the segment's
      // ends move as the points read at the image ends do.
      const double z1 = l.line.p1.z(), z2 = l.line.p2.z();
      const Eigen::Vector3d X1 = pointAtStampDepth(camera, R1, tau1 * velocity.linear, l.px1, z1);
      const Eigen::Vector3d X2 = pointAtStampDepth(camera, R2, tau2 * velocity.linear, l.px2, z2);
      if (X1.z() > 1e-9 && X2.z() > 1e-9 && X1.allFinite() && X2.allFinite()) {
        l.line.p1 += X1 - z1 * camera.ray(l.px1.x(), l.px1.y());
        l.line.p2 += X2 - z2 * camera.ray(l.px2.x(), l.px2.y());
        l.line.cov1 = R1 * l.line.cov1 * R1.transpose();
        l.line.cov2 = R2 * l.line.cov2 * R2.transpose();
        l.px1 = camera.project(X1);
        l.px2 = camera.project(X2);
      }
    } else {
      l.px1 = turnedPixel(camera, R1, l.px1);
      l.px2 = turnedPixel(camera, R2, l.px2);
    }
    const Eigen::Vector3d eq = features::lineEquation(l.px1, l.px2);
    if (eq.allFinite()) l.eq = eq;
  }
}

void compensateReadoutTranslation(estimator::Correspondences& correspondences,
                                  const PinholeCamera& camera, const Pose3& T_curr_ref,
                                  const Eigen::Vector3d& linear_velocity) {
  if (!(camera.readout_s > 0) || !(linear_velocity.norm() > 0)) return;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (estimator::PointMatch3D2D& m : correspondences.points) {
    const double z = (T_curr_ref * m.P_prev.p).z();
    if (!(z > 1e-9)) continue;
    const Eigen::Vector3d t = rowTime(camera, m.px_curr.y()) * linear_velocity;
    m.px_curr = stampPixel(camera, pointAtStampDepth(camera, I, t, m.px_curr, z), m.px_curr);
  }
  for (estimator::LineMatch3D2D& m : correspondences.lines) {
    const Eigen::Vector3d& l = m.l_curr;
    const double norm = l.head<2>().norm();
    if (!(norm > 0)) continue;
    // The observed line's points nearest to the matched segment's predicted ends.
    Eigen::Vector2d ends[2];
    bool in_front = true;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d X = T_curr_ref * (k == 0 ? m.L_prev.p1 : m.L_prev.p2);
      in_front = X.z() > 1e-9;
      if (!in_front) break;
      const Eigen::Vector2d q = camera.project(X);
      const Eigen::Vector2d foot = q - (l.head<2>().dot(q) + l.z()) / (norm * norm) * l.head<2>();
      const Eigen::Vector3d t = rowTime(camera, foot.y()) * linear_velocity;
      ends[k] = stampPixel(camera, pointAtStampDepth(camera, I, t, foot, X.z()), foot);
    }
    if (!in_front) continue;
    const Eigen::Vector3d eq = features::lineEquation(ends[0], ends[1]);
    if (eq.allFinite() && eq.head<2>().norm() > 0) m.l_curr = eq;
  }
}

}  // namespace pplvo::tracking
