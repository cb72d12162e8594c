#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pplvo/estimator/frame_error_estimator.h"
#include "pplvo/estimator/motion_chain.h"
#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::estimator {
namespace {

Pose3 poseOf(const Eigen::Vector3d& t, const Eigen::Vector3d& rotation_vector) {
  Pose3 T = Pose3::Identity();
  const double angle = rotation_vector.norm();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Frame k of a hand-held sway at 30 Hz (0.3 m, 20 deg, periods of 2-4 s).
Pose3 swayAt(int k) {
  const double s = k / 30.0;
  const Eigen::Vector3d t(0.3 * std::sin(2 * M_PI * s / 2.0), 0.2 * std::sin(2 * M_PI * s / 3.0),
                          0.1 * std::cos(2 * M_PI * s / 4.0));
  const Eigen::Vector3d r(0.35 * std::sin(2 * M_PI * s / 3.0), 0.2 * std::sin(2 * M_PI * s / 2.5),
                          0.1 * std::sin(2 * M_PI * s / 4.0));
  return poseOf(t, r);
}

/// A hand-held sway at 30 Hz (0.3 m, 20 deg, periods of 2-4 s: accelerations up to ~3 m/s^2,
/// jerks up to ~9 m/s^3) with a shared error of `sigma` on every frame's pose and an
/// estimation noise of `noise_sd` per axis on every relative motion, whose covariance is
/// reported; fed frame by frame to `estimator`. A block not in `measured` is the constant
/// velocity's (a prediction: smooth), as a weak estimate combined with it would give.
void feedSway(FrameErrorEstimator& estimator, const FrameErrorSigma& sigma, double noise_sd_t,
              double noise_sd_q, int frames, unsigned seed,
              MeasuredDirections measured = MeasuredDirections::all()) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const auto truth = swayAt;
  auto shared = [&] {
    Eigen::Vector3d t, r;
    for (int i = 0; i < 3; ++i) t[i] = sigma.t_m * n01(rng);
    for (int i = 0; i < 3; ++i) r[i] = sigma.rot_rad * n01(rng);
    return poseOf(t, r);
  };
  Matrix6d C = Matrix6d::Zero();
  C.topLeftCorner<3, 3>().diagonal().setConstant(noise_sd_t * noise_sd_t);
  C.bottomRightCorner<3, 3>().diagonal().setConstant(noise_sd_q * noise_sd_q);
  Pose3 prev = truth(0) * shared();
  for (int k = 1; k < frames; ++k) {
    const Pose3 curr = truth(k) * shared();
    Vector6d noise;
    for (int i = 0; i < 3; ++i) noise[i] = noise_sd_t * n01(rng);
    for (int i = 3; i < 6; ++i) noise[i] = noise_sd_q * n01(rng);
    Vector6d xi = poseToXi(prev.inverse() * curr) + noise;
    if (measured.translation_max_variance == 0) xi.head<3>() = Eigen::Vector3d(0.01, 0.0, 0.0);
    if (measured.rotation_max_variance == 0) xi.tail<3>() = Eigen::Vector3d(0.0, 0.001, 0.0);
    estimator.addMeasuredMotion(xiToPose(xi), C, std::nullopt, measured);
    prev = curr;
  }
}

constexpr double kDeg = M_PI / 180.0;

/// The same sway tracked against keyframes taken every `keyframe_every` frames, as the keyframe
/// tracker measures it: each frame's pose against its keyframe carries an error common to all
/// frames of that keyframe (its landmarks' errors, std `common_sd` per axis) and one of its own
/// (`own_sd`), and is published with the covariance of both; the motion is the difference of
/// two such estimates (the first after a keyframe: the estimate from the keyframe frame).
void feedSwayAgainstKeyframes(FrameErrorEstimator& estimator, const FrameErrorSigma& sigma,
                              double common_sd, double own_sd, int keyframe_every, int frames,
                              unsigned seed, bool give_reference = true) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const auto truth = swayAt;
  auto noise = [&](double sd_t, double sd_r) {
    Vector6d v;
    for (int i = 0; i < 3; ++i) v[i] = sd_t * n01(rng);
    for (int i = 3; i < 6; ++i) v[i] = 0.5 * sd_r * n01(rng);  // q_xyz: half the angle
    return v;
  };
  const double var = common_sd * common_sd + own_sd * own_sd;
  Matrix6d C = Matrix6d::Zero();  // the published covariance of an estimate against a keyframe
  C.topLeftCorner<3, 3>().diagonal().setConstant(var);
  C.bottomRightCorner<3, 3>().diagonal().setConstant(0.25 * var);
  int keyframe = 0;
  Vector6d common = Vector6d::Zero();
  Pose3 kf_measured = truth(0), prev_measured = truth(0);
  for (int k = 1; k < frames; ++k) {
    // Frame k's measured world pose: through its keyframe's measured pose.
    const Vector6d shared = noise(sigma.t_m, sigma.rot_rad);
    const Pose3 true_kf_k = truth(keyframe).inverse() * truth(k);
    const Vector6d err = shared + common + noise(own_sd, own_sd);
    const Pose3 measured = kf_measured * xiToPose(poseToXi(true_kf_k) + err);
    const bool held = give_reference && k - 1 != keyframe;
    estimator.addMeasuredMotion(prev_measured.inverse() * measured, C,
                                held ? std::optional<int64_t>(keyframe) : std::nullopt);
    prev_measured = measured;
    if (k % keyframe_every == 0) {
      keyframe = k;
      kf_measured = measured;
      common = noise(common_sd, common_sd);
    }
  }
}

