// Every Jacobian of the pose estimator checked against central differences: the residuals of
// the points (eq. 19), lines (eq. 20) and planes (eq. 21) with respect to the pose xi, the
// derivative of a rotated point with respect to q_xyz, and the Jacobians with respect to the
// primitives that propagate their covariances into Sigma_r.
#include <gtest/gtest.h>

#include <random>

#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/estimator/residuals.h"
#include "pplvo/fixtures/numeric_jacobian.h"

namespace pplvo::estimator {
namespace {

using pplvo::testing::expectJacobianNear;
using Vec2 = Eigen::Matrix<double, 2, 1>;
using Vec3 = Eigen::Matrix<double, 3, 1>;
using Vec4 = Eigen::Matrix<double, 4, 1>;

const Projector kCamera{525.0, -520.0, 319.5, 239.5, 0.1};  // fy < 0 as ICL's

struct Sampler {
  std::mt19937 rng{20261204};
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
  Vector6d pose() {
    Vector6d xi;
    xi << uniform(-0.3, 0.3), uniform(-0.3, 0.3), uniform(-0.3, 0.3), uniform(-0.2, 0.2),
        uniform(-0.2, 0.2), uniform(-0.2, 0.2);
    return xi;
  }
  /// A point the pose `xi` keeps in front of the camera.
  Vec3 pointInFront(const Vector6d& xi) {
    for (;;) {
      const Vec3 p(uniform(-1, 1), uniform(-1, 1), uniform(1.5, 4));
      if ((xiToPose(xi) * p).z() > 0.5) return p;
    }
  }
  Eigen::Matrix3d covariance() {
    Eigen::Matrix3d A;
    for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = uniform(-0.01, 0.01);
    return A * A.transpose() + 1e-6 * Eigen::Matrix3d::Identity();
  }
};

TEST(ResidualJacobians, RotatedPointWithRespectToQxyz) {
  Sampler s;
  for (int trial = 0; trial < 20; ++trial) {
    const Vector6d xi = s.pose();
    const Vec3 v = xi.tail<3>(), p = s.pointInFront(xi);
    const std::function<Vec3(const Vec3&)> rotated = [&](const Vec3& w) {
      return Vec3(xiToPose((Vector6d() << Vec3::Zero(), w).finished()).linear() * p);
    };
    expectJacobianNear<3, 3>("d R(v) p / d v", rotatedPointJacobian(v, p), rotated, v);
  }
}

TEST(ResidualJacobians, PointResidual) {
  Sampler s;
  for (int trial = 0; trial < 20; ++trial) {
    const Vector6d xi = s.pose();
    PointTerm T;
    T.P = s.pointInFront(xi);
    T.cov = s.covariance();
    T.px = Vec2(s.uniform(0, 640), s.uniform(0, 480));
    T.var_px2 = 0.25;
    const PoseEval pose(xi.data());
    ASSERT_TRUE(pose.valid);
    Vec2 r;
    Matrix26 J;
    Eigen::Matrix2d Sigma_r;
    ASSERT_TRUE(pointResidual(T, pose, kCamera, r, &J, &Sigma_r));
    const std::function<Vec2(const Vector6d&)> of_pose = [&](const Vector6d& x) {
      Vec2 out;
      EXPECT_TRUE(pointResidual(T, PoseEval(x.data()), kCamera, out, nullptr, nullptr));
      return out;
    };
    expectJacobianNear<2, 6>("point residual / xi", J, of_pose, xi);
    // Sigma_r propagates the point's covariance through d r / d P.
    const std::function<Vec2(const Vec3&)> of_point = [&](const Vec3& P) {
      PointTerm moved = T;
      moved.P = P;
      Vec2 out;
      EXPECT_TRUE(pointResidual(moved, pose, kCamera, out, nullptr, nullptr));
      return out;
    };
    const Eigen::Matrix<double, 2, 3> JP =
        pplvo::testing::numericJacobian<2, 3>(of_point, T.P, 1e-7);
    const Eigen::Matrix2d expected =
        JP * T.cov * JP.transpose() + T.var_px2 * Eigen::Matrix2d::Identity();
    EXPECT_LE((Sigma_r - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  }
}

TEST(ResidualJacobians, LineResidual) {
  Sampler s;
  for (int trial = 0; trial < 20; ++trial) {
    const Vector6d xi = s.pose();
    LineTerm T;
    for (int i = 0; i < 2; ++i) {
      T.P[i] = s.pointInFront(xi);
      T.cov[i] = s.covariance();
    }
    const double angle = s.uniform(0, M_PI);
    T.l = Vec3(std::cos(angle), std::sin(angle), s.uniform(-400, 0));
    T.var_px2 = 0.25;
    const PoseEval pose(xi.data());
    Vec2 r, var_r;
    Matrix26 J;
    ASSERT_TRUE(lineResidual(T, pose, kCamera, r, &J, &var_r));
    const std::function<Vec2(const Vector6d&)> of_pose = [&](const Vector6d& x) {
      Vec2 out;
      EXPECT_TRUE(lineResidual(T, PoseEval(x.data()), kCamera, out, nullptr, nullptr));
      return out;
    };
    expectJacobianNear<2, 6>("line residual / xi", J, of_pose, xi);
    // Each endpoint's distance propagates that endpoint's covariance.
    for (int i = 0; i < 2; ++i) {
      const std::function<Eigen::Matrix<double, 1, 1>(const Vec3&)> of_endpoint =
          [&](const Vec3& P) {
            LineTerm moved = T;
            moved.P[i] = P;
            Vec2 out;
            EXPECT_TRUE(lineResidual(moved, pose, kCamera, out, nullptr, nullptr));
            return Eigen::Matrix<double, 1, 1>(out(i));
          };
      const Eigen::Matrix<double, 1, 3> g =
          pplvo::testing::numericJacobian<1, 3>(of_endpoint, T.P[i], 1e-7);
      const double expected = (g * T.cov[i] * g.transpose())(0, 0) + T.var_px2;
      EXPECT_NEAR(var_r(i), expected, 1e-6 * expected);
    }
  }
}

TEST(ResidualJacobians, PlaneResidual) {
  Sampler s;
  for (int trial = 0; trial < 20; ++trial) {
    const Vector6d xi = s.pose();
    PlaneTerm T;
    const Vec3 n_prev = Vec3(s.uniform(-1, 1), s.uniform(-1, 1), s.uniform(-1, -0.2)).normalized();
    const Vec3 n_curr = Vec3(s.uniform(-1, 1), s.uniform(-1, 1), s.uniform(-1, -0.2)).normalized();
    T.prev << n_prev, s.uniform(0.5, 3);
    T.curr << n_curr, s.uniform(0.5, 3);
    Eigen::Matrix4d A, B;
    for (int i = 0; i < 16; ++i) {
      A(i / 4, i % 4) = s.uniform(-0.01, 0.01);
      B(i / 4, i % 4) = s.uniform(-0.01, 0.01);
    }
    T.cov_prev = A * A.transpose();
    T.cov_curr = B * B.transpose();
    const PoseEval pose(xi.data());
    Vec3 r;
    Matrix36 J;
    Eigen::Matrix3d Sigma_r;
    planeResidual(T, pose, r, &J, &Sigma_r);
    const std::function<Vec3(const Vector6d&)> of_pose = [&](const Vector6d& x) {
      Vec3 out;
      planeResidual(T, PoseEval(x.data()), out, nullptr, nullptr);
      return out;
    };
    expectJacobianNear<3, 6>("plane residual / xi", J, of_pose, xi);
    // Sigma_r propagates both planes' covariances ([n; d] each, to first order).
    const std::function<Vec3(const Vec4&)> of_prev = [&](const Vec4& p) {
      PlaneTerm moved = T;
      moved.prev = p;
      Vec3 out;
      planeResidual(moved, pose, out, nullptr, nullptr);
      return out;
    };
    const std::function<Vec3(const Vec4&)> of_curr = [&](const Vec4& p) {
      PlaneTerm moved = T;
      moved.curr = p;
      Vec3 out;
      planeResidual(moved, pose, out, nullptr, nullptr);
      return out;
    };
    const Eigen::Matrix<double, 3, 4> Jp =
        pplvo::testing::numericJacobian<3, 4>(of_prev, Vec4(T.prev), 1e-7);
    const Eigen::Matrix<double, 3, 4> Jc =
        pplvo::testing::numericJacobian<3, 4>(of_curr, Vec4(T.curr), 1e-7);
    const Eigen::Matrix3d expected =
        Jp * T.cov_prev * Jp.transpose() + Jc * T.cov_curr * Jc.transpose();
    EXPECT_LE((Sigma_r - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  }
}

}  // namespace
}  // namespace pplvo::estimator
