// The whole method without LCM (OdometryPipeline) on ray-cast synthetic sequences with
// Kinect-like depth noise: tracking holds and the drift stays bounded for the full
// configuration and the paper's ablations; degenerate frames (no depth, no texture, bad
// sizes) never crash and never give a NaN pose.
#include <gtest/gtest.h>

#include <cmath>

#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/pipeline/odometry_pipeline.h"

namespace pplvo::pipeline {
namespace {

constexpr int kFrames = 36;  // 1.2 s at 30 Hz

const std::vector<synth::SynthFrame>& frames() {
  static const std::vector<synth::SynthFrame> f = [] {
    synth::SynthOptions o;
    o.frames = kFrames;
    o.seed = 3;
    synth::SyntheticSequence seq(o);
    std::vector<synth::SynthFrame> out;
    for (int i = 0; i < seq.size(); ++i) out.push_back(seq.render(i));
    return out;
  }();
  return f;
}

struct RunStats {
  int tracking = 0, other = 0;
  double rmse_t_m = 0, max_t_m = 0, max_r_deg = 0;
  bool all_finite = true;
};

/// Runs the pipeline over the synthetic frames; errors of T_w_c against the truth expressed
/// in the first camera (the pipeline's world frame).
RunStats run(const PipelineOptions& options,
             const std::function<void(int, RgbdFrame&)>& edit = {}) {
  OdometryPipeline pipe(options);
  const auto& f = frames();
  RunStats s;
  double sum2 = 0;
  for (int i = 0; i < static_cast<int>(f.size()); ++i) {
    RgbdFrame frame = f[i].frame;
    frame.bgr = frame.bgr.clone();
    frame.depth_m = frame.depth_m.clone();
    if (edit) edit(i, frame);
    const PipelineFrameResult r = pipe.process(frame);
    if (r.pose.status == TrackingStatus::kTracking)
      ++s.tracking;
    else if (i > 0)
      ++s.other;
    s.all_finite =
        s.all_finite && r.pose.T_w_c.matrix().allFinite() && r.pose.rel_covariance.allFinite();
    const Pose3 truth = f[0].T_w_c.inverse() * f[i].T_w_c;
    const Pose3 err = truth.inverse() * r.pose.T_w_c;
    const double t = err.translation().norm();
    sum2 += t * t;
    s.max_t_m = std::max(s.max_t_m, t);
    s.max_r_deg = std::max(s.max_r_deg, rotationAngle(err.linear()) * 180.0 / M_PI);
  }
  s.rmse_t_m = std::sqrt(sum2 / f.size());
  return s;
}

TEST(OdometryPipeline, FullConfigurationTracksSyntheticSequence) {
  const RunStats s = run(PipelineOptions{});
  std::printf("all: tracking %d/%d, drift rmse %.2f mm max %.2f mm %.3f deg\n", s.tracking,
              kFrames - 1, 1e3 * s.rmse_t_m, 1e3 * s.max_t_m, s.max_r_deg);
  EXPECT_TRUE(s.all_finite);
  EXPECT_EQ(s.tracking, kFrames - 1);
  // Observed ~11 mm and ~0.5 deg over the 1.2 s (ORB keypoints localise to ~0.7 px on the
  // procedural textures, docs/pipeline.md); bounds with a 2-3x margin.
  EXPECT_LT(s.max_t_m, 0.03);
  EXPECT_LT(s.max_r_deg, 1.0);
}

TEST(OdometryPipeline, EveryAblationAndDepthModelTracks) {
  struct Case {
    const char* features;
    depth_filter::DepthModel model;
  };
  const Case cases[] = {{"points", depth_filter::DepthModel::kOgm},
                        {"points,lines", depth_filter::DepthModel::kOgm},
                        {"points,planes", depth_filter::DepthModel::kOgm},
                        {"points,lines,planes", depth_filter::DepthModel::kSensor},
                        {"points,lines,planes", depth_filter::DepthModel::kCgm}};
  for (const Case& c : cases) {
    PipelineOptions o;
    FeatureFamilies f;
    ASSERT_TRUE(parseFeatureFamilies(c.features, &f));
    o.setFamilies(f);
    o.depth_filter.model = c.model;
    const RunStats s = run(o);
    std::printf("%-20s %-6s tracking %d/%d, drift max %.2f mm %.3f deg\n", c.features,
                depth_filter::toString(c.model), s.tracking, kFrames - 1, 1e3 * s.max_t_m,
                s.max_r_deg);
    EXPECT_TRUE(s.all_finite) << c.features;
    EXPECT_GE(s.tracking, kFrames - 3) << c.features;
    EXPECT_LT(s.max_t_m, 0.05) << c.features;
    EXPECT_LT(s.max_r_deg, 1.5) << c.features;
  }
}

TEST(OdometryPipeline, KeyframeTrackingHoldsAndTakesKeyframes) {
  // The hand-held synthetic sequence against keyframes: every frame tracked, keyframes taken
  // along the motion, the drift within the frame-to-frame test's bounds.
  PipelineOptions o;
  o.odometry.reference = tracking::TrackingReference::kKeyframe;
  OdometryPipeline pipe(o);
  const auto& f = frames();
  int tracking = 0, keyframes = 0, against_older = 0;
  double max_t = 0;
  for (int i = 0; i < static_cast<int>(f.size()); ++i) {
    const PipelineFrameResult r = pipe.process(f[i].frame);
    if (r.pose.status == TrackingStatus::kTracking) ++tracking;
    if (r.odometry.new_keyframe) ++keyframes;
    if (i > 0 && r.odometry.reference_seq && *r.odometry.reference_seq < f[i].frame.seq - 1)
      ++against_older;
    const Pose3 truth = f[0].T_w_c.inverse() * f[i].T_w_c;
    max_t = std::max(max_t, (truth.inverse() * r.pose.T_w_c).translation().norm());
  }
  std::printf(
      "keyframe: tracking %d/%d, %d keyframes, %d frames against an older keyframe, "
      "max drift %.2f mm\n",
      tracking, kFrames - 1, keyframes, against_older, 1e3 * max_t);
  EXPECT_EQ(tracking, kFrames - 1);
  EXPECT_GE(keyframes, 1);
  EXPECT_GE(against_older, kFrames / 3);  // the keyframe serves more than one frame
  EXPECT_LT(max_t, 0.03);
}

TEST(OdometryPipeline, FusedPlanesAreFittedOnlyForFramesTrackedAgainst) {
  // Against keyframes only a new keyframe's 3D features are tracked against (and a fallback's,
  // none here): the planes of the fused depth are fitted for those frames alone, and the poses
  // are those of fitting them for every frame.
  PipelineOptions only, every;
  only.odometry.reference = every.odometry.reference = tracking::TrackingReference::kKeyframe;
  every.frontend.fused_planes_only_for_references = false;
  OdometryPipeline a(only), b(every);
  const auto& f = frames();
  int references = 0, fallbacks = 0;
  for (int i = 0; i < static_cast<int>(f.size()); ++i) {
    const PipelineFrameResult ra = a.process(f[i].frame);
    const PipelineFrameResult rb = b.process(f[i].frame);
    ASSERT_EQ(ra.pose.T_w_c.matrix(), rb.pose.T_w_c.matrix()) << i;
    fallbacks += ra.odometry.keyframe_fallback;
    // The first frame is the first keyframe; later ones are references exactly when taken.
    const bool keyframe = i == 0 || ra.odometry.new_keyframe;
    EXPECT_EQ(ra.pose.reference,
              keyframe ? ReferenceRole::kReference : ReferenceRole::kFallbackOnly)
        << i;
    references += ra.pose.reference == ReferenceRole::kReference;
  }
  ASSERT_EQ(fallbacks, 0);
  ASSERT_LT(references, kFrames / 2);
  const int n = static_cast<int>(f.size());
  ASSERT_NE(a.timings().find("planes"), nullptr);
  EXPECT_EQ(a.timings().find("planes")->count, n + references);
  EXPECT_EQ(b.timings().find("planes")->count, 2 * n);

  // Frame to frame every frame is the next one's reference.
  PipelineOptions frame_mode;
  frame_mode.odometry.reference = tracking::TrackingReference::kFrame;
  OdometryPipeline frame_to_frame(frame_mode);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(frame_to_frame.process(f[i].frame).pose.reference, ReferenceRole::kReference);
  }
}

TEST(OdometryPipeline, KeyframeTrackingSurvivesTurningAwayAndBack) {
  // The camera turns 80 deg away from its start and back within 2 s: the first keyframe's
  // view leaves the image, new keyframes (or the previous frame) take over, and tracking
  // returns close to the start.
  synth::SynthOptions so;
  so.frames = 60;
  so.seed = 5;
  so.trajectory_scale = 0.2;
  so.trajectory = [](int i, const Pose3& hand_held) {
    const double yaw = 0.5 * (80.0 * M_PI / 180.0) * (1.0 - std::cos(2.0 * M_PI * i / 59.0));
    Pose3 turn = Pose3::Identity();
    turn.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
    return hand_held * turn;
  };
  const synth::SyntheticSequence seq(so);
  PipelineOptions o;
  o.odometry.reference = tracking::TrackingReference::kKeyframe;
  OdometryPipeline pipe(o);
  int not_tracking = 0, keyframes = 0;
  Pose3 first = Pose3::Identity(), last = Pose3::Identity(), est = Pose3::Identity();
  for (int i = 0; i < seq.size(); ++i) {
    const synth::SynthFrame frame = seq.render(i);
    const PipelineFrameResult r = pipe.process(frame.frame);
    if (i > 0 && r.pose.status != TrackingStatus::kTracking) ++not_tracking;
    if (r.odometry.new_keyframe) ++keyframes;
    if (i == 0) first = frame.T_w_c;
    last = frame.T_w_c;
    est = r.pose.T_w_c;
    ASSERT_TRUE(r.pose.T_w_c.matrix().allFinite());
  }
  const Pose3 err = (first.inverse() * last).inverse() * est;
  std::printf(
      "turn away and back: %d keyframes, %d frames not tracking, end error %.1f mm "
      "%.2f deg\n",
      keyframes, not_tracking, 1e3 * err.translation().norm(),
      rotationAngle(err.linear()) * 180.0 / M_PI);
  EXPECT_GE(keyframes, 3);  // 80 deg is more than the 62-deg view: the first one is left
  EXPECT_LE(not_tracking, 3);
  EXPECT_LT(err.translation().norm(), 0.05);
  EXPECT_LT(rotationAngle(err.linear()) * 180.0 / M_PI, 2.0);
}

/// RMS translation error of the frame-to-frame motions against the truth, and the ratio of
/// estimated to true motion (least squares over the pairs), from frame `first` on.
struct MotionErrors {
  double rms_m = 0, scale = 0;
};

MotionErrors motionErrors(const synth::SyntheticSequence& seq, const PipelineOptions& options,
                          int first = 1) {
  OdometryPipeline pipe(options);
  Pose3 last_truth = Pose3::Identity(), last_est = Pose3::Identity();
  double sum2 = 0, num = 0, den = 0;
  int pairs = 0;
  for (int i = 0; i < seq.size(); ++i) {
    const synth::SynthFrame frame = seq.render(i);
    const PipelineFrameResult r = pipe.process(frame.frame);
    if (i >= std::max(1, first)) {
      const Eigen::Vector3d truth = (last_truth.inverse() * frame.T_w_c).translation();
      const Eigen::Vector3d est = (last_est.inverse() * r.pose.T_w_c).translation();
      sum2 += (est - truth).squaredNorm();
      num += est.dot(truth);
      den += truth.squaredNorm();
      ++pairs;
    }
    last_truth = frame.T_w_c;
    last_est = r.pose.T_w_c;
  }
  return {std::sqrt(sum2 / std::max(1, pairs)), num / den};
}

TEST(OdometryPipeline, DepthCapturedBeforeColourIsMovedToTheColourInstant) {
  // A free-running sensor whose depth is about 15 ms older than its colour and now and then
  // 16 ms younger (the pattern of TUM fr1's associations) on a brisk hand-held motion. Without
  // the depth filter's time alignment the 3D-3D terms measure the depth camera's motion
  // between depth instants, off by up to 31 ms of motion where the offset flips; with it the
  // result is close to that of the same motion with depth and colour at one instant.
  synth::SynthOptions so;
  so.frames = 30;
  so.seed = 7;
  so.trajectory_scale = 2.0;
  const synth::SyntheticSequence in_sync(so);
  so.depth_offsets_s = {-0.015, -0.013, 0.016, -0.016, -0.012, -0.014, 0.015};
  const synth::SyntheticSequence offset(so);
  ASSERT_EQ(offset.render(3).frame.depth_utime - offset.render(3).frame.utime, -16000);

  PipelineOptions o;
  o.odometry.reference = tracking::TrackingReference::kFrame;  // every pair its own estimate
  // Planes at the paper's weight: the plane weights from their residuals would see the
  // misaligned depth's planes disagree and weigh them less (0.77 mm as captured), hiding
  // what this test is about, the depth moved to the colour instant.
  o.odometry.tracker.estimator.plane_weight_from_residuals = false;
  // The velocity of frames j-3 and j-2 moves frame j's depth: frames 0-2 have none yet (as the
  // tracker, which has no motion model before its second pose), so the pairs from frame 4 on
  // are those with both depths aligned.
  constexpr int kFirstAlignedPair = 4;
  const MotionErrors sync = motionErrors(in_sync, o, kFirstAlignedPair);
  const MotionErrors aligned = motionErrors(offset, o, kFirstAlignedPair);
  o.depth_filter.time_alignment = false;
  const MotionErrors raw = motionErrors(offset, o, kFirstAlignedPair);
  std::printf(
      "depth -16..+16 ms from colour: per-frame motion error %.2f mm (scale %.3f) as captured, "
      "%.2f mm (%.3f) aligned, %.2f mm (%.3f) in sync\n",
      1e3 * raw.rms_m, raw.scale, 1e3 * aligned.rms_m, aligned.scale, 1e3 * sync.rms_m,
      sync.scale);
  EXPECT_LT(aligned.rms_m, 0.7 * raw.rms_m);
  EXPECT_LT(aligned.rms_m, 1.5 * sync.rms_m);
  // Measured 1.74 mm as captured, 1.03 mm aligned, 0.85 mm in sync (deterministic).
}

/// Mean NEES of the published relative poses of `frames` synthetic frames whose every pose
/// carries a shared error of `sigma_t_m` / `sigma_rot_deg` per axis; `without_shared`: the
/// same with the published shared-error part (pose.frame_error_covariance) taken out.
struct SharedErrorNees {
  double with = 0, without_shared = 0;
};
SharedErrorNees sharedErrorNees(const PipelineOptions& o, double sigma_t_m, double sigma_rot_deg,
                                int frames) {
  synth::SynthOptions so;
  so.frames = frames;
  so.seed = 9;
  so.frame_error_sigma_t_m = sigma_t_m;
  so.frame_error_sigma_rot_rad = sigma_rot_deg * M_PI / 180;
  const synth::SyntheticSequence seq(so);
  OdometryPipeline pipe(o);
  Pose3 last_truth = Pose3::Identity();
  SharedErrorNees sum;
  int pairs = 0;
  for (int i = 0; i < seq.size(); ++i) {
    const synth::SynthFrame frame = seq.render(i);
    const PipelineFrameResult r = pipe.process(frame.frame);
    if (i > 0) {
      EXPECT_EQ(r.pose.status, TrackingStatus::kTracking) << i;
      const Vector6d e =
          poseToXi(r.pose.T_prev_curr) - poseToXi(last_truth.inverse() * frame.T_w_c);
      sum.with += e.dot(r.pose.rel_covariance.ldlt().solve(e));
      const Matrix6d own = r.pose.rel_covariance - r.pose.frame_error_covariance;
      sum.without_shared += e.dot(own.ldlt().solve(e));
      ++pairs;
    }
    last_truth = frame.T_w_c;
  }
  return {sum.with / pairs, sum.without_shared / pairs};
}

TEST(OdometryPipeline, PerFrameSharedErrorKeepsThePublishedCovarianceConsistent) {
  // A camera whose every frame carries a pose error of its own, common to all of its pixels:
  // no number of matches averages it away. Estimated online from the roughness of the
  // motions, the published relative covariances stay consistent (mean NEES in [3, 12]) when
  // the error is 2 mm / 0.06 deg and when it doubles; without the shared part they are
  // over-confident by far, and a fixed value told 2 mm is over-confident once it doubles.
  PipelineOptions online;
  PipelineOptions fixed;
  fixed.odometry.tracker.frame_error_online = false;
  fixed.odometry.tracker.frame_error_sigma_t_m = 2e-3;
  fixed.odometry.tracker.frame_error_sigma_rot_deg = 0.06;
  constexpr int kSharedErrorFrames = 80;
  const SharedErrorNees single = sharedErrorNees(online, 2e-3, 0.06, kSharedErrorFrames);
  const SharedErrorNees doubled = sharedErrorNees(online, 4e-3, 0.12, kSharedErrorFrames);
  const SharedErrorNees told_half = sharedErrorNees(fixed, 4e-3, 0.12, kSharedErrorFrames);
  std::printf(
      "shared error 2 mm / 0.06 deg: mean NEES %.2f online (%.1f without it); doubled: %.2f "
      "online, %.2f with a fixed 2 mm / 0.06 deg\n",
      single.with, single.without_shared, doubled.with, told_half.with);
  // Mean of 79 chi2(6) pairs: 6 +- 0.4 (std); the first ~13 frames use the larger start value.
  for (const double nees : {single.with, doubled.with}) {
    EXPECT_GT(nees, 3.0);
    EXPECT_LT(nees, 12.0);
  }
  EXPECT_GT(single.without_shared, 5 * single.with);
  EXPECT_GT(told_half.with, 12.0);
}

TEST(OdometryPipeline, FramesWithoutDepthOrTextureFallBackAndRecover) {
  // Frames 10-11 lose all depth, frames 20-21 are a flat grey image without depth (lens
  // covered): the estimate is rejected, the velocity model bridges, tracking resumes.
  const RunStats s = run(PipelineOptions{}, [](int i, RgbdFrame& f) {
    if (i == 10 || i == 11 || i == 20 || i == 21) f.depth_m.setTo(0.0f);
    if (i == 20 || i == 21) f.bgr.setTo(cv::Scalar(128, 128, 128));
  });
  std::printf("with gaps: tracking %d/%d, other %d, drift max %.2f mm\n", s.tracking, kFrames - 1,
              s.other, 1e3 * s.max_t_m);
  EXPECT_TRUE(s.all_finite);
  EXPECT_GE(s.other, 2);                   // at least the textureless frames are not "tracking"
  EXPECT_GE(s.tracking, kFrames - 1 - 6);  // the rest, including after the gaps, is tracked
  EXPECT_LT(s.max_t_m, 0.10);
}

TEST(OdometryPipeline, FrameWhoseDepthDisagreesWithTheCameraIsRejected) {
  OdometryPipeline pipe;
  RgbdFrame f = frames()[0].frame;
  f.depth_m = cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f));
  EXPECT_THROW(pipe.process(f), std::invalid_argument);
  f.depth_m = cv::Mat();
  EXPECT_THROW(pipe.process(f), std::invalid_argument);
  // The pipeline is still usable afterwards.
  const PipelineFrameResult r = pipe.process(frames()[0].frame);
  EXPECT_EQ(r.pose.status, TrackingStatus::kFirstFrame);
}

