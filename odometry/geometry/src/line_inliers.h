#pragma once
/// The distance test of the line RANSAC in liftLine(), over points stored as coordinate
/// columns so that it vectorises. Internal to pplvo_geometry (and its tests).
#include <Eigen/Core>
#include <vector>

namespace pplvo::geometry::detail {

/// Points as three coordinate arrays (structure of arrays).
struct PointColumns {
  std::vector<double> x, y, z;
  void assign(const std::vector<Eigen::Vector3d>& points);
  int size() const { return static_cast<int>(x.size()); }
};

/// inlier[q] = 1 where the squared distance of point q from the line through `a` along `d`,
/// |(P_q - a) x d|^2 / dn2 with dn2 = |d|^2, is below thr2, else 0; returns how many are 1.
/// The same double operations in the same order as Eigen's
/// `(P[q] - a).cross(d).squaredNorm() / dn2`, without FMA contraction, so the marks are bit
/// for bit those of that expression.
int markLineInliers(const PointColumns& points, const Eigen::Vector3d& a, const Eigen::Vector3d& d,
                    double dn2, double thr2, char* inlier);

}  // namespace pplvo::geometry::detail
