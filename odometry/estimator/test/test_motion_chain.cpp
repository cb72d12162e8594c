#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

#include "pplvo/core/config_visitor.h"
#include "pplvo/estimator/motion_chain.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "synthetic_scene.h"

namespace pplvo::estimator {
namespace {

PoseEstimate goodEstimate(const Pose3& T) {
  PoseEstimate e;
  e.status = EstimateStatus::kOk;
  e.T_curr_prev = T;
  Vector6d sd;
  sd << 1e-3, 1e-3, 2e-3, 5e-4, 5e-4, 5e-4;
  e.covariance = Matrix6d(sd.cwiseProduct(sd).asDiagonal());
  return e;
}

PoseEstimate rejectedEstimate() {
  PoseEstimate e;
  e.status = EstimateStatus::kDegenerate;
  e.T_curr_prev = testing::typicalMotion().inverse();  // must not be used
  return e;
}

/// A weak estimate of T that measures every direction to 0.1 mm / 0.1 mrad but `axis` (of
/// xi), which it knows to `variance`.
PoseEstimate weakEstimate(const Pose3& T, int axis, double variance,
                          EstimateStatus status = EstimateStatus::kUncertain) {
  PoseEstimate e;
  e.status = status;
  e.T_curr_prev = T;
  e.covariance = Matrix6d::Identity() * 1e-8;
  e.covariance(axis, axis) = variance;
  return e;
}

/// A chain that has measured one motion, M.
MotionChain chainMovingBy(const Pose3& M, const MotionChainOptions& o) {
  MotionChain chain(o);
  chain.update(0, goodEstimate(Pose3::Identity()));
  chain.update(1, goodEstimate(M));
  return chain;
}

void expectPoseNear(const Pose3& a, const Pose3& b, double tol = 1e-9) {
  EXPECT_LT((a.matrix() - b.matrix()).norm(), tol) << a.matrix() << "\n" << b.matrix();
}

// An accepted estimate whose residuals spread less than modelled publishes its covariance at
// the measured spread, and the shared error is read against what is published; the poses and
// the decisions' shared error are those of the model's covariance, with the option or without.
TEST(MotionChain, PublishesTheCovarianceAtTheMeasuredSpread) {
  const Pose3 M = testing::typicalMotion();
  MotionChainOptions on, off;
  off.publish_measured_spread = false;
  MotionChain with(on), without(off);
  FrameErrorSigma published_with, published_without;  // of the last frame
  for (int k = 0; k < 40; ++k) {
    // A sway with a shared error the model's covariance already covers: read as none
    // against it, as some against the quarter that is published.
    const double s = (k % 2 == 0 ? 1.0 : -1.0) * 0.6e-3;
    Pose3 T = M;
    T.translation() += Eigen::Vector3d(s, -s, s);
    PoseEstimate e = goodEstimate(T);
    e.covariance_at_measured_spread = 0.25 * e.covariance;
    const MotionChainOutput a = with.update(k, e);
    const MotionChainOutput b = without.update(k, e);
    EXPECT_TRUE(a.T_w_c.matrix() == b.T_w_c.matrix());  // bit for bit
    EXPECT_EQ(a.status, b.status);
    published_with = a.frame_error;
    published_without = b.frame_error;
    if (k == 0) continue;
    const Matrix6d published = a.covariance_prev_curr - a.frame_error_covariance;
    EXPECT_LT((published - invertedPoseCovariance(T, 0.25 * e.covariance)).norm(),
              1e-12 * e.covariance.norm());
    EXPECT_LT((b.covariance_prev_curr - b.frame_error_covariance -
               invertedPoseCovariance(T, e.covariance))
                  .norm(),
              1e-12 * e.covariance.norm());
  }
  EXPECT_EQ(with.frameError().t_m, without.frameError().t_m);  // the decisions' reading
  EXPECT_GT(published_with.t_m, published_without.t_m);
  EXPECT_EQ(published_without.t_m, without.frameError().t_m);
}

TEST(MotionChain, StateMachineAndDecayingVelocity) {
  MotionChainOptions opts;
  opts.velocity_decay = 0.5;
  opts.max_velocity_model_frames = 3;
  MotionChain tracker(opts);
  const Pose3 M = testing::typicalMotion();  // T_curr_prev of every good frame
  MotionChainOutput out = tracker.initialise(0);
  EXPECT_EQ(out.status, TrackingStatus::kFirstFrame);
  Pose3 T_w_c = Pose3::Identity();
  int64_t seq = 1;
  for (int i = 0; i < 2; ++i, ++seq) {
    out = tracker.update(seq, goodEstimate(M));
    T_w_c = T_w_c * M.inverse();
    EXPECT_EQ(out.status, TrackingStatus::kTracking);
    expectPoseNear(out.T_w_c, T_w_c);
  }
  // Rejections: decay^k times the last good motion, translation scaled exactly.
  for (int k = 1; k <= 3; ++k, ++seq) {
    out = tracker.update(seq, rejectedEstimate());
    EXPECT_EQ(out.status, TrackingStatus::kVelocityModel) << k;
    EXPECT_EQ(out.consecutive_rejections, k);
    const double s = std::pow(0.5, k);
    EXPECT_LT((out.T_curr_prev.translation() - s * M.translation()).norm(), 1e-12);
    EXPECT_NEAR(rotationAngle(out.T_curr_prev.linear()), s * rotationAngle(M.linear()), 1e-9);
    T_w_c = T_w_c * out.T_curr_prev.inverse();
    expectPoseNear(out.T_w_c, T_w_c);
    EXPECT_TRUE(out.covariance.allFinite());
  }
  // Exhausted: LOST, pose held.
  for (int k = 0; k < 2; ++k, ++seq) {
    out = tracker.update(seq, rejectedEstimate());
    EXPECT_EQ(out.status, TrackingStatus::kLost);
    expectPoseNear(out.T_w_c, T_w_c);
    expectPoseNear(out.T_curr_prev, Pose3::Identity());
    ASSERT_EQ(out.window.size(), 1u);
    EXPECT_EQ(out.window.back().seq, seq);
  }
  // Good estimate: REINITIALISED for one frame, then TRACKING.
  out = tracker.update(seq++, goodEstimate(M));
  EXPECT_EQ(out.status, TrackingStatus::kReinitialised);
  T_w_c = T_w_c * M.inverse();
  expectPoseNear(out.T_w_c, T_w_c);
  out = tracker.update(seq++, goodEstimate(M));
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  // A rejection after VELOCITY_MODEL recovery goes back to TRACKING (not REINITIALISED).
  out = tracker.update(seq++, rejectedEstimate());
  EXPECT_EQ(out.status, TrackingStatus::kVelocityModel);
  out = tracker.update(seq++, goodEstimate(M));
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  // Predicted motion for the next frame is the last good motion.
  expectPoseNear(tracker.predictedMotion(), M, 1e-12);
}

TEST(MotionChain, WindowCovarianceGrowsWithAgeAndMatchesDirectPropagation) {
  MotionChainOptions opts;
  opts.window_length = 10;
  MotionChain tracker(opts);
  tracker.initialise(100);
  const Pose3 M = testing::typicalMotion();
  const PoseEstimate good = goodEstimate(M);
  MotionChainOutput out;
  for (int64_t s = 101; s <= 115; ++s) out = tracker.update(s, good);
  ASSERT_EQ(out.window.size(), 10u);
  EXPECT_EQ(out.window.front().seq, 106);
  EXPECT_EQ(out.window.back().seq, 115);
  EXPECT_EQ(out.window.back().max_translation_variance_m2, 0.0);
  for (size_t i = 0; i + 1 < out.window.size(); ++i) {
    EXPECT_GT(out.window[i].max_translation_variance_m2,
              out.window[i + 1].max_translation_variance_m2);
  }
  // Frame 114 -> 115: exactly the last estimate's covariance.
  EXPECT_LT((out.window[8].covariance - good.covariance).norm(), 1e-15);
  // Oldest entry (106 -> 115, 9 steps) equals the eq. 24 recursion done here.
  Pose3 T = M;
  Matrix6d P = good.covariance;
  for (int k = 1; k < 9; ++k) {
    P = propagateCompositionCovariance(T, P, M, good.covariance);
    T = M * T;
  }
  EXPECT_LT((out.window[0].covariance - P).norm(), 1e-12 * P.norm() + 1e-18);
  expectPoseNear(out.window[0].T_curr_frame, T, 1e-9);
  // A velocity-model step inflates every entry above the velocity-model noise.
  out = tracker.update(116, rejectedEstimate());
  EXPECT_EQ(out.status, TrackingStatus::kVelocityModel);
  for (size_t i = 0; i + 1 < out.window.size(); ++i) {
    EXPECT_GE(out.window[i].max_translation_variance_m2,
              opts.velocity_model_sigma_t_m * opts.velocity_model_sigma_t_m * 0.99);
  }
}

TEST(MotionChain, RelativePoseForMessagesIsPrevCurr) {
  MotionChainOptions opts;
  opts.frame_error_online = false;
  opts.frame_error_sigma_t_m = opts.frame_error_sigma_rot_deg = 0;  // the estimate's alone
  MotionChain tracker(opts);
  tracker.initialise(0);
  const Pose3 M = testing::typicalMotion();
  const MotionChainOutput out = tracker.update(1, goodEstimate(M));
  expectPoseNear(out.T_prev_curr, M.inverse(), 1e-12);
  EXPECT_TRUE(out.covariance_prev_curr.allFinite());
  EXPECT_NEAR(out.covariance_prev_curr.trace(), out.covariance.trace(),
              0.2 * out.covariance.trace());
}

TEST(MotionChain, PerFrameSharedErrorEntersThePublishedCovarianceOnce) {
  // Each frame's pose has its own error (2 mm, 0.06 deg per axis): a relative pose gains it
  // from both frames (2 Q), and so does every window transform, without accumulating along
  // the chain; the estimate's own covariance (the EKF's Q) and the pose do not change.
  MotionChainOptions plain, with_error;
  plain.frame_error_online = with_error.frame_error_online = false;  // the fixed sigmas
  plain.frame_error_sigma_t_m = plain.frame_error_sigma_rot_deg = 0;
  with_error.frame_error_sigma_t_m = 2e-3;
  with_error.frame_error_sigma_rot_deg = 0.06;
  MotionChain a(plain), b(with_error);
  MotionChainOutput out_a = a.initialise(0), out_b = b.initialise(0);
  EXPECT_EQ(out_b.covariance_prev_curr, Matrix6d::Zero());  // first frame: no relative pose
  const Pose3 M = testing::typicalMotion();
  for (int64_t s = 1; s <= 6; ++s) {
    out_a = a.update(s, goodEstimate(M));
    out_b = b.update(s, goodEstimate(M));
  }
  const Matrix6d added = out_b.covariance_prev_curr - out_a.covariance_prev_curr;
  const double var_t = 2 * 2e-3 * 2e-3;
  const double half_angle = 0.5 * 0.06 * M_PI / 180;
  Vector6d expected;
  expected << var_t, var_t, var_t, Eigen::Vector3d::Constant(2 * half_angle * half_angle);
  EXPECT_LT((added - Matrix6d(expected.asDiagonal())).norm(), 1e-15);
  EXPECT_LT((added - frameErrorCovariance(with_error)).norm(), 1e-18);
  EXPECT_EQ(out_b.covariance, out_a.covariance);
  EXPECT_EQ(out_b.T_w_c.matrix(), out_a.T_w_c.matrix());
  ASSERT_EQ(out_a.window.size(), out_b.window.size());
  for (size_t i = 0; i + 1 < out_b.window.size(); ++i) {
    EXPECT_NEAR(
        out_b.window[i].max_translation_variance_m2 - out_a.window[i].max_translation_variance_m2,
        var_t, 1e-15);
  }
  EXPECT_EQ(out_b.window.back().max_translation_variance_m2, 0.0);  // the current frame
  const FramePose published = toFramePose(out_b);
  EXPECT_EQ(published.rel_covariance, out_b.covariance_prev_curr);
  EXPECT_NEAR(published.max_translation_variance_m2,
              toFramePose(out_a).max_translation_variance_m2 + var_t, 1e-15);
}

// End to end: synthetic correspondences through track(); degenerate frames hand over to the
// velocity model without NaN, and tracking resumes.
TEST(MotionChain, TrackSyntheticWithDegenerateFrames) {
  const PinholeCamera cam = testing::testCamera();
  testing::SceneConfig cfg;
  testing::SceneGenerator gen(cam, cfg, 91);
  MotionChain tracker;
  tracker.initialise(0);
  const Pose3 M = testing::typicalMotion();
  Pose3 T_w_true = Pose3::Identity();
  MotionChainOutput out;
  for (int64_t s = 1; s <= 12; ++s) {
    const bool degenerate = (s == 6 || s == 7);
    Correspondences c;
    if (degenerate) {
      c.planes.push_back(gen.planeMatch(testing::SceneGenerator::roomPlanes()[0], M));
    } else {
      c = gen.generate(M);
    }
    out = tracker.track(s, c, cam);
    T_w_true = T_w_true * M.inverse();
    EXPECT_TRUE(out.T_w_c.matrix().allFinite());
    EXPECT_TRUE(out.covariance.allFinite());
    for (const WindowEntry& w : out.window) {
      EXPECT_TRUE(w.covariance.allFinite());
      EXPECT_TRUE(std::isfinite(w.max_translation_variance_m2));
    }
    EXPECT_EQ(out.status, degenerate ? TrackingStatus::kVelocityModel : TrackingStatus::kTracking)
        << s;
  }
  // Two velocity-model frames (0.8 and 0.64 of the motion) leave a bounded drift.
  EXPECT_LT((out.T_w_c.translation() - T_w_true.translation()).norm(), 0.03);
}

/// A plain wall 3 m ahead and a door's two vertical edges, seen after the motion M:
/// 3 + 2 x 2 = 7 residual rows, translation along the edges unobservable.
Correspondences wallWithADoor(testing::SceneGenerator& gen, const PinholeCamera& cam,
                              const Pose3& M) {
  const Eigen::Vector4d wall(0, 0, -1, 3.0);  // z = 3 m in front of the previous camera
  const Eigen::Vector3d edges[2][2] = {{{-0.45, -0.9, 3.0}, {-0.45, 0.9, 3.0}},
                                       {{0.45, -0.9, 3.0}, {0.45, 0.9, 3.0}}};
  Correspondences c;
  c.planes.push_back(gen.planeMatch(wall, M));
  for (const auto& edge : edges) {
    c.lines.push_back(gen.lineMatch(
        edge[0],
        gen.backprojectionCov(cam.project(edge[0]).x(), cam.project(edge[0]).y(), edge[0].z()),
        edge[1],
        gen.backprojectionCov(cam.project(edge[1]).x(), cam.project(edge[1]).y(), edge[1].z()), M));
  }
  return c;
}

// A weak estimate (a plain wall and a door's two edges, a model twice the noise drawn) is
// published at the spread of its solve with the prediction as a prior: smaller in the
// rotation, which the wall and the edges measure; the same along the edges, which the
// prediction holds; the world poses bit for bit those with the option off.
TEST(MotionChain, WeakEstimatesArePublishedAtTheirSolvesMeasuredSpread) {
  const PinholeCamera cam = testing::testCamera();
  testing::SceneGenerator gen(cam, testing::SceneConfig{}, 93);
  const Pose3 M =
      makePose({0.004, 0.0, 0.002},
               Eigen::Quaterniond(Eigen::AngleAxisd(0.8 * M_PI / 180.0, Eigen::Vector3d::UnitY())));
  MotionChainOptions off;
  off.publish_measured_spread = false;
  MotionChain with, without(off);
  with.initialise(0);
  without.initialise(0);
  double rotation_ratio = 0.0, along_edges_ratio = 0.0;
  int frames = 0;
  for (int64_t s = 1; s <= 12; ++s) {
    Correspondences c = wallWithADoor(gen, cam, M);
    for (LineMatch3D2D& m : c.lines) {
      m.sigma_px *= 2.0;
      m.L_prev.cov1 *= 4.0;
      m.L_prev.cov2 *= 4.0;
    }
    for (PlaneMatch3D3D& m : c.planes) {
      m.prev.cov *= 4.0;
      m.curr.cov *= 4.0;
    }
    const MotionChainOutput a = with.track(s, c, cam);
    const MotionChainOutput b = without.track(s, c, cam);
    ASSERT_EQ(a.status, TrackingStatus::kTracking);
    ASSERT_FALSE(a.estimate.accepted());
    EXPECT_TRUE(a.T_w_c.matrix() == b.T_w_c.matrix());  // bit for bit
    const Matrix6d pa = a.covariance_prev_curr - a.frame_error_covariance;
    const Matrix6d pb = b.covariance_prev_curr - b.frame_error_covariance;
    rotation_ratio += pa.bottomRightCorner<3, 3>().trace() / pb.bottomRightCorner<3, 3>().trace();
    along_edges_ratio += pa(1, 1) / pb(1, 1);
    ++frames;
  }
  rotation_ratio /= frames;
  along_edges_ratio /= frames;
  std::printf(
      "weak estimates published at their spread: rotation %.2f, along the edges %.2f of "
      "the model's\n",
      rotation_ratio, along_edges_ratio);
  EXPECT_LT(rotation_ratio, 0.75);  // 0.57 measured; 1 with the model's floor
  EXPECT_NEAR(along_edges_ratio, 1.0, 0.05);
}

TEST(MotionChain, PlainWallWithADoorIsTrackedFromTwoEdgesAndThePlane) {
  // A plain wall and a door's two vertical edges: 3 + 2 x 2 = 7 residual rows, fewer than an
  // estimate needs to stand alone, and translation along the edges unobservable. The five
  // directions the wall and the edges do constrain (all rotation) come from them, the sixth
  // from the prediction: every frame is tracked, the turn is kept, and the covariance is
  // largest along the edges.
  const PinholeCamera cam = testing::testCamera();
  testing::SceneConfig cfg;
  testing::SceneGenerator gen(cam, cfg, 93);
  const Pose3 M =
      makePose({0.004, 0.0, 0.002},  // a turn of 0.8 deg a frame about the vertical
               Eigen::Quaterniond(Eigen::AngleAxisd(0.8 * M_PI / 180.0, Eigen::Vector3d::UnitY())));
  MotionChain tracker;
  tracker.initialise(0);
  Pose3 T_w_true = Pose3::Identity();
  MotionChainOutput out;
  constexpr int kFrames = 30;
  for (int64_t s = 1; s <= kFrames; ++s) {
    out = tracker.track(s, wallWithADoor(gen, cam, M), cam);
    T_w_true = T_w_true * M.inverse();
    EXPECT_EQ(out.status, TrackingStatus::kTracking) << "frame " << s;
    EXPECT_LT(out.estimate.n_residuals, PoseEstimatorOptions{}.min_residuals);
    EXPECT_GE(out.estimate.irls_iterations, 1);
  }
  EXPECT_EQ(tracker.fusedEstimates(), kFrames);
  const double turn_error_deg =
      rotationAngle(out.T_w_c.linear().transpose() * T_w_true.linear()) * 180.0 / M_PI;
  std::printf("24 deg turn tracked from a wall and two edges: %.2f deg off\n", turn_error_deg);
  // The wall's normal noise (3 mrad per axis on each of the two planes of a frame) random-walks
  // to about 1.9 deg rms over 30 frames (measured 2.75 with the information-form combination,
  // 0.61 solved with the prior); a chain that loses these frames loses
  // the whole turn (24 deg).
  EXPECT_LT(turn_error_deg, 4.0);
  // The last motion's covariance: largest along the edges (camera y).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(
      out.covariance.topLeftCorner<3, 3>());
  EXPECT_GT(std::abs(translation.eigenvectors().col(2).y()), 0.9);
}

TEST(MotionChain, AWeakFrameIsGatedOnWhatItsSolveWithThePriorMeasured) {
  // The wall and the door measure five directions; their solve with the prediction as a
  // prior is what the prediction gate reads, along those directions (the solve alone wanders
  // kilometres along the edges): a frame that pitches 10 deg at once (a wrong association;
  // the prediction's spread is 1.1 deg) is refused and the velocity model carries it, the
  // next frames are combined again.
  const PinholeCamera cam = testing::testCamera();
  testing::SceneGenerator gen(cam, testing::SceneConfig{}, 95);
  const Pose3 M = makePose({0.004, 0.0, 0.002}, Eigen::Quaterniond::Identity());
  const Pose3 jump = makePose(
      {0.004, 0.0, 0.002},
      Eigen::Quaterniond(Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitX())));
  MotionChain tracker;
  tracker.initialise(0);
  for (int64_t s = 1; s <= 12; ++s) {
    const MotionChainOutput out = tracker.track(s, wallWithADoor(gen, cam, s == 8 ? jump : M), cam);
    EXPECT_EQ(out.status, s == 8 ? TrackingStatus::kVelocityModel : TrackingStatus::kTracking)
        << "frame " << s;
    EXPECT_FALSE(out.estimate.accepted());
  }
  EXPECT_EQ(tracker.gatedEstimates(), 1);
  EXPECT_EQ(tracker.fusedEstimates(), 11);
}
TEST(MotionChain, FramePoseForPublishing) {
  MotionChain tracker;
  tracker.initialise(10);
  const Pose3 M = testing::typicalMotion();
  tracker.update(11, goodEstimate(M));
  const MotionChainOutput out = tracker.update(12, goodEstimate(M));
  const FramePose p = toFramePose(out);
  EXPECT_EQ(p.seq, 12);
  EXPECT_EQ(p.status, TrackingStatus::kTracking);
  expectPoseNear(p.T_prev_curr, M.inverse(), 1e-12);
  ASSERT_EQ(p.window.size(), 2u);  // frames 10 and 11, oldest first; not the current one
  EXPECT_EQ(p.window[0].seq, 10);
  EXPECT_EQ(p.window[1].seq, 11);
  EXPECT_GT(p.window[0].max_translation_variance_m2, p.window[1].max_translation_variance_m2);
}

