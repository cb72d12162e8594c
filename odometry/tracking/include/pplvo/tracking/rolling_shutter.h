#pragma once
/// Rolling-shutter compensation of a frame's point and line features (docs/estimator.md,
/// "Rolling shutter"). A rolling-shutter colour camera reads its rows top to bottom over the
/// readout time r (PinholeCamera::readout_s), the middle row at the frame's stamp: row v is
/// read at tau(v) = (v - (H - 1) / 2) r / (H - 1). Under a constant velocity (the motion
/// model's, camera frame: w rad/s, v m/s) the camera at tau is at [R, t] = [exp(tau w), tau v]
/// from its pose at the stamp, so the point X (stamp frame) a feature was read on at pixel p
/// lies on that camera's ray, X = t + s R d(p). The depth image is read at once (the depth
/// filter moves it to the stamp), so the depth looked up at p is X's depth at the stamp, z;
/// then s = (z - t_z) / (R d(p))_z, and the feature moves to the stamp as X and its projection.
/// The rotation alone needs no depth; the translation does (a point moves by f |v| tau / z
/// pixels: 0.5 m/s, 12 ms, 1.2 m: 2.6 px, a shear that grows with the speed and changes sign
/// with its direction). A frame's 2D stage, tracked before its depth arrives, is turned at
/// once and moved by the translation per correspondence, at the depth of the 3D feature it
/// matched seen from the predicted pose. Planes (from the depth image) are left as they are.
#include <Eigen/Core>

#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"
#include "pplvo/estimator/pose_estimator.h"

namespace pplvo::tracking {

/// A camera's velocity in its own frame.
struct CameraVelocity {
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();  ///< rad/s
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();   ///< m/s
};

/// The camera's angular velocity (rad/s, in its own frame) of a motion T_curr_prev that took
/// `interval_s` seconds; zero for a non-positive or non-finite interval.
Eigen::Vector3d angularVelocity(const Pose3& T_curr_prev, double interval_s);

/// Both velocities of a motion T_curr_prev that took `interval_s` seconds.
CameraVelocity cameraVelocity(const Pose3& T_curr_prev, double interval_s);

/// The instant (s, relative to the stamp) at which row `v` of `camera` was read.
double rowTime(const PinholeCamera& camera, double v);

/// The camera's linear velocity (m/s, in its own frame at the start of the motion) of a
/// motion T_curr_prev that took `interval_s` seconds; zero for a non-positive or non-finite
/// interval.
Eigen::Vector3d linearVelocity(const Pose3& T_curr_prev, double interval_s);

/// Moves the points and lines of `frame` to the instant of its stamp, given the camera's
/// velocity: lifted ones (2D and 3D) by the rotation and the translation, the others (no depth)
/// by the rotation only. No-op for a global shutter (readout_s == 0) or a camera at rest.
void compensateRollingShutter(FrameFeatures& frame, const CameraVelocity& velocity);
/// The same with the readout `readout_s` instead of the calibration's (one read from the
/// frames, readout_estimator.h); frame.camera is left as it is.
void compensateRollingShutter(FrameFeatures& frame, const CameraVelocity& velocity,
                              double readout_s);

/// Moves the current frame's 2D observations in `correspondences` by the camera's translation
/// during the readout (`linear_velocity`, m/s), each at the depth of the 3D feature it matched
/// as the predicted pose T_curr_ref sees it (a line's two ends on the observed line, each at the
/// depth of the matched segment's end). For observations without depth of their own that were
/// turned by compensateRollingShutter already. No-op for a global shutter.
void compensateReadoutTranslation(estimator::Correspondences& correspondences,
                                  const PinholeCamera& camera, const Pose3& T_curr_ref,
                                  const Eigen::Vector3d& linear_velocity);

}  // namespace pplvo::tracking