TEST(FrameErrorEstimator, RecoversTheSharedErrorAndFollowsItWhenItDoubles) {
  // The estimation noise (0.3 mm, 0.005 rad of q) is known from the covariance and taken off.
  for (const double scale : {1.0, 2.0}) {
    const FrameErrorSigma truth{scale * 2e-3, scale * 0.06 * kDeg};
    FrameErrorEstimator estimator(400, 10);
    feedSway(estimator, truth, 3e-4, 5e-5, 402, 7);
    ASSERT_TRUE(estimator.ready());
    const FrameErrorSigma s = estimator.sigma();
    std::printf("shared error x%.0f: %.2f mm / %.3f deg estimated (truth %.2f / %.3f)\n", scale,
                1e3 * s.t_m, s.rot_rad / kDeg, 1e3 * truth.t_m, truth.rot_rad / kDeg);
    // 400 samples of a 3-vector: the MAD-based variance is within ~10 % (one sigma ~5 %).
    EXPECT_NEAR(s.t_m, truth.t_m, 0.12 * truth.t_m);
    EXPECT_NEAR(s.rot_rad, truth.rot_rad, 0.12 * truth.rot_rad);
  }
}

TEST(FrameErrorEstimator, EachBlockIsReadFromTheMotionsThatMeasuredIt) {
  // Weak estimates that fixed only the rotation, the prediction (smooth) giving the whole
  // translation. The rotation's shared error is read from them; the translation is not ready
  // and reads none, where taking the predicted translation as measured would read ~0 as the
  // camera's error.
  const FrameErrorSigma truth{2e-3, 0.06 * kDeg};
  FrameErrorEstimator rotation_only(400, 10), both(400, 10);
  const double all = MeasuredDirections::all().rotation_max_variance;
  feedSway(rotation_only, truth, 3e-4, 5e-5, 402, 7, MeasuredDirections{0.0, all});
  feedSway(both, truth, 3e-4, 5e-5, 402, 7, MeasuredDirections::all());
  EXPECT_TRUE(rotation_only.rotationReady());
  EXPECT_FALSE(rotation_only.translationReady());
  EXPECT_FALSE(rotation_only.ready());
  EXPECT_EQ(rotation_only.sigma().t_m, 0.0);
  EXPECT_NEAR(rotation_only.sigma().rot_rad, truth.rot_rad, 0.12 * truth.rot_rad);
  // The rotation reads the same whether the translation was measured or not.
  EXPECT_DOUBLE_EQ(rotation_only.sigma().rot_rad, both.sigma().rot_rad);

  // Blocks measured on alternate frames never make three in a row: no sample in either.
  FrameErrorEstimator alternating(400, 1);
  const Matrix6d C = Matrix6d::Identity() * 1e-10;
  for (int k = 0; k < 20; ++k) {
    const MeasuredDirections directions{k % 2 == 0 ? all : 0.0, k % 2 == 1 ? all : 0.0};
    alternating.addMeasuredMotion(poseOf({0.01, 0, 0}, {0, 0.01, 0}), C, std::nullopt,
                                  directions);
  }
  EXPECT_EQ(alternating.samples(), 0);
  EXPECT_FALSE(alternating.translationReady());
  EXPECT_FALSE(alternating.rotationReady());
}

