#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/backprojection.h"

namespace pplvo::geometry {
namespace {

// Eq. 9 against Monte-Carlo: pixel error uniform over one pixel (variance 1/12), depth Gaussian.
void checkMonteCarlo(const PinholeCamera& cam, double u, double v, double z, double sigma_z) {
  const Point3WithCov p = backprojectWithCov(cam, u, v, z, sigma_z * sigma_z);
  EXPECT_NEAR((p.p - cam.backproject(u, v, z)).norm(), 0.0, 1e-12);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.5, 0.5);
  std::normal_distribution<double> N(0.0, sigma_z);
  const int n = 200000;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  std::vector<Eigen::Vector3d> s(n);
  for (int i = 0; i < n; ++i) {
    s[i] = cam.backproject(u + U(rng), v + U(rng), z + N(rng));
    mean += s[i];
  }
  mean /= n;
  for (const auto& x : s) M += (x - mean) * (x - mean).transpose();
  M /= (n - 1);
  // First order is exact in u, v and Z separately; the bilinear u*Z term is second order.
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(M(r, r), p.cov(r, r), 0.03 * p.cov(r, r)) << "diag " << r;
    for (int c = r + 1; c < 3; ++c) {
      EXPECT_NEAR(M(r, c), p.cov(r, c), 0.03 * std::sqrt(p.cov(r, r) * p.cov(c, c)))
          << r << "," << c;
    }
  }
}

TEST(Backprojection, CovarianceMatchesMonteCarlo) {
  checkMonteCarlo(fixtures::iclVgaCamera(false), 100.3, 400.7, 2.5, 1.425e-3 * 2.5 * 2.5);
  checkMonteCarlo(fixtures::iclVgaCamera(true), 600.0, 20.0, 1.2, 0.004);  // signed fy < 0
  checkMonteCarlo(fixtures::iclVgaCamera(true), 319.5, 239.5, 4.0, 0.02);  // principal point
}

TEST(Backprojection, SignedFocalLengthKeepsProjectionConsistent) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const Point3WithCov p = backprojectWithCov(cam, 500.0, 100.0, 3.0, 1e-4);
  const Eigen::Vector2d px = cam.project(p.p);
  EXPECT_NEAR(px.x(), 500.0, 1e-9);
  EXPECT_NEAR(px.y(), 100.0, 1e-9);
  EXPECT_GT(p.p.y(), 0.0);  // v < cy with fy < 0 gives y > 0
  // Covariance is symmetric positive definite.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(p.cov);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
}

TEST(Backprojection, DepthAtFallsBackToSensorModel) {
  DepthWithVariance dv;
  dv.depth_m = cv::Mat::zeros(4, 4, CV_32F);
  dv.depth_m.at<float>(1, 2) = 2.0f;
  dv.depth_m.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  DepthNoiseModel model;
  double z = 0, var = 0;
  EXPECT_TRUE(depthAt(dv, 2, 1, model, &z, &var));
  EXPECT_DOUBLE_EQ(z, 2.0);
  EXPECT_NEAR(var, std::pow(1.425e-3 * 4.0, 2), 1e-12);
  EXPECT_FALSE(depthAt(dv, 0, 0, model, &z, &var));   // missing
  EXPECT_FALSE(depthAt(dv, 2, 2, model, &z, &var));   // NaN
  EXPECT_FALSE(depthAt(dv, -1, 0, model, &z, &var));  // outside
  EXPECT_FALSE(depthAt(dv, 4, 0, model, &z, &var));
  dv.var_m2 = cv::Mat(4, 4, CV_32F, cv::Scalar(1e-4));
  EXPECT_TRUE(depthAt(dv, 2, 1, model, &z, &var));
  EXPECT_NEAR(var, 1e-4, 1e-10);
}

}  // namespace
}  // namespace pplvo::geometry
