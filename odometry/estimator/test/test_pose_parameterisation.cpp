#include <gtest/gtest.h>

#include <random>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo {
namespace {

Pose3 randomPose(std::mt19937& rng, double max_angle_rad, double max_t_m) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(U(rng), U(rng), U(rng)).normalized();
  const double angle = max_angle_rad * std::abs(U(rng));
  return makePose(max_t_m * Eigen::Vector3d(U(rng), U(rng), U(rng)),
                  Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis)));
}

Vector6d composeXi(const Vector6d& xi_k_1, const Vector6d& xi_k1_k) {
  return poseToXi(xiToPose(xi_k1_k) * xiToPose(xi_k_1));
}

TEST(PoseParameterisation, XiRoundTrip) {
  std::mt19937 rng(1);
  for (int i = 0; i < 50; ++i) {
    const Pose3 T = randomPose(rng, 2.5, 2.0);
    const Pose3 T2 = xiToPose(poseToXi(T));
    EXPECT_LT((T.matrix() - T2.matrix()).norm(), 1e-12);
    EXPECT_LE(poseToXi(T).tail<3>().norm(), 1.0);
  }
}

TEST(PoseParameterisation, RotatedPointJacobianMatchesNumeric) {
  std::mt19937 rng(2);
  for (int i = 0; i < 20; ++i) {
    const Vector6d xi = poseToXi(randomPose(rng, 2.0, 1.0));
    const Eigen::Vector3d p(0.3 * i - 2, 1.5, -0.7 + 0.1 * i);
    const Eigen::Matrix3d J = rotatedPointJacobian(xi.tail<3>(), p);
    Eigen::Matrix3d Jn;
    const double h = 1e-7;
    for (int k = 0; k < 3; ++k) {
      Vector6d a = xi, b = xi;
      a(3 + k) += h;
      b(3 + k) -= h;
      Jn.col(k) = (xiToPose(a).linear() * p - xiToPose(b).linear() * p) / (2 * h);
    }
    EXPECT_LT((J - Jn).norm(), 1e-6 * (1 + Jn.norm())) << J << "\n" << Jn;
  }
}

TEST(PoseParameterisation, CompositionJacobiansMatchNumeric) {
  std::mt19937 rng(3);
  for (int i = 0; i < 30; ++i) {
    const Pose3 T1 = randomPose(rng, 1.0, 1.0);  // T^(k|1)
    const Pose3 T2 = randomPose(rng, 0.3, 0.1);  // T^(k+1|k)
    const CompositionJacobians J = compositionJacobians(T1, T2);
    const Vector6d x1 = poseToXi(T1), x2 = poseToXi(T2);
    Matrix6d Fn, Gn;
    const double h = 1e-7;
    for (int k = 0; k < 6; ++k) {
      Vector6d a = x1, b = x1;
      a(k) += h;
      b(k) -= h;
      Fn.col(k) = (composeXi(a, x2) - composeXi(b, x2)) / (2 * h);
      a = x2;
      b = x2;
      a(k) += h;
      b(k) -= h;
      Gn.col(k) = (composeXi(x1, a) - composeXi(x1, b)) / (2 * h);
    }
    EXPECT_LT((J.F - Fn).cwiseAbs().maxCoeff(), 1e-6) << "F\n" << J.F << "\nnumeric\n" << Fn;
    EXPECT_LT((J.G - Gn).cwiseAbs().maxCoeff(), 1e-6) << "G\n" << J.G << "\nnumeric\n" << Gn;
  }
}

