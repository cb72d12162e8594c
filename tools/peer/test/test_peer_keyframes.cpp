// The peer odometry's keyframe mode (ReferenceMode::kKeyframe) on rendered synthetic sequences
// with known poses: where keyframes are made, the fallback to the previous frame, failures,
// and the accuracy gained over frame to frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <vector>

#include "peer_test_util.h"

namespace pplvo::peer {
namespace {

using namespace pplvo::peer::test;

constexpr int kFrames = 45;  // the sequence of test_peer_odometry: 1.5 s, 0.17 m path

PeerOdometryOptions keyframeOptions(double translation_m, double rotation_deg) {
  PeerOdometryOptions o;
  o.reference_mode = ReferenceMode::kKeyframe;
  o.keyframe_translation_m = translation_m;
  o.keyframe_rotation_deg = rotation_deg;
  return o;
}

double angleDeg(const Pose3& T) { return rotationAngle(T.linear()) * 180.0 / M_PI; }

/// The keyframe rule applied to the true poses: how many frames after the first would pass a
/// threshold from their keyframe.
int keyframesByMotionOnTruth(const std::vector<Pose3>& T_w_c, double translation_m,
                             double rotation_deg) {
  int count = 0;
  Pose3 T_w_kf = T_w_c.front();
  for (const Pose3& T : T_w_c) {
    const Pose3 T_kf_c = T_w_kf.inverse() * T;
    if (T_kf_c.translation().norm() > translation_m || angleDeg(T_kf_c) > rotation_deg) {
      ++count;
      T_w_kf = T;
    }
  }
  return count;
}

TEST(PeerKeyframes, StillCameraKeepsTheFirstKeyframe) {
  // The camera does not move (trajectory_scale 0); only the sensor noise differs per frame.
  const Rendered& r = rendered(525.0, 30, 0.0);
  ASSERT_TRUE(r.T_w_c.front().isApprox(r.T_w_c.back(), 1e-12));
  const RunResult res = run(r.frames, keyframeOptions(0.10, 10.0));
  EXPECT_EQ(res.stats.failures, 0);
  EXPECT_EQ(res.stats.tracked, 29);
  EXPECT_EQ(res.stats.keyframes, 1);
  EXPECT_EQ(res.stats.keyframes_by_motion, 0);
  EXPECT_EQ(res.stats.keyframe_fallbacks, 0);
  EXPECT_TRUE(res.results.front().new_keyframe);
  for (size_t i = 1; i < res.results.size(); ++i) {
    EXPECT_EQ(res.results[i].reference_seq, r.frames.front().seq) << i;
    EXPECT_FALSE(res.results[i].new_keyframe) << i;
  }
  // Even with thresholds of 1 cm and 1 deg the estimated motion stays below them.
  const RunResult tight = run(r.frames, keyframeOptions(0.01, 1.0));
  EXPECT_EQ(tight.stats.keyframes, 1);
}

TEST(PeerKeyframes, KeyframesAreMadeWhereTheMotionPassesAThreshold) {
  const Rendered& r = rendered(525.0, kFrames);
  struct Case {
    double translation_m, rotation_deg;
  };
  int previous_count = -1;
  // Thresholds from loose to tight: the keyframe count must grow, and follow the rule applied
  // to the true poses within one (a pose error of millimetres can move one switch by a frame,
  // which can shift the later ones but not change their number by more than one).
  for (const Case& c : {Case{0.10, 10.0}, Case{0.04, 10.0}, Case{0.02, 10.0}, Case{0.01, 10.0}}) {
    const RunResult res = run(r.frames, keyframeOptions(c.translation_m, c.rotation_deg));
    const int expected = keyframesByMotionOnTruth(r.T_w_c, c.translation_m, c.rotation_deg);
    std::printf("thresholds %.2f m %.0f deg: %lld keyframes by motion (%d on the true poses)\n",
                c.translation_m, c.rotation_deg,
                static_cast<long long>(res.stats.keyframes_by_motion), expected);
    EXPECT_EQ(res.stats.failures, 0);
    EXPECT_EQ(res.stats.keyframe_fallbacks, 0);
    EXPECT_EQ(res.stats.keyframes, 1 + res.stats.keyframes_by_motion);
    EXPECT_NEAR(static_cast<double>(res.stats.keyframes_by_motion), expected, 1.0);
    EXPECT_GT(res.stats.keyframes_by_motion, previous_count);
    previous_count = static_cast<int>(res.stats.keyframes_by_motion);
    // Frame by frame: each frame is registered to the last keyframe, and becomes the keyframe
    // exactly when its motion from that keyframe passes a threshold.
    int64_t keyframe_seq = r.frames.front().seq;
    for (size_t i = 1; i < res.results.size(); ++i) {
      const PeerFrameResult& f = res.results[i];
      ASSERT_EQ(f.status, PeerStatus::kOk) << i;
      EXPECT_EQ(f.reference_seq, keyframe_seq) << i;
      EXPECT_FALSE(f.fell_back) << i;
      const bool far =
          f.T_ref_c.translation().norm() > c.translation_m || angleDeg(f.T_ref_c) > c.rotation_deg;
      EXPECT_EQ(f.new_keyframe, far) << i;
      if (f.new_keyframe) keyframe_seq = r.frames[i].seq;
    }
  }
  EXPECT_GE(previous_count, 10);  // the tightest case really switches often
}

TEST(PeerKeyframes, ZeroThresholdsGiveExactlyTheFrameToFramePoses) {
  // Every tracked frame becomes the keyframe: the same registrations from the same initial
  // guesses as frame to frame, so the same poses bit for bit.
  const Rendered& r = rendered(525.0, kFrames);
  const RunResult a = run(r.frames, PeerOdometryOptions{});
  const RunResult b = run(r.frames, keyframeOptions(0.0, 0.0));
  EXPECT_EQ(b.stats.keyframes, kFrames);
  EXPECT_EQ(b.stats.keyframes_by_motion, kFrames - 1);
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_TRUE(a.T_w_c[i].matrix() == b.T_w_c[i].matrix()) << "frame " << i;
    EXPECT_EQ(b.results[i].reference_seq, a.results[i].reference_seq) << i;
  }
}

TEST(PeerKeyframes, MoreAccurateThanFrameToFrame) {
  // Frame to frame sums the registration noise of every frame; against a keyframe it is
  // summed once per keyframe (about every 10 cm here: once or twice in the sequence).
  const Rendered& r = rendered(525.0, kFrames);
  for (PeerMethod m : {PeerMethod::kRgbd, PeerMethod::kRgbdIcp}) {
    PeerOdometryOptions f2f;
    f2f.method = m;
    PeerOdometryOptions kf = keyframeOptions(0.10, 10.0);
    kf.method = m;
    const RunResult a = run(r.frames, f2f);
    const RunResult b = run(r.frames, kf);
    const DriftErrors ea = driftErrors(a.T_w_c, r.T_w_c);
    const DriftErrors eb = driftErrors(b.T_w_c, r.T_w_c);
    std::printf("[%s] frame to frame: %s\n[%s] keyframes (%lld): %s\n", methodName(m),
                describe(ea).c_str(), methodName(m), static_cast<long long>(b.stats.keyframes),
                describe(eb).c_str());
    EXPECT_EQ(b.stats.failures, 0);
    // Measured: rgbd 0.7 mm against 26 mm rmse, rgbd_icp 0.6 mm against 39 mm.
    EXPECT_LT(eb.rmse_trans_m, 0.3 * ea.rmse_trans_m) << methodName(m);
    EXPECT_LT(eb.max_trans_m, 0.3 * ea.max_trans_m) << methodName(m);
    EXPECT_LT(eb.max_rot_deg, 0.3 * ea.max_rot_deg) << methodName(m);
  }
}

/// A copy of `depth` with the columns outside [x0, x1) set to 0 (missing).
cv::Mat depthOnlyInColumns(const cv::Mat& depth, int x0, int x1) {
  cv::Mat out(depth.size(), CV_32FC1, cv::Scalar(0.0f));
  depth.colRange(x0, x1).copyTo(out.colRange(x0, x1));
  return out;
}

TEST(PeerKeyframes, FallsBackToThePreviousFrameWhenTheKeyframeIsLost) {
  // The keyframe (frame 0) has depth only in the left half of the image, frame 4 only in the
  // right part: no keyframe pixel finds a depth in frame 4 (the camera moves a few pixels over
  // these frames; the gap is 60 px), so tracking against the keyframe fails as if the camera
  // had turned away. The previous frame (3, full depth) still overlaps: it tracks frame 4,
  // which becomes the keyframe of the frames after it.
  const Rendered& r = rendered(525.0, kFrames);
  std::vector<RgbdFrame> frames(r.frames.begin(), r.frames.begin() + 10);
  frames[0].depth_m = depthOnlyInColumns(r.frames[0].depth_m, 0, 290);
  frames[4].depth_m = depthOnlyInColumns(r.frames[4].depth_m, 350, 640);
  const RunResult res = run(frames, keyframeOptions(0.10, 10.0));
  EXPECT_EQ(res.stats.failures, 0);
  EXPECT_EQ(res.stats.keyframe_fallbacks, 1);
  EXPECT_EQ(res.stats.keyframes_by_motion, 0);
  EXPECT_EQ(res.stats.keyframes, 2);
  for (int i = 1; i < 10; ++i) {
    const PeerFrameResult& f = res.results[i];
    ASSERT_EQ(f.status, PeerStatus::kOk) << i << ": " << f.message;
    EXPECT_EQ(f.fell_back, i == 4) << i;
    EXPECT_EQ(f.new_keyframe, i == 4) << i;
    EXPECT_EQ(f.reference_seq, frames[i < 4 ? 0 : i == 4 ? 3 : 4].seq) << i;
  }
  const DriftErrors e =
      driftErrors(res.T_w_c, std::vector<Pose3>(r.T_w_c.begin(), r.T_w_c.begin() + 10));
  EXPECT_LT(e.max_trans_m, 0.01) << describe(e);
  EXPECT_LT(e.max_rot_deg, 0.5) << describe(e);

  // Controls: frame 4 cannot be registered to frame 0 on its own (the first registration
  // really failed), and with zero thresholds (every frame a keyframe, so no fallback exists)
  // frame 4 is tracked from frame 3 directly.
  const RunResult pair = run({frames[0], frames[4]}, keyframeOptions(0.10, 10.0));
  EXPECT_EQ(pair.results[1].status, PeerStatus::kNotConverged);
  const RunResult every = run(frames, keyframeOptions(0.0, 0.0));
  EXPECT_EQ(every.stats.failures, 0);
  EXPECT_EQ(every.stats.keyframe_fallbacks, 0);
}

TEST(PeerKeyframes, BothRegistrationsFailingIsAFailureThatKeepsTheKeyframe) {
  const Rendered& r = rendered(525.0, kFrames);
  std::vector<RgbdFrame> frames(r.frames.begin(), r.frames.begin() + 10);
  // Frame 6: valid depth (a wall at 1 m, far from the room's 2-4 m) and no texture: neither
  // the keyframe (frame 0) nor the previous frame (5) finds correspondences in it.
  frames[6].bgr = cv::Mat(frames[6].bgr.size(), CV_8UC3, cv::Scalar(128, 128, 128));
  frames[6].depth_m = cv::Mat(frames[6].depth_m.size(), CV_32FC1, cv::Scalar(1.0f));
  // Frame 3: no depth at all (fails before OpenCV is called).
  frames[3].depth_m = cv::Mat(frames[3].depth_m.size(), CV_32FC1, cv::Scalar(0.0f));
  const RunResult res = run(frames, keyframeOptions(0.10, 10.0));
  EXPECT_EQ(res.results[3].status, PeerStatus::kNoDepth);
  EXPECT_EQ(res.results[6].status, PeerStatus::kNotConverged);
  EXPECT_NE(res.results[6].message.find("keyframe and previous frame"), std::string::npos)
      << res.results[6].message;
  EXPECT_EQ(res.stats.failures, 2);
  EXPECT_EQ(res.stats.not_converged, 1);
  // Hold policy: the failed frames keep the last tracked pose.
  EXPECT_TRUE(res.results[3].T_w_c.isApprox(res.results[2].T_w_c, 1e-12));
  EXPECT_TRUE(res.results[6].T_w_c.isApprox(res.results[5].T_w_c, 1e-12));
  // Neither failure made a keyframe: every frame is registered to frame 0.
  EXPECT_EQ(res.stats.keyframes, 1);
  EXPECT_EQ(res.stats.keyframe_fallbacks, 0);
  for (int i : {1, 2, 4, 5, 7, 8, 9}) {
    EXPECT_EQ(res.results[i].status, PeerStatus::kOk) << i;
    EXPECT_EQ(res.results[i].reference_seq, frames[0].seq) << i;
  }
  std::vector<Pose3> est, gt;
  for (int i = 0; i < 10; ++i) {
    if (i == 3 || i == 6) continue;
    est.push_back(res.T_w_c[i]);
    gt.push_back(r.T_w_c[i]);
  }
  const DriftErrors e = driftErrors(est, gt);
  EXPECT_LT(e.max_trans_m, 0.02) << describe(e);
}

TEST(PeerKeyframes, ReferenceResetMakesTheCurrentFrameTheKeyframe) {
  // As ReferenceIsReplacedAfterTooManyFailures in frame-to-frame mode: a motion limit below
  // the true motion makes every registration fail; after max_consecutive_failures the current
  // frame becomes the keyframe.
  const Rendered& r = rendered(525.0, kFrames);
  const std::vector<RgbdFrame> frames(r.frames.begin(), r.frames.begin() + 12);
  PeerOdometryOptions o = keyframeOptions(0.10, 10.0);
  o.max_translation_m = 1e-5;
  o.max_consecutive_failures = 5;
  const RunResult res = run(frames, o);
  EXPECT_EQ(res.stats.failures, 11);
  EXPECT_EQ(res.stats.reference_resets, 2);  // after frames 5 and 10
  EXPECT_EQ(res.stats.keyframes, 3);
  EXPECT_EQ(res.stats.keyframe_fallbacks, 0);
  EXPECT_TRUE(res.results[5].new_keyframe);
  EXPECT_TRUE(res.results[10].new_keyframe);
  EXPECT_EQ(res.results[5].reference_seq, frames[0].seq);
  EXPECT_EQ(res.results[6].reference_seq, frames[5].seq);
  EXPECT_EQ(res.results[11].reference_seq, frames[10].seq);
}

TEST(PeerKeyframes, ModeNames) {
  EXPECT_STREQ(referenceModeName(ReferenceMode::kPreviousFrame), "previous_frame");
  EXPECT_STREQ(referenceModeName(ReferenceMode::kKeyframe), "keyframe");
  // Default: frame to frame, with DVO's thresholds ready for keyframe mode.
  const PeerOdometryOptions o;
  EXPECT_EQ(o.reference_mode, ReferenceMode::kPreviousFrame);
  EXPECT_DOUBLE_EQ(o.keyframe_translation_m, 0.10);
  EXPECT_DOUBLE_EQ(o.keyframe_rotation_deg, 10.0);
  PeerOdometry odo;
  const Rendered& r = rendered(525.0, kFrames);
  for (int i = 0; i < 5; ++i) odo.process(r.frames[i]);
  EXPECT_EQ(odo.stats().keyframes, 0);  // counted in keyframe mode only
}

}  // namespace
}  // namespace pplvo::peer