TEST(FrameErrorEstimator, ABlockIsReadInTheDirectionsItsMotionsMeasured) {
  // A corridor along x: the motions' translation along it is the prediction's (constant, with
  // the velocity model's 20 mm variance), across it measured (0.3 mm) with a shared error of
  // 2 mm per axis. Read in the measured directions, the shared error is recovered; read over
  // all three axes, the prediction's variance along x hides it entirely.
  const double sd_t = 3e-4, shared_t = 2e-3;
  FrameErrorEstimator across(400, 10), whole(400, 10);
  std::mt19937 rng(21);
  std::normal_distribution<double> n01(0.0, 1.0);
  Matrix6d C = Matrix6d::Zero();
  C.diagonal() << 4e-4, sd_t * sd_t, sd_t * sd_t, 1e-10, 1e-10, 1e-10;
  Pose3 prev = swayAt(0);
  for (int k = 1; k < 402; ++k) {
    Eigen::Vector3d e;
    for (int i = 0; i < 3; ++i) e[i] = shared_t * n01(rng);
    Pose3 curr = swayAt(k);
    curr.translation() += e;
    Vector6d xi = poseToXi(prev.inverse() * curr);
    for (int i = 1; i < 3; ++i) xi[i] += sd_t * n01(rng);
    xi[0] = 0.01;  // along the corridor: the prediction's
    const MeasuredDirections measured{1e-4, 2.5e-5};
    across.addMeasuredMotion(xiToPose(xi), C, std::nullopt, measured);
    whole.addMeasuredMotion(xiToPose(xi), C, std::nullopt, MeasuredDirections::all());
    prev = curr;
  }
  std::printf("corridor-like motions: %.2f mm read across the corridor, %.2f mm over all axes "
              "(truth %.2f)\n",
              1e3 * across.sigma().t_m, 1e3 * whole.sigma().t_m, 1e3 * shared_t);
  EXPECT_TRUE(across.translationReady());
  EXPECT_NEAR(across.sigma().t_m, shared_t, 0.15 * shared_t);
  EXPECT_LT(whole.sigma().t_m, 0.5 * shared_t);
}

TEST(FrameErrorEstimator, NoSharedErrorGivesNoneBeyondTheEstimationNoise) {
  // Only estimation noise (1 mm, 0.002 of q per axis), reported in the covariance: what is
  // left is far below that noise (the motion's jerk alone).
  FrameErrorEstimator estimator(400, 10);
  feedSway(estimator, FrameErrorSigma{}, 1e-3, 2e-3, 402, 3);
  const FrameErrorSigma s = estimator.sigma();
  EXPECT_LT(s.t_m, 0.3e-3);
  EXPECT_LT(s.rot_rad, 0.3 * 4e-3);
}

