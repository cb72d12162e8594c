#pragma once
/// Geometric primitives with their uncertainty, always carried together with the value.
/// Frames are explicit in the names of the functions that move them.
#include <Eigen/Core>

#include "pplvo/core/geometry.h"

namespace pplvo {

/// 3D point with covariance (metres, m^2).
struct Point3WithCov {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();

  /// The point expressed in frame a, given it is in frame b: p_a = T_a_b p_b, cov rotated.
  Point3WithCov transformed(const Pose3& T_a_b) const {
    const Eigen::Matrix3d R = T_a_b.linear();
    return {T_a_b * p, R * cov * R.transpose()};
  }
};

/// 3D line segment by its endpoints, each with covariance.
struct Line3WithCov {
  Eigen::Vector3d p1 = Eigen::Vector3d::Zero(), p2 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov1 = Eigen::Matrix3d::Zero(), cov2 = Eigen::Matrix3d::Zero();

  Line3WithCov transformed(const Pose3& T_a_b) const {
    const Eigen::Matrix3d R = T_a_b.linear();
    return {T_a_b * p1, T_a_b * p2, R * cov1 * R.transpose(), R * cov2 * R.transpose()};
  }
};

/// Plane in Hessian normal form n.p + d = 0 with |n| = 1 and d > 0 (the normal points from
/// the plane towards the camera), with the 4x4 covariance of [n; d].
struct PlaneWithCov {
  Eigen::Vector4d hessian = Eigen::Vector4d(0, 0, -1, 1);
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();

  Eigen::Vector3d normal() const { return hessian.head<3>(); }
  double d() const { return hessian(3); }
  /// Signed distance of a point to the plane.
  double distance(const Eigen::Vector3d& p) const { return normal().dot(p) + d(); }
  /// Closest point of the plane to the origin, -d n (the paper's plane "point" C).
  Eigen::Vector3d closestPoint() const { return -d() * normal(); }

  /// The plane in frame a given it is in frame b: n_a = R n_b, d_a = d_b - n_a . t.
  PlaneWithCov transformed(const Pose3& T_a_b) const {
    const Eigen::Matrix3d R = T_a_b.linear();
    const Eigen::Vector3d t = T_a_b.translation();
    Eigen::Matrix4d J = Eigen::Matrix4d::Zero();
    J.topLeftCorner<3, 3>() = R;
    J.block<1, 3>(3, 0) = -t.transpose() * R;
    J(3, 3) = 1.0;
    PlaneWithCov out;
    out.hessian = J * hessian;
    out.cov = J * cov * J.transpose();
    return out;
  }
};

}  // namespace pplvo
