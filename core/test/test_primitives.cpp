#include <gtest/gtest.h>

#include <random>

#include "pplvo/core/primitives.h"

namespace pplvo {
namespace {

Pose3 somePose() {
  return makePose(Eigen::Vector3d(0.3, -0.1, 0.5),
                  Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -2, 0.5).normalized())));
}

TEST(Primitives, PlaneTransformKeepsPointsOnPlane) {
  PlaneWithCov pl;
  pl.hessian << Eigen::Vector3d(0.2, -0.3, -1).normalized(), 2.0;
  const Pose3 T_a_b = somePose();
  const PlaneWithCov pa = pl.transformed(T_a_b);
  EXPECT_NEAR(pa.normal().norm(), 1.0, 1e-12);
  // Points on the plane in b stay on the transformed plane in a.
  const Eigen::Vector3d onb = pl.closestPoint() + Eigen::Vector3d(0.3, 0.2, 0).cross(pl.normal());
  EXPECT_NEAR(pl.distance(onb), 0.0, 1e-12);
  EXPECT_NEAR(pa.distance(T_a_b * onb), 0.0, 1e-12);
}

TEST(Primitives, PlaneCovariancePropagatesLikeMonteCarlo) {
  PlaneWithCov pl;
  pl.hessian << Eigen::Vector3d(0.1, 0.2, -1).normalized(), 1.5;
  Eigen::Matrix4d A = Eigen::Matrix4d::Random() * 0.01;
  pl.cov = A * A.transpose();
  const Pose3 T = somePose();
  const Eigen::Matrix4d predicted = pl.transformed(T).cov;
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  Eigen::LLT<Eigen::Matrix4d> llt(pl.cov);
  Eigen::Matrix4d sample = Eigen::Matrix4d::Zero();
  const int n = 20000;
  const Eigen::Vector4d mean = pl.transformed(T).hessian;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector4d z(g(rng), g(rng), g(rng), g(rng));
    PlaneWithCov s = pl;
    s.hessian += llt.matrixL() * z;
    const Eigen::Vector4d e = s.transformed(T).hessian - mean;
    sample += e * e.transpose() / n;
  }
  EXPECT_LT((sample - predicted).norm() / predicted.norm(), 0.05);
}

TEST(Primitives, PointTransformRotatesCovariance) {
  Point3WithCov p{{1, 2, 3}, Eigen::Vector3d(1e-4, 4e-4, 9e-4).asDiagonal()};
  const Pose3 T = somePose();
  const auto q = p.transformed(T);
  EXPECT_TRUE(q.p.isApprox(T * p.p));
  EXPECT_NEAR(q.cov.trace(), p.cov.trace(), 1e-15);
}

}  // namespace
}  // namespace pplvo