TEST(MotionChain, OptionsRoundTripThroughYaml) {
  MotionChainOptions o;
  o.velocity_decay = 0.5;
  o.estimator.use_lines = false;
  o.estimator.max_translation_variance_m2 = 3e-4;
  const auto tracker = [](auto& v, MotionChainOptions& x) {
    v.section("tracker", "tracker", [&] { visit(v, x); });
  };
  const std::string dump = config::dumpConfig(o, tracker, "");
  MotionChainOptions back;
  EXPECT_TRUE(config::readConfig(YAML::Load(dump), &back, tracker).empty());
  EXPECT_EQ(back.velocity_decay, 0.5);
  EXPECT_FALSE(back.estimator.use_lines);
  EXPECT_EQ(back.estimator.max_translation_variance_m2, 3e-4);

  MotionChainOptions ignored;
  EXPECT_EQ(config::readConfig(YAML::Load("tracker: {velocity_decay: x, no_such_key: 1}"), &ignored,
                               tracker)
                .size(),
            2u);
}

}  // namespace
}  // namespace pplvo::estimator

namespace pplvo::estimator {
namespace {

// fuse_weak_estimates: an estimate that pins down five directions and leaves the translation
// along x free (a plain corridor) takes those five from the features and x from the
// constant-velocity prediction, with the prediction's uncertainty along x only.
TEST(MotionChain, WeakEstimateTakesTheUnconstrainedDirectionFromThePrediction) {
  MotionChainOptions o;
  o.fuse_weak_estimates = true;
  MotionChain tracker(o);
  tracker.update(0, goodEstimate(Pose3::Identity()));
  const Pose3 M = makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity());  // the velocity
  tracker.update(1, goodEstimate(M));
  PoseEstimate weak;
  weak.status = EstimateStatus::kUncertain;
  // Wrong along x (the features cannot tell), right across it.
  weak.T_curr_prev = makePose({-0.3, 0.004, -0.002}, Eigen::Quaterniond::Identity());
  weak.covariance = Matrix6d::Identity() * 1e-8;
  weak.covariance(0, 0) = kLargeVariance;
  const MotionChainOutput out = tracker.update(2, weak);
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  EXPECT_EQ(tracker.fusedEstimates(), 1);
  EXPECT_NEAR(out.T_curr_prev.translation().x(), 0.02, 1e-6);    // the prediction
  EXPECT_NEAR(out.T_curr_prev.translation().y(), 0.004, 1e-6);   // the estimate
  EXPECT_NEAR(out.T_curr_prev.translation().z(), -0.002, 1e-6);  // the estimate
  EXPECT_NEAR(std::sqrt(out.covariance(0, 0)), o.velocity_model_sigma_t_m, 1e-6);
  EXPECT_LT(out.covariance(1, 1), 2e-8);

