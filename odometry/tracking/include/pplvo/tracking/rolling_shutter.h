#pragma once
/// Rolling-shutter compensation of a frame's point and line features (docs/estimator.md,
/// "Rolling shutter"). A rolling-shutter colour camera reads its rows top to bottom over the
/// readout time r (PinholeCamera::readout_s), the middle row at the frame's stamp: row v is
/// read at tau(v) = (v - (H - 1) / 2) r / (H - 1). Under a constant angular velocity w (the
/// motion model's, camera frame, rad/s) the camera at tau is rotated by R(tau) = exp(tau w)
/// from its pose at the stamp, so a feature read at row v is moved to the stamp by R(tau(v)):
/// its ray (pixel) and its 3D point (lifted along that ray) turn with it. Only the rotation
/// is compensated: it is what moves the image most (1 rad/s over 12 ms is 6 px at VGA), and it
/// needs no depth; a translation of 1 m/s moves a point 2 m away by about 3 px over the same
/// time and is left to the estimator's noise. Planes (from the depth image, which the sensor
/// reads at once) are left as they are.
#include <Eigen/Core>

#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"

namespace pplvo::tracking {

/// The camera's angular velocity (rad/s, in its own frame) of a motion T_curr_prev that took
/// `interval_s` seconds; zero for a non-positive or non-finite interval.
Eigen::Vector3d angularVelocity(const Pose3& T_curr_prev, double interval_s);

/// The instant (s, relative to the stamp) at which row `v` of `camera` was read.
double rowTime(const PinholeCamera& camera, double v);

/// Moves the points and lines of `frame` (2D and, when lifted, 3D) to the instant of its stamp,
/// given the camera's angular velocity. No-op for a global shutter (readout_s == 0) or w = 0.
void compensateRollingShutter(FrameFeatures& frame, const Eigen::Vector3d& angular_velocity);

}  // namespace pplvo::tracking
