#include "pplvo/core/body_odometry.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

namespace pplvo {
namespace {

constexpr double kDt = 1.0 / 30.0;

Pose3 motion(const Eigen::Vector3d& t, const Eigen::Vector3d& rotvec) {
  Pose3 T = Pose3::Identity();
  if (rotvec.norm() > 0) T.linear() = Eigen::AngleAxisd(rotvec.norm(), rotvec.normalized()).matrix();
  T.translation() = t;
  return T;
}

FramePose framePose(int64_t seq, const Pose3& T_prev_curr, const Matrix6d& cov) {
  FramePose p;
  p.seq = seq;
  p.utime = seq * 33333;
  p.status = seq == 0 ? TrackingStatus::kFirstFrame : TrackingStatus::kTracking;
  p.T_prev_curr = T_prev_curr;
  p.rel_covariance = cov;
  return p;
}

TEST(BodyOdometry, OpticalAxesBecomeRep103Axes) {
  const Eigen::Matrix3d R = opticalToCameraBody();
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d::UnitX()));   // looking: forward
  EXPECT_TRUE(R.col(0).isApprox(-Eigen::Vector3d::UnitY()));  // right: -left
  EXPECT_TRUE(R.col(1).isApprox(-Eigen::Vector3d::UnitZ()));  // down: -up
}

// A camera driving forward while turning left at a constant rate (an arc): the body twist is
// forward speed along +x and a yaw rate about +z, nothing sideways.
TEST(BodyOdometry, ForwardAndLeftTurnInBodyAxes) {
  BodyOdometryIntegrator odometry;
  const Matrix6d cov = Matrix6d::Identity() * 1e-6;
  // Optical frame: forward is +z, a left turn is a rotation about -y (y points down); an arc
  // moves by V(phi) times the straight step.
  const Eigen::Vector3d phi(0, -0.02, 0);
  const Pose3 step = motion(leftJacobianSO3(phi) * Eigen::Vector3d(0, 0, 0.05), phi);
  odometry.add(framePose(0, Pose3::Identity(), cov), 0.0);
  BodyOdometry out;
  for (int k = 1; k <= 10; ++k) out = odometry.add(framePose(k, step, cov), k * kDt);
  EXPECT_NEAR(out.linear_velocity.x(), 0.05 / kDt, 1e-9);
  EXPECT_NEAR(out.linear_velocity.y(), 0.0, 1e-9);
  EXPECT_NEAR(out.linear_velocity.z(), 0.0, 1e-9);
  EXPECT_NEAR(out.angular_velocity.z(), 0.02 / kDt, 1e-9);
  EXPECT_NEAR(out.angular_velocity.x(), 0.0, 1e-12);
  EXPECT_NEAR(out.dt_s, kDt, 1e-12);
  // Ten steps of 5 cm turning left: ahead and a little to the left, yawed by 0.2 rad.
  EXPECT_GT(out.T_odom_base.translation().x(), 0.45);
  EXPECT_GT(out.T_odom_base.translation().y(), 0.01);
  EXPECT_NEAR(out.T_odom_base.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(out.T_odom_base.linear()).angle(), 0.2, 1e-9);
}

// The composition of the body motions is the camera's pose moved into the body frame, for any
// mounting: T_odom_base = T_base_opt T_w_c T_base_opt^-1.
TEST(BodyOdometry, ComposedMotionsEqualTheConvertedCameraPose) {
  BodyExtrinsic mount;
  mount.T_base_camera = motion({0.2, -0.05, 0.5}, {0.03, 0.4, -0.1});  // pitched down, offset
  BodyOdometryIntegrator odometry(mount);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  Pose3 T_w_c = Pose3::Identity();
  odometry.add(framePose(0, Pose3::Identity(), Matrix6d::Identity() * 1e-6), 0.0);
  BodyOdometry out;
  for (int k = 1; k <= 50; ++k) {
    const Pose3 step = motion({0.02 * n(rng), 0.02 * n(rng), 0.03 + 0.02 * n(rng)},
                              {0.01 * n(rng), 0.02 * n(rng), 0.01 * n(rng)});
    T_w_c = T_w_c * step;
    out = odometry.add(framePose(k, step, Matrix6d::Identity() * 1e-6), k * kDt);
  }
  const Pose3 A = mount.baseFromOptical();
  const Pose3 expected = A * T_w_c * A.inverse();
  EXPECT_TRUE(out.T_odom_base.isApprox(expected, 1e-9));
}

// The camera ahead of and above the robot's origin, the robot turning on the spot: the camera
// moves on a circle, the body does not move.
TEST(BodyOdometry, LeverArmOfAnOffsetCameraIsRemoved) {
  BodyExtrinsic mount;
  mount.T_base_camera = motion({0.3, 0.0, 0.4}, {0, 0, 0});
  const Pose3 A = mount.baseFromOptical();
  const Pose3 yaw = motion({0, 0, 0}, {0, 0, 0.05});  // the body's motion
  const Pose3 camera_step = A.inverse() * yaw * A;
  EXPECT_GT(camera_step.translation().norm(), 0.01);  // the camera does move
  BodyOdometryIntegrator odometry(mount);
  odometry.add(framePose(0, Pose3::Identity(), Matrix6d::Identity() * 1e-6), 0.0);
  const BodyOdometry out =
      odometry.add(framePose(1, camera_step, Matrix6d::Identity() * 1e-6), kDt);
  EXPECT_LT(out.linear_velocity.norm(), 1e-9);
  EXPECT_NEAR(out.angular_velocity.z(), 0.05 / kDt, 1e-9);
}

