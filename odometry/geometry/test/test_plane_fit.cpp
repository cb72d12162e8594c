#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/backprojection.h"
#include "pplvo/geometry/plane_fit.h"

namespace pplvo::geometry {
namespace {

struct Samples {
  std::vector<Eigen::Vector3d> P;
  std::vector<Eigen::Matrix3d> C;
  std::vector<double> V;
};

// Pixels of a window; the true point is where the ray through a sub-pixel position (uniform
// over the pixel) meets the plane; the measurement uses the integer pixel and a noisy depth.
Samples samplePlane(const PinholeCamera& cam, const Eigen::Vector4d& plane, int u0, int v0, int w,
                    int h, int step, std::mt19937& rng, double coeff = 1.425e-3) {
  std::uniform_real_distribution<double> U(-0.5, 0.5);
  std::normal_distribution<double> N(0.0, 1.0);
  Samples s;
  for (int v = v0; v < v0 + h; v += step) {
    for (int u = u0; u < u0 + w; u += step) {
      const Eigen::Vector3d r = cam.ray(u + U(rng), v + U(rng));
      const double z = -plane(3) / plane.head<3>().dot(r);
      const double sz = coeff * z * z;
      const double zm = z + sz * N(rng);
      const Point3WithCov p = backprojectWithCov(cam, u, v, zm, sz * sz);
      s.P.push_back(p.p);
      s.C.push_back(p.cov);
      s.V.push_back(sz * sz);
    }
  }
  return s;
}

Eigen::Vector4d makePlane(Eigen::Vector3d n, double d) {
  n.normalize();
  Eigen::Vector4d h;
  h << n, d;
  return h;
}

TEST(PlaneFit, RecoversTruePlane) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  std::mt19937 rng(1);
  const Eigen::Vector4d truth = makePlane({0.3, -0.2, -1.0}, 2.5);
  const Samples s = samplePlane(cam, truth, 100, 80, 400, 300, 4, rng);
  const PlaneFitResult f = fitPlaneWls(s.P, s.C, s.V);
  ASSERT_TRUE(f.ok()) << toString(f.status);
  EXPECT_LT(fixtures::angleDeg(f.plane.normal(), truth.head<3>()), 0.2);
  EXPECT_NEAR(f.plane.d(), truth(3), 0.005);
  EXPECT_GT(f.plane.d(), 0.0);
  EXPECT_NEAR(f.plane.normal().norm(), 1.0, 1e-12);
  // Convention: n.p + d = 0 on the points.
  EXPECT_LT(f.rms_m, 0.03);
}

// NEES over many trials: 3-dof theta_m and the Hessian form projected on its 3-dof tangent
// (two normal directions + d). Mean within [0.8, 1.25] x dof.
void neesExperiment(const Eigen::Vector4d& truth, int u0, int v0, int w, int h, int step,
                    double* nees_m, double* nees_h) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  std::mt19937 rng(12345);
  const Eigen::Vector3d theta_true = truth.head<3>() / truth(3);
  const int trials = 1000;
  double sum_m = 0, sum_h = 0;
  for (int t = 0; t < trials; ++t) {
    const Samples s = samplePlane(cam, truth, u0, v0, w, h, step, rng);
    const PlaneFitResult f = fitPlaneWls(s.P, s.C, s.V);
    ASSERT_TRUE(f.ok());
    const Eigen::Vector3d e = f.theta_m - theta_true;
    sum_m += e.dot(f.cov_theta_m.ldlt().solve(e));
    // Tangent of [n; d]: B spans the plane orthogonal to n_est.
    const Eigen::Vector3d n = f.plane.normal();
    Eigen::Matrix<double, 3, 4> Jt = Eigen::Matrix<double, 3, 4>::Zero();
    const Eigen::Vector3d b1 = n.unitOrthogonal(), b2 = n.cross(b1);
    Jt.block<1, 3>(0, 0) = b1.transpose();
    Jt.block<1, 3>(1, 0) = b2.transpose();
    Jt(2, 3) = 1.0;
    const Eigen::Vector3d eh = Jt * (f.plane.hessian - truth);
    const Eigen::Matrix3d Ch = Jt * f.plane.cov * Jt.transpose();
    sum_h += eh.dot(Ch.ldlt().solve(eh));
  }
  *nees_m = sum_m / trials;
  *nees_h = sum_h / trials;
}