TEST(FrameErrorEstimator, FramesAgainstAKeyframeReadTheirOwnErrorsNotAsShared) {
  // Each frame against its keyframe: 0.7 mm (and mrad) common to the keyframe's frames, 0.7 its
  // own, the published covariance holding both. The motions' errors are the differences of the
  // own parts (1 mm, as published): no shared error. Read as independent motions, the
  // alternating errors look like one of ~0.4 mm. What is left with the reference (~0.2 mm) is
  // the keyframe switches (their samples keep the independent model: larger, never smaller).
  FrameErrorEstimator estimator(1200, 10), as_independent(1200, 10);
  feedSwayAgainstKeyframes(estimator, FrameErrorSigma{}, 0.7e-3, 0.7e-3, 15, 1202, 5);
  feedSwayAgainstKeyframes(as_independent, FrameErrorSigma{}, 0.7e-3, 0.7e-3, 15, 1202, 5, false);
  const FrameErrorSigma none = estimator.sigma(), spurious = as_independent.sigma();
  std::printf("no shared error, against keyframes: %.2f mm / %.3f deg estimated (%.2f / %.3f "
              "read as independent motions)\n",
              1e3 * none.t_m, none.rot_rad / kDeg, 1e3 * spurious.t_m, spurious.rot_rad / kDeg);
  EXPECT_LT(none.t_m, 0.3e-3);
  EXPECT_LT(none.rot_rad, 0.3e-3);
  EXPECT_GT(spurious.t_m, 0.4e-3);
  EXPECT_GT(spurious.rot_rad, 0.4e-3);

  // A shared error of 2 mm / 0.06 deg on top is recovered (within 15 %; one sigma ~5 %).
  for (const double scale : {1.0, 2.0}) {
    const FrameErrorSigma truth{scale * 2e-3, scale * 0.06 * kDeg};
    FrameErrorEstimator with_shared(400, 10);
    feedSwayAgainstKeyframes(with_shared, truth, 0.7e-3, 0.7e-3, 15, 402, 9);
    const FrameErrorSigma s = with_shared.sigma();
    std::printf("shared error x%.0f against keyframes: %.2f mm / %.3f deg (truth %.2f / %.3f)\n",
                scale, 1e3 * s.t_m, s.rot_rad / kDeg, 1e3 * truth.t_m, truth.rot_rad / kDeg);
    EXPECT_NEAR(s.t_m, truth.t_m, 0.15 * truth.t_m);
    EXPECT_NEAR(s.rot_rad, truth.rot_rad, 0.15 * truth.rot_rad);
  }
}

TEST(FrameErrorEstimator, OneWrongMotionDoesNotSetTheWindowsError) {
  // A shared error of 2 mm, and one motion 5 cm off (a wrong estimate): its three samples are
  // clipped at 10 times the median, so the window's estimate moves by less than a third.
  FrameErrorEstimator clean(60, 10), with_jump(60, 10);
  const FrameErrorSigma truth{2e-3, 0.06 * kDeg};
  feedSway(clean, truth, 3e-4, 5e-5, 62, 11);
  feedSway(with_jump, truth, 3e-4, 5e-5, 30, 11);
  const Matrix6d C = Matrix6d::Identity() * 1e-10;
  with_jump.addMeasuredMotion(poseOf({0.06, 0.0, 0.0}, {0, 0, 0}), C);
  feedSway(with_jump, truth, 3e-4, 5e-5, 32, 12);
  EXPECT_LT(with_jump.sigma().t_m, 1.33 * clean.sigma().t_m);
  EXPECT_GT(with_jump.sigma().t_m, 0.7 * truth.t_m);
}

TEST(FrameErrorEstimator, GapsRestartTheDifferencesAndTheWindowIsBounded) {
  FrameErrorEstimator estimator(30, 10);
  const Pose3 step = poseOf({0.01, 0, 0}, {0, 0.01, 0});
  const Matrix6d C = Matrix6d::Identity() * 1e-10;
  estimator.addMeasuredMotion(step, C);
  estimator.addMeasuredMotion(step, C);
  EXPECT_EQ(estimator.samples(), 0);  // three motions make one sample
  estimator.addGap();
  estimator.addMeasuredMotion(poseOf({0.5, 0, 0}, {0, 0.3, 0}), C);  // a jump after a gap
  estimator.addMeasuredMotion(step, C);
  EXPECT_EQ(estimator.samples(), 0);
  for (int k = 0; k < 100; ++k) estimator.addMeasuredMotion(step, C);
  EXPECT_EQ(estimator.samples(), 30);
  EXPECT_TRUE(estimator.ready());
  EXPECT_EQ(estimator.sigma().t_m, 0.0);  // the jump's differences left the window
  EXPECT_EQ(estimator.sigma().rot_rad, 0.0);
}

TEST(FrameErrorEstimator, NonFiniteMotionsAreAGap) {
  FrameErrorEstimator estimator(30, 1);
  const Matrix6d C = Matrix6d::Identity() * 1e-10;
  Pose3 bad = Pose3::Identity();
  bad.translation().x() = std::nan("");
  for (int k = 0; k < 10; ++k) {
    estimator.addMeasuredMotion(Pose3::Identity(), C);
    estimator.addMeasuredMotion(bad, C);
  }
  EXPECT_EQ(estimator.samples(), 0);
  EXPECT_FALSE(estimator.ready());
  EXPECT_EQ(estimator.sigma().t_m, 0.0);
}