TEST(OdometryPipeline, ReferenceFeaturesCarry3dEstimates) {
  OdometryPipeline pipe;
  pipe.process(frames()[0].frame);
  ASSERT_TRUE(pipe.reference().has_value());
  const FrameFeatures& ref = *pipe.reference();
  int p3 = 0, l3 = 0;
  for (const auto& p : ref.points) p3 += p.has_3d;
  for (const auto& l : ref.lines) l3 += l.has_3d;
  EXPECT_GT(p3, 200);
  EXPECT_GT(l3, 10);
  EXPECT_GE(ref.planes.size(), 2u);
  EXPECT_EQ(ref.seq, frames()[0].frame.seq);
}

TEST(OdometryPipeline, ParallelFrontendGivesTheSameResults) {
  PipelineOptions seq_opts, par_opts;
  seq_opts.frontend.parallel = false;
  par_opts.frontend.parallel = true;
  OdometryPipeline a(seq_opts), b(par_opts);
  for (int i = 0; i < 6; ++i) {
    const PipelineFrameResult ra = a.process(frames()[i].frame);
    const PipelineFrameResult rb = b.process(frames()[i].frame);
    EXPECT_EQ(ra.pose.T_w_c.matrix(), rb.pose.T_w_c.matrix()) << i;
    EXPECT_EQ(ra.frontend.lines, rb.frontend.lines) << i;
    EXPECT_EQ(ra.frontend.planes, rb.frontend.planes) << i;
  }
  const FrameFeatures& fa = *a.reference();
  const FrameFeatures& fb = *b.reference();
  ASSERT_EQ(fa.lines.size(), fb.lines.size());
  for (size_t i = 0; i < fa.lines.size(); ++i) {
    EXPECT_EQ(fa.lines[i].px1, fb.lines[i].px1);
    EXPECT_EQ(fa.lines[i].line.p1, fb.lines[i].line.p1);
  }
  EXPECT_EQ(cv::norm(fa.plane_labels, fb.plane_labels, cv::NORM_INF), 0.0);
}

TEST(FeatureFamilies, ParsesListsAndRejectsUnknownNames) {
  FeatureFamilies f;
  ASSERT_TRUE(parseFeatureFamilies("points,planes", &f));
  EXPECT_TRUE(f.points);
  EXPECT_FALSE(f.lines);
  EXPECT_TRUE(f.planes);
  EXPECT_EQ(toString(f), "points,planes");
  ASSERT_TRUE(parseFeatureFamilies("all", &f));
  EXPECT_TRUE(f.points && f.lines && f.planes);
  const FeatureFamilies before = f;
  EXPECT_FALSE(parseFeatureFamilies("points,surf", &f));
  EXPECT_FALSE(parseFeatureFamilies("", &f));
  EXPECT_EQ(toString(f), toString(before));
}

}  // namespace
}  // namespace pplvo::pipeline