TEST(PlaneFit, CovarianceIsConsistentNees) {
  struct Case {
    Eigen::Vector4d plane;
    int u0, v0, w, h, step;
  };
  const Case cases[] = {
      {makePlane({0.0, 0.0, -1.0}, 2.0), 200, 150, 240, 180, 6},  // fronto-parallel
      {makePlane({0.6, 0.3, -1.0}, 1.5), 100, 100, 200, 120, 5},  // slanted
      {makePlane({0.0, 1.0, -0.4}, 1.0), 0, 300, 640, 180, 8},    // floor-like, grazing
  };
  for (const Case& c : cases) {
    double nm = 0, nh = 0;
    neesExperiment(c.plane, c.u0, c.v0, c.w, c.h, c.step, &nm, &nh);
    EXPECT_GT(nm, 0.8 * 3) << c.plane.transpose();
    EXPECT_LT(nm, 1.25 * 3) << c.plane.transpose();
    EXPECT_GT(nh, 0.8 * 3) << c.plane.transpose();
    EXPECT_LT(nh, 1.25 * 3) << c.plane.transpose();
    std::printf(
        "plane [%.3f %.3f %.3f %.3f]: mean NEES theta_m %.3f, Hessian tangent %.3f (dof 3)\n",
        c.plane(0), c.plane(1), c.plane(2), c.plane(3), nm, nh);
  }
}

TEST(PlaneFit, PlaneThroughCameraCentreIsRejected) {
  // Points on the plane x = 0 (contains the origin), at various depths.
  std::vector<Eigen::Vector3d> P;
  std::vector<Eigen::Matrix3d> C;
  std::vector<double> V;
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0.0, 0.001);
  for (int i = 0; i < 200; ++i) {
    P.emplace_back(N(rng), -1.0 + 0.01 * i, 1.0 + 0.02 * (i % 50));
    C.push_back(Eigen::Matrix3d::Identity() * 1e-6);
    V.push_back(1e-6);
  }
  const PlaneFitResult f = fitPlaneWls(P, C, V);
  EXPECT_EQ(f.status, FitStatus::kThroughCameraCentre);
  EXPECT_TRUE(f.plane.hessian.allFinite());
  EXPECT_TRUE(f.plane.cov.allFinite());
}

TEST(PlaneFit, DegenerateInputs) {
  std::vector<Eigen::Vector3d> P = {{0, 0, 1}, {1, 0, 1}};
  std::vector<Eigen::Matrix3d> C(2, Eigen::Matrix3d::Identity() * 1e-6);
  std::vector<double> V(2, 1e-6);
  EXPECT_EQ(fitPlaneWls(P, C, V).status, FitStatus::kTooFewPoints);
  EXPECT_EQ(fitPlaneWls({}, {}, {}).status, FitStatus::kTooFewPoints);
  // Collinear points.
  P = {{0, 0, 1}, {1, 0, 1}, {2, 0, 1}, {3, 0, 1}};
  C.assign(4, Eigen::Matrix3d::Identity() * 1e-6);
  V.assign(4, 1e-6);
  EXPECT_EQ(fitPlaneWls(P, C, V).status, FitStatus::kDegenerate);
  // NaN input.
  P[1].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(fitPlaneWls(P, C, V).ok());
  // Mismatched sizes.
  V.pop_back();
  EXPECT_EQ(fitPlaneWls(P, C, V).status, FitStatus::kTooFewPoints);
}

TEST(PlaneFit, HessianJacobianMatchesNumeric) {
  const Eigen::Vector3d tm(0.2, -0.4, -0.7);
  Eigen::Matrix<double, 4, 3> J;
  const PlaneWithCov p = hessianFromMinimal(tm, Eigen::Matrix3d::Identity(), &J);
  EXPECT_NEAR(p.normal().dot(tm / tm.norm()), 1.0, 1e-12);
  EXPECT_NEAR(p.d(), 1.0 / tm.norm(), 1e-12);
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d a = tm, b = tm;
    a(k) += h;
    b(k) -= h;
    const Eigen::Vector4d num = (hessianFromMinimal(a, Eigen::Matrix3d::Zero()).hessian -
                                 hessianFromMinimal(b, Eigen::Matrix3d::Zero()).hessian) /
                                (2 * h);
    EXPECT_LT((num - J.col(k)).norm(), 1e-6) << k;
  }
}

}  // namespace
}  // namespace pplvo::geometry