TEST(MotionChain, PublishesTheOnlineSharedErrorOnceItIsReady) {
  // Motions that alternate by +-3 mm along x (a rough trajectory): once enough of them are
  // in, the published 2 Q is the online estimator's, before that the configured sigma's.
  MotionChainOptions opts;
  opts.frame_error_min_samples = 5;
  opts.frame_error_sigma_t_m = 1e-3;  // used until then
  MotionChain chain(opts);
  chain.initialise(0);
  FrameErrorEstimator reference(opts.frame_error_window, opts.frame_error_min_samples);
  PoseEstimate e;
  e.status = EstimateStatus::kOk;
  e.covariance = Matrix6d::Identity() * 1e-10;
  for (int64_t s = 1; s <= 20; ++s) {
    const double jitter = (s % 2 == 0 ? 1 : -1) * 3e-3;
    e.T_curr_prev = poseOf({0.01 + jitter, 0, 0}, {0, 0, 0}).inverse();
    const MotionChainOutput out = chain.update(s, e);
    reference.addMeasuredMotion(out.T_prev_curr,
                                invertedPoseCovariance(e.T_curr_prev, e.covariance));
    const FrameErrorSigma expected =
        reference.ready() ? reference.sigma() : FrameErrorSigma{1e-3, 0.0};
    EXPECT_NEAR(out.frame_error_covariance(0, 0), 2 * expected.t_m * expected.t_m, 1e-12) << s;
    EXPECT_TRUE((out.covariance_prev_curr - out.frame_error_covariance)
                    .isApprox(invertedPoseCovariance(e.T_curr_prev, e.covariance), 1e-6))
        << s;
  }
  EXPECT_GT(chain.frameError().t_m, 1e-3);  // the data's, not the starting value
}

TEST(MotionChain, WeakEstimatesGiveTheSharedErrorInTheDirectionsTheyMeasure) {
  // A corridor's weak estimates: nothing along x, the translation across it and the rotation
  // fixed; the rotation rough by +-0.05 deg about z, the translation smooth. Combined with the
  // prediction, they give the shared error online: the rotation's, and none across the
  // corridor. With too few rows to tell a wrong match (min_residuals) a weak estimate
  // measures nothing and the configured values stay.
  for (const int rows : {40, 8}) {
    MotionChainOptions opts;
    opts.frame_error_min_samples = 5;
    opts.frame_error_sigma_t_m = 3e-3;
    opts.frame_error_sigma_rot_deg = 0.5;
    MotionChain chain(opts);
    chain.initialise(0);
    PoseEstimate e;
    e.status = EstimateStatus::kUncertain;
    e.n_residuals = rows;
    e.covariance = Matrix6d::Identity() * 1e-10;
    e.covariance(0, 0) = 1.0;  // along the corridor: unconstrained
    e.max_translation_variance_m2 = 1.0;
    e.max_rotation_variance = 1e-10;
    for (int64_t s = 1; s <= 30; ++s) {
      const double jitter = (s % 2 == 0 ? 1 : -1) * 0.05 * kDeg;
      e.T_curr_prev = poseOf({0.0, 0.0, 0.0}, {0, 0, jitter}).inverse();
      const MotionChainOutput out = chain.update(s, e);
      ASSERT_EQ(out.status, TrackingStatus::kTracking) << s;
    }
    const bool measured = rows >= opts.estimator.min_residuals;
    EXPECT_EQ(chain.frameErrorSource().translation_online, measured);
    EXPECT_EQ(chain.frameErrorSource().rotation_online, measured);
    if (measured) {
      EXPECT_LT(chain.frameError().t_m, 1e-5);
      // Motions alternating by +-j have second differences of 4 j: |d|^2 / 3 = 16 j^2 / 3 per
      // axis = 20 sigma^2, sigma = 0.516 j (the combination keeps the estimate's rotation).
      EXPECT_NEAR(chain.frameError().rot_rad, 0.516 * 0.05 * kDeg, 0.02 * 0.05 * kDeg);
    } else {
      EXPECT_DOUBLE_EQ(chain.frameError().t_m, 3e-3);
      EXPECT_DOUBLE_EQ(chain.frameError().rot_rad, 0.5 * kDeg);
    }
  }
}

}  // namespace
}  // namespace pplvo::estimator