  // An estimate that knows less than the prediction in most directions is rejected as a
  // whole (the velocity model), as is any weak estimate without the option.
  MotionChain chain2(o);
  chain2.update(0, goodEstimate(Pose3::Identity()));
  chain2.update(1, goodEstimate(M));
  PoseEstimate vague = weak;
  vague.covariance = Matrix6d::Identity();  // 1 m, 1 rad: nothing
  vague.covariance(1, 1) = 1e-8;
  EXPECT_EQ(chain2.update(2, vague).status, TrackingStatus::kVelocityModel);
  MotionChainOptions off;
  off.fuse_weak_estimates = false;
  MotionChain strict(off);
  strict.update(0, goodEstimate(Pose3::Identity()));
  strict.update(1, goodEstimate(M));
  EXPECT_EQ(strict.update(2, weak).status, TrackingStatus::kVelocityModel);
}

TEST(MotionChain, TheVelocityCarriesOnlyWhatWeakEstimatesMeasured) {
  // 300 weak frames that measure x, y and the rotation and all but nothing along z (2 m), each
  // 1 sigma off along z the same way (a model's bias). Each frame's motion takes its tiny
  // share of it; the velocity takes none, so the bias is not integrated into a walk.
  MotionChainOptions o;
  MotionChain tracker =
      chainMovingBy(makePose({0.0, 0.0, 0.01}, Eigen::Quaterniond::Identity()), o);
  PoseEstimate weak = weakEstimate(Pose3::Identity(), 2, 4.0);
  const double sigma_p2 = o.velocity_model_sigma_t_m * o.velocity_model_sigma_t_m;
  const double share = (2.0 / 4.0) / (1.0 / 4.0 + 1.0 / sigma_p2);  // the frame's shift along z
  for (int64_t s = 2; s < 302; ++s) {
    const double predicted_z = tracker.predictedMotion().translation().z();
    weak.T_curr_prev = makePose({0.001, 0.0, predicted_z + 2.0}, Eigen::Quaterniond::Identity());
    const MotionChainOutput out = tracker.update(s, weak);
    ASSERT_EQ(out.status, TrackingStatus::kTracking) << "frame " << s;
    EXPECT_NEAR(out.T_curr_prev.translation().z(), 0.01 + share, 1e-7) << "frame " << s;
    EXPECT_NEAR(out.T_curr_prev.translation().x(), 0.001, 1e-6);
  }
  EXPECT_EQ(tracker.fusedEstimates(), 300);
  EXPECT_NEAR(tracker.predictedMotion().translation().z(), 0.01, 1e-9);   // not 0.01 + 300 shares
  EXPECT_NEAR(tracker.predictedMotion().translation().x(), 0.001, 1e-6);  // measured: carried on
}

TEST(MotionChain, WeakEstimateCanTakeTheDecayedVelocityWhereItKnowsNothing) {
  // decay_unconstrained_velocity: the unconstrained direction moves as a rejected frame's
  // would (velocity_decay times the velocity), and a run of such frames lets it fade; the
  // constrained directions still come from the estimate.
  MotionChainOptions o;
  o.decay_unconstrained_velocity = true;
  MotionChain tracker =
      chainMovingBy(makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity()), o);
  const PoseEstimate weak =
      weakEstimate(makePose({0.0, 0.004, -0.002}, Eigen::Quaterniond::Identity()), 0,
                   kLargeVariance, EstimateStatus::kDegenerate);
  double expected_x = 0.02;
  for (int64_t s = 2; s < 8; ++s) {
    const MotionChainOutput out = tracker.update(s, weak);
    expected_x *= o.velocity_decay;
    EXPECT_EQ(out.status, TrackingStatus::kTracking);
    EXPECT_NEAR(out.T_curr_prev.translation().x(), expected_x, 1e-6) << "frame " << s;
    EXPECT_NEAR(out.T_curr_prev.translation().y(), 0.004, 1e-6);
    EXPECT_NEAR(std::sqrt(out.covariance(0, 0)), o.velocity_model_sigma_t_m, 1e-6);
  }
  EXPECT_EQ(tracker.fusedEstimates(), 6);
}

