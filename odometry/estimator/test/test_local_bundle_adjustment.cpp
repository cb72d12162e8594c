// Local bundle adjustment (local_bundle_adjustment.h) on fabricated keyframes and points with
// known truth: it recovers perturbed free keyframes, keeps fixed ones, reports wrong
// associations as outliers, and leaves an ungauged problem alone.
#include <gtest/gtest.h>

#include <random>

#include "pplvo/estimator/local_bundle_adjustment.h"
#include "pplvo/fixtures/cameras.h"

namespace pplvo::estimator {
namespace {

using fixtures::kinectVgaCamera;

Pose3 poseAt(double x, double yaw_deg) {
  Pose3 T = Pose3::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.02 * x, 0.05 * x);
  return T;
}

Pose3 perturbed(const Pose3& T, const Eigen::Vector3d& dt, double droll_deg) {
  Pose3 P = T;
  P.translation() += dt;
  P.linear() = T.linear() * Eigen::AngleAxisd(droll_deg * M_PI / 180, Eigen::Vector3d::UnitZ())
                                .toRotationMatrix();
  return P;
}

/// Points in front of four keyframes 10 cm apart; each keyframe measures every point it sees
/// (3D with a depth-like covariance, noise drawn from it when `noisy`).
struct Scene {
  BundleProblem problem;
  std::vector<Pose3> truth;
  std::vector<Eigen::Vector3d> points_w;
};

Scene makeScene(bool noisy, bool pixels_after_first) {
  Scene s;
  s.problem.camera = kinectVgaCamera();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 4; ++k) s.truth.push_back(poseAt(0.1 * k, 3.0 * k));
  for (int i = 0; i < 150; ++i) s.points_w.emplace_back(1.2 * u(rng), 0.9 * u(rng), 2.5 + u(rng));
  for (int k = 0; k < 4; ++k) s.problem.keyframes.push_back({s.truth[k], k == 0});
  for (size_t i = 0; i < s.points_w.size(); ++i) {
    s.problem.landmarks_w.push_back(s.points_w[i]);
    bool first = true;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = s.truth[k].inverse() * s.points_w[i];
      if (!s.problem.camera.inImage(s.problem.camera.project(p))) continue;
      // Depth-like: 1 mm across the ray, 1.4e-3 z^2 along it.
      const double sz = 1.4e-3 * p.z() * p.z();
      Eigen::Matrix3d cov = Eigen::Vector3d(1e-6, 1e-6, sz * sz).asDiagonal();
      Eigen::Vector3d measured = p;
      if (noisy) measured += Eigen::Vector3d(1e-3 * n(rng), 1e-3 * n(rng), sz * n(rng));
      BundleObservation o{k, static_cast<int>(i), measured, cov};
      o.use_depth = first || !pixels_after_first;
      o.sigma_px = 0.5;
      first = false;
      s.problem.observations.push_back(o);
    }
  }
  return s;
}

double worstTranslationError(const BundleResult& r, const Scene& s) {
  double worst = 0;
  for (size_t k = 0; k < s.truth.size(); ++k) {
    worst = std::max(worst, (r.T_w_kf[k].translation() - s.truth[k].translation()).norm());
  }
  return worst;
}

TEST(LocalBundleAdjustment, RecoversPerturbedKeyframes) {
  for (const bool pixels : {false, true}) {
    Scene s = makeScene(/*noisy=*/false, pixels);
    s.problem.keyframes[2].T_w_kf =
        perturbed(s.truth[2], Eigen::Vector3d(0.02, -0.01, 0.015), 1.0);
    s.problem.keyframes[3].T_w_kf =
        perturbed(s.truth[3], Eigen::Vector3d(-0.015, 0.02, 0.0), -0.8);
    BundleOptions o;
    o.max_iterations = 30;
    const BundleResult r = adjustLocalBundle(s.problem, o);
    ASSERT_TRUE(r.solved);
    EXPECT_LT(worstTranslationError(r, s), 1e-5) << "pixels after first: " << pixels;
    EXPECT_TRUE(r.T_w_kf[0].isApprox(s.truth[0]));  // fixed: untouched
    for (size_t i = 0; i < r.inlier.size(); ++i) EXPECT_TRUE(r.inlier[i]);
  }
}