TEST(BodyOdometry, FirstFrameHasNoTwist) {
  BodyOdometryIntegrator odometry;
  const BodyOdometry first =
      odometry.add(framePose(0, Pose3::Identity(), Matrix6d::Identity()), 0.0);
  EXPECT_TRUE(first.T_odom_base.isApprox(Pose3::Identity()));
  EXPECT_EQ(first.dt_s, 0.0);
  EXPECT_EQ(first.twist_covariance(0, 0), kUnknownTwistVariance);
  EXPECT_TRUE(first.pose_covariance.isZero());
}

// Monte Carlo: motions drawn with pose_t's covariance over [t; q_xyz], integrated; the spread
// of the odom pose ([dp; dphi] in odom) and of the last twist must match the covariances
// propagated to first order. Fixed seed: deterministic.
TEST(BodyOdometry, CovariancesMatchTheSpreadOfSampledMotions) {
  BodyExtrinsic mount;
  mount.T_base_camera = motion({0.1, 0.0, 0.3}, {0.0, 0.3, 0.0});
  const Pose3 step = motion({0.01, -0.005, 0.04}, {0.01, -0.03, 0.005});
  Eigen::Matrix<double, 6, 6> L = Eigen::Matrix<double, 6, 6>::Zero();  // cov = L L^T
  L.diagonal() << 2e-3, 1e-3, 3e-3, 1.5e-3, 2.5e-3, 1e-3;  // m and quaternion units
  L(2, 0) = 1e-3;
  L(4, 2) = 0.8e-3;
  const Matrix6d cov = L * L.transpose();
  const int kSteps = 20, kSamples = 4000;

  BodyOdometryIntegrator nominal(mount);
  nominal.add(framePose(0, Pose3::Identity(), cov), 0.0);
  BodyOdometry predicted;
  for (int k = 1; k <= kSteps; ++k) predicted = nominal.add(framePose(k, step, cov), k * kDt);

  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vector6d> pose_err, twist_err;
  for (int s = 0; s < kSamples; ++s) {
    BodyOdometryIntegrator sample(mount);
    sample.add(framePose(0, Pose3::Identity(), cov), 0.0);
    BodyOdometry out;
    for (int k = 1; k <= kSteps; ++k) {
      Vector6d z;
      for (int i = 0; i < 6; ++i) z(i) = n(rng);
      const Vector6d d = L * z;
      Eigen::Quaterniond q(step.linear());
      q.vec() += d.tail<3>();
      q.w() = std::sqrt(1.0 - q.vec().squaredNorm());
      Pose3 noisy = Pose3::Identity();
      noisy.linear() = q.toRotationMatrix();
      noisy.translation() = step.translation() + d.head<3>();
      out = sample.add(framePose(k, noisy, cov), k * kDt);
    }
    Vector6d e;
    e.head<3>() = out.T_odom_base.translation() - predicted.T_odom_base.translation();
    const Eigen::AngleAxisd dR(out.T_odom_base.linear() * predicted.T_odom_base.linear().transpose());
    e.tail<3>() = dR.angle() * dR.axis();
    pose_err.push_back(e);
    Vector6d t;
    t << out.linear_velocity - predicted.linear_velocity,
        out.angular_velocity - predicted.angular_velocity;
    twist_err.push_back(t);
  }
  const auto empirical = [](const std::vector<Vector6d>& errs) {
    Matrix6d c = Matrix6d::Zero();
    for (const Vector6d& e : errs) c += e * e.transpose();
    return Matrix6d(c / static_cast<double>(errs.size()));
  };
  const Matrix6d pose_cov = empirical(pose_err), twist_cov = empirical(twist_err);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(pose_cov(i, i) / predicted.pose_covariance(i, i), 1.0, 0.12) << "pose axis " << i;
    EXPECT_NEAR(twist_cov(i, i) / predicted.twist_covariance(i, i), 1.0, 0.12)
        << "twist axis " << i;
  }
  // NEES of the samples: mean 6 for a consistent covariance.
  double nees = 0;
  const Matrix6d info = predicted.pose_covariance.inverse();
  for (const Vector6d& e : pose_err) nees += e.dot(info * e);
  EXPECT_NEAR(nees / kSamples, 6.0, 0.5);
}

// The per-frame shared error does not accumulate: taken out of every motion (and twist), it
// is in the pose covariance once, however long the chain.
TEST(BodyOdometry, SharedFrameErrorIsCountedOnceNotPerMotion) {
  Matrix6d shared = Matrix6d::Zero();
  shared.diagonal() << 4e-6, 4e-6, 4e-6, 1e-7, 1e-7, 1e-7;
  Matrix6d estimate = Matrix6d::Identity() * 1e-8;
  BodyOdometryIntegrator with_shared, without;
  const Pose3 step = motion({0.0, 0.0, 0.03}, {0.0, 0.01, 0.0});
  with_shared.add(framePose(0, Pose3::Identity(), Matrix6d::Zero()), 0.0);
  without.add(framePose(0, Pose3::Identity(), Matrix6d::Zero()), 0.0);
  BodyOdometry a, b;
  for (int k = 1; k <= 100; ++k) {
    FramePose p = framePose(k, step, estimate + shared);
    p.frame_error_covariance = shared;  // the estimator says which part is shared
    a = with_shared.add(p, k * kDt);
    b = without.add(framePose(k, step, estimate), k * kDt);
  }
  EXPECT_TRUE(a.twist_covariance.isApprox(b.twist_covariance, 1e-9));
  // Translation: 100 estimates plus the shared error once (2 frames' worth), not 100 times.
  const double extra = a.pose_covariance(0, 0) - b.pose_covariance(0, 0);
  EXPECT_NEAR(extra, shared(1, 1), 0.3 * shared(1, 1));
  EXPECT_LT(a.pose_covariance.trace(), 2.0 * b.pose_covariance.trace() + 6 * shared(0, 0));
}

}  // namespace
}  // namespace pplvo