TEST(MotionChain, ConfidentEstimateFarFromThePredictionIsRefused) {
  // Walking at 20 mm a frame: an accepted estimate that jumps 0.35 m in one frame (wrong
  // associations) is refused, the velocity model carries the frame and the velocity is kept,
  // so the next frames do not inherit the jump; a quick but possible change (30 mm) is used.
  MotionChainOptions o;
  MotionChain chain(o);
  chain.update(0, goodEstimate(Pose3::Identity()));
  const Pose3 M = makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  chain.update(1, goodEstimate(M));
  chain.update(2, goodEstimate(M));
  MotionChainOutput out =
      chain.update(3, goodEstimate(makePose({0.37, 0.0, 0.0}, Eigen::Quaterniond::Identity())));
  EXPECT_EQ(out.status, TrackingStatus::kVelocityModel);
  EXPECT_EQ(chain.gatedEstimates(), 1);
  EXPECT_NEAR(out.T_curr_prev.translation().x(), o.velocity_decay * 0.02, 1e-9);
  out = chain.update(4, goodEstimate(makePose({0.05, 0.0, 0.0}, Eigen::Quaterniond::Identity())));
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  EXPECT_NEAR(out.T_curr_prev.translation().x(), 0.05, 1e-12);
  EXPECT_EQ(chain.gatedEstimates(), 1);
  // The first motion after a start has nothing to agree with: any is used.
  MotionChain fresh(o);
  fresh.update(0, goodEstimate(Pose3::Identity()));
  EXPECT_EQ(
      fresh.update(1, goodEstimate(makePose({0.37, 0, 0}, Eigen::Quaterniond::Identity()))).status,
      TrackingStatus::kTracking);
}