TEST(LocalBundleAdjustment, NoisyMeasurementsLeaveExactPosesNearTruth) {
  for (const bool pixels : {false, true}) {
    const Scene s = makeScene(/*noisy=*/true, pixels);
    const BundleResult r = adjustLocalBundle(s.problem);
    ASSERT_TRUE(r.solved);
    EXPECT_LT(worstTranslationError(r, s), 3e-3) << "pixels after first: " << pixels;
  }
}

TEST(LocalBundleAdjustment, WrongAssociationIsAnOutlier) {
  Scene s = makeScene(/*noisy=*/false, false);
  // Keyframe 3's observation of one landmark is replaced by another point 30 cm away.
  int wrong = -1;
  for (size_t i = 0; i < s.problem.observations.size(); ++i) {
    if (s.problem.observations[i].keyframe == 3) {
      s.problem.observations[i].p_kf += Eigen::Vector3d(0.3, 0.0, 0.0);
      wrong = static_cast<int>(i);
      break;
    }
  }
  ASSERT_GE(wrong, 0);
  const BundleResult r = adjustLocalBundle(s.problem);
  ASSERT_TRUE(r.solved);
  EXPECT_FALSE(r.inlier[wrong]);
  EXPECT_LT(worstTranslationError(r, s), 1e-3);
}

TEST(LocalBundleAdjustment, NoFixedKeyframeLeavesTheProblemAlone) {
  Scene s = makeScene(false, false);
  s.problem.keyframes[0].fixed = false;
  const BundleResult r = adjustLocalBundle(s.problem);
  EXPECT_FALSE(r.solved);
  EXPECT_TRUE(r.T_w_kf[1].isApprox(s.truth[1]));
}

TEST(LocalBundleAdjustment, InvalidObservationsAreLeftOut) {
  Scene s = makeScene(false, false);
  s.problem.observations[0].cov_kf = -Eigen::Matrix3d::Identity();
  s.problem.observations[1].landmark = 100000;
  s.problem.observations[2].p_kf.x() = std::nan("");
  const BundleResult r = adjustLocalBundle(s.problem);
  ASSERT_TRUE(r.solved);
  EXPECT_FALSE(r.inlier[0]);
  EXPECT_FALSE(r.inlier[1]);
  EXPECT_FALSE(r.inlier[2]);
  EXPECT_LT(worstTranslationError(r, s), 1e-6);
}

TEST(LocalBundleAdjustment, RelativePoseAloneSetsTheKeyframe) {
  // Two keyframes and no points: the free one lands where the measured relative pose puts it.
  BundleProblem problem;
  problem.camera = kinectVgaCamera();
  const Pose3 truth = poseAt(0.2, 5.0);
  problem.keyframes = {{Pose3::Identity(), true},
                       {perturbed(truth, Eigen::Vector3d(0.03, 0.01, -0.02), 2.0), false}};
  Matrix6d cov = Matrix6d::Identity() * 1e-6;
  problem.relative_poses.push_back({0, 1, truth.inverse(), cov});
  BundleOptions o;
  o.max_iterations = 30;
  const BundleResult r = adjustLocalBundle(problem, o);
  ASSERT_TRUE(r.solved);
  EXPECT_LT((r.T_w_kf[1].translation() - truth.translation()).norm(), 1e-6);
  EXPECT_LT(Eigen::AngleAxisd(r.T_w_kf[1].linear().transpose() * truth.linear()).angle(), 1e-6);
}

}  // namespace
}  // namespace pplvo::estimator