TEST(PoseParameterisation, CompositionJacobiansWhenComposedQuaternionFlipsSign) {
  // Two rotations of 100 deg about the same axis compose to 200 deg: q_w < 0 before re-signing.
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  const Pose3 T1 = makePose({0.1, 0.2, 0.3}, Eigen::Quaterniond(Eigen::AngleAxisd(1.75, axis)));
  const Pose3 T2 = makePose({-0.1, 0.0, 0.2}, Eigen::Quaterniond(Eigen::AngleAxisd(1.75, axis)));
  const CompositionJacobians J = compositionJacobians(T1, T2);
  const Vector6d x1 = poseToXi(T1), x2 = poseToXi(T2);
  Matrix6d Fn;
  const double h = 1e-7;
  for (int k = 0; k < 6; ++k) {
    Vector6d a = x1, b = x1;
    a(k) += h;
    b(k) -= h;
    Fn.col(k) = (composeXi(a, x2) - composeXi(b, x2)) / (2 * h);
  }
  EXPECT_LT((J.F - Fn).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(PoseParameterisation, InvertedCovarianceMatchesNumeric) {
  std::mt19937 rng(4);
  for (int i = 0; i < 20; ++i) {
    const Pose3 T = randomPose(rng, 1.0, 1.0);
    const Vector6d x = poseToXi(T);
    Matrix6d Jn;
    const double h = 1e-7;
    for (int k = 0; k < 6; ++k) {
      Vector6d a = x, b = x;
      a(k) += h;
      b(k) -= h;
      Jn.col(k) = (poseToXi(xiToPose(a).inverse()) - poseToXi(xiToPose(b).inverse())) / (2 * h);
    }
    Matrix6d A = Matrix6d::Random();
    const Matrix6d cov = A * A.transpose() + Matrix6d::Identity();
    const Matrix6d expected = Jn * cov * Jn.transpose();
    EXPECT_LT((invertedPoseCovariance(T, cov) - expected).norm(), 1e-5 * expected.norm());
  }
}

// Propagated covariance of a chain of 6 noisy transforms vs Monte-Carlo composition.
TEST(PoseParameterisation, ChainCovarianceMatchesMonteCarlo) {
  std::mt19937 rng(5);
  std::normal_distribution<double> N01;
  const int n_links = 6;
  std::vector<Pose3> links;
  std::vector<Matrix6d> covs;
  for (int i = 0; i < n_links; ++i) {
    links.push_back(randomPose(rng, 0.1, 0.05));
    Vector6d sd;
    sd << 0.002, 0.003, 0.001, 0.001, 0.002, 0.0015;
    Matrix6d A = 0.3 * Matrix6d::Random();
    Matrix6d C = sd.asDiagonal() * (Matrix6d::Identity() + A * A.transpose()) * sd.asDiagonal();
    covs.push_back(C);
  }
  // Propagation: T^(1|0) = links[0], then compose.
  Pose3 T = links[0];
  Matrix6d P = covs[0];
  for (int i = 1; i < n_links; ++i) {
    P = propagateCompositionCovariance(T, P, links[i], covs[i]);
    T = links[i] * T;
  }
  const Vector6d x_nominal = poseToXi(T);
  const int n_samples = 5000;
  Matrix6d S = Matrix6d::Zero();
  double nees = 0;
  const Eigen::LDLT<Matrix6d> ldlt(P);
  for (int s = 0; s < n_samples; ++s) {
    Pose3 Ts = Pose3::Identity();
    for (int i = 0; i < n_links; ++i) {
      Vector6d g;
      for (int k = 0; k < 6; ++k) g(k) = N01(rng);
      const Vector6d xi = poseToXi(links[i]) + covs[i].llt().matrixL() * g;
      Ts = xiToPose(xi) * Ts;
    }
    const Vector6d e = poseToXi(Ts) - x_nominal;
    S += e * e.transpose();
    nees += e.dot(ldlt.solve(e));
  }
  S /= n_samples;
  nees /= n_samples;
  // Mean NEES of 5000 chi2(6) samples: std 0.035; accept [5.8, 6.2].
  EXPECT_GT(nees, 5.8);
  EXPECT_LT(nees, 6.2);
  EXPECT_LT((S - P).norm(), 0.05 * P.norm()) << "MC\n" << S << "\npropagated\n" << P;
}

}  // namespace
}  // namespace pplvo