TEST(MotionChain, PredictionCoversTheFramesDroppedSinceTheLast) {
  // 30 Hz stamps, 20 mm a frame; then a frame two periods later (one dropped on the way).
  MotionChainOptions o;
  MotionChain chain(o);
  const int64_t period_us = 33333;
  const Pose3 M = makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  int64_t t = 1000000;
  for (int seq = 0; seq < 5; ++seq, t += period_us) {
    chain.setFrameTime(t);
    chain.update(seq, goodEstimate(seq == 0 ? Pose3::Identity() : M));
  }
  t += period_us;  // the frame at t - period_us was dropped
  chain.setFrameTime(t);
  EXPECT_EQ(chain.periodsToFrame(), 2);
  // Constant velocity, the dropped period decayed once as a frame without a measurement.
  EXPECT_NEAR(chain.predictedMotion().translation().x(), (1.0 + o.velocity_decay) * 0.02, 1e-12);
  const Pose3 M2 = makePose({0.04, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  EXPECT_EQ(chain.update(5, goodEstimate(M2)).status, TrackingStatus::kTracking);
  EXPECT_EQ(chain.lastMotionPeriods(), 2);
  // The velocity is per period: the next frame, one period on, is predicted 20 mm, not 40.
  chain.setFrameTime(t + period_us);
  EXPECT_EQ(chain.periodsToFrame(), 1);
  EXPECT_NEAR(chain.predictedMotion().translation().x(), 0.02, 1e-12);
  // Without stamps every frame is one period, as before.
  MotionChain stampless(o);
  for (int seq = 0; seq < 5; ++seq)
    stampless.update(seq, goodEstimate(seq == 0 ? Pose3::Identity() : M));
  EXPECT_EQ(stampless.periodsToFrame(), 1);
  EXPECT_NEAR(stampless.predictedMotion().translation().x(), 0.02, 1e-12);
}

TEST(MotionChain, ProcessNoiseCoversTheTimeSinceTheLastFrame) {
  // A hand reverses a 60 mm-a-frame motion. At 30 Hz that is a 120 mm change within one
  // nominal frame, beyond the velocity model's 20 mm process noise: refused as a wrong
  // solution. At 10 Hz (a dataset played at every third frame) the same change spans three
  // nominal frames, noise 20 mm * 3^1.5: used.
  const Pose3 forward = makePose({0.06, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  const Pose3 back = makePose({-0.06, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  MotionChainOptions o;
  auto reversalAt = [&](int64_t period_us) {
    MotionChain chain(o);
    int64_t t = 1000000;
    for (int seq = 0; seq < 4; ++seq, t += period_us) {
      chain.setFrameTime(t);
      chain.update(seq, goodEstimate(seq == 0 ? Pose3::Identity() : forward));
    }
    chain.setFrameTime(t);
    return chain.update(4, goodEstimate(back));
  };
  MotionChainOutput at30 = reversalAt(33333);
  EXPECT_EQ(at30.status, TrackingStatus::kVelocityModel);
  EXPECT_NEAR(at30.covariance(0, 0), o.velocity_model_sigma_t_m * o.velocity_model_sigma_t_m,
              1e-12);
  MotionChainOutput at10 = reversalAt(100000);
  EXPECT_EQ(at10.status, TrackingStatus::kTracking);
  EXPECT_NEAR(at10.T_curr_prev.translation().x(), -0.06, 1e-12);
  // A frame the velocity model carries at 10 Hz has the noise of three nominal frames.
  MotionChain slow(o);
  int64_t t = 1000000;
  for (int seq = 0; seq < 4; ++seq, t += 100000) {
    slow.setFrameTime(t);
    slow.update(seq, goodEstimate(seq == 0 ? Pose3::Identity() : forward));
  }
  slow.setFrameTime(t);
  const MotionChainOutput carried = slow.update(4, rejectedEstimate());
  EXPECT_EQ(carried.status, TrackingStatus::kVelocityModel);
  EXPECT_NEAR(carried.covariance(0, 0),
              27.0 * o.velocity_model_sigma_t_m * o.velocity_model_sigma_t_m, 1e-12);
}

TEST(MotionChain, CorrectedPoseMovesTheWorldPoseAndNotTheMotion) {
  // A local map moves the current frame 5 cm (its adjustment): the next frame chains from the
  // corrected pose, its published motion is what was measured, and the prediction (velocity)
  // is untouched, so the next estimate is not gated as a jump.
  MotionChain chain;
  chain.update(0, goodEstimate(Pose3::Identity()));
  const Pose3 M = makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  chain.update(1, goodEstimate(M));
  chain.update(2, goodEstimate(M));
  Pose3 corrected = chain.T_w_c();
  corrected.translation() += Eigen::Vector3d(0.0, 0.05, 0.0);
  const Pose3 predicted = chain.predictedMotion();
  chain.correctPose(corrected);
  expectPoseNear(chain.T_w_c(), corrected);
  expectPoseNear(chain.predictedMotion(), predicted);
  const MotionChainOutput out = chain.update(3, goodEstimate(M));
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  EXPECT_EQ(chain.gatedEstimates(), 0);
  expectPoseNear(out.T_curr_prev, M);
  expectPoseNear(out.T_w_c, corrected * M.inverse());
  // Not a pose: ignored.
  Pose3 invalid = Pose3::Identity();
  invalid.translation().x() = std::numeric_limits<double>::quiet_NaN();
  chain.correctPose(invalid);
  expectPoseNear(chain.T_w_c(), out.T_w_c);
}

TEST(MotionChain, WeakEstimateThatDisagreesWithThePredictionIsRejected) {
  // Walking along a corridor at 20 mm a frame: the features constrain everything but x. A weak
  // estimate whose x wandered 1.5 m off with a claimed 0.1 m std would pull the combination
  // ~80 mm along x, and that would become the velocity there for good (nothing corrects x):
  // the innovation gate rejects it. One 30 mm off, within the joint spread, is combined.
  MotionChainOptions o;
  const Pose3 M = makePose({0.02, 0.0, 0.0}, Eigen::Quaterniond::Identity());
  PoseEstimate weak;
  weak.status = EstimateStatus::kUncertain;
  weak.covariance = Matrix6d::Identity() * 1e-8;
  weak.covariance(0, 0) = 0.1 * 0.1;
  for (const double x : {1.5, 0.05}) {
    MotionChain chain(o);
    chain.update(0, goodEstimate(Pose3::Identity()));
    chain.update(1, goodEstimate(M));
    weak.T_curr_prev = makePose({x, 0.001, 0.0}, Eigen::Quaterniond::Identity());
    const MotionChainOutput out = chain.update(2, weak);
    if (x > 1.0) {
      EXPECT_EQ(out.status, TrackingStatus::kVelocityModel);
      EXPECT_EQ(chain.fusedEstimates(), 0);
      EXPECT_NEAR(out.T_curr_prev.translation().x(), o.velocity_decay * 0.02, 1e-9);
    } else {
      EXPECT_EQ(out.status, TrackingStatus::kTracking);
      EXPECT_EQ(chain.fusedEstimates(), 1);
      EXPECT_GT(out.T_curr_prev.translation().x(), 0.02);
      EXPECT_LT(out.T_curr_prev.translation().x(), 0.05);
    }
  }
  // Without the gate the wandered estimate is combined and moves the velocity.
  MotionChainOptions ungated;
  ungated.prediction_gate_chi2 = std::numeric_limits<double>::infinity();
  MotionChain chain(ungated);
  chain.update(0, goodEstimate(Pose3::Identity()));
  chain.update(1, goodEstimate(M));
  weak.T_curr_prev = makePose({1.5, 0.001, 0.0}, Eigen::Quaterniond::Identity());
  const MotionChainOutput out = chain.update(2, weak);
  EXPECT_EQ(out.status, TrackingStatus::kTracking);
  EXPECT_GT(out.T_curr_prev.translation().x(), 0.07);
}

}  // namespace
}  // namespace pplvo::estimator
