#pragma once
/// Visual odometry of a stream of frames (paper Sec. "Matching" and "Pose Estimation"): the
/// tracking policy. Each frame's 2D features (points, lines, C-GM planes) are matched against
/// 3D features lifted on fused depth, either the previous frame's (the paper) or the active
/// keyframe's (docs/estimator.md, "Keyframes"), and the motion, its covariance and the window
/// uncertainties the depth filter needs follow (MotionChain). No LCM.
///
/// The data lives apart from the policy: the keyframe and its landmarks in a KeyframeStore,
/// the 3D stages that arrive after later frames' 2D stages in a LiftedStageBuffer. The policy
/// decides what a frame is tracked against, when the previous frame must serve instead
/// (fallback), when a new keyframe is taken (keyframe_rule.h) and when landmarks are fused.
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "pplvo/core/body_odometry.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/estimator/motion_chain.h"
#include "pplvo/estimator/pose_estimator.h"
#include "pplvo/features/matching.h"
#include "pplvo/geometry/plane_matching.h"
#include "pplvo/tracking/keyframe_rule.h"
#include "pplvo/tracking/keyframe_store.h"
#include "pplvo/tracking/lifted_stage_buffer.h"
#include "pplvo/tracking/local_mapper.h"
#include "pplvo/tracking/readout_estimator.h"
#include "pplvo/tracking/rolling_shutter.h"

namespace pplvo::tracking {

/// What the current frame's 2D features are matched against.
enum class TrackingReference {
  kFrame,     ///< the previous frame (the paper)
  kKeyframe,  ///< the active keyframe, the previous frame as fallback
  /// the landmarks of the keyframes around the active one, adjusted together (local_mapper.h),
  /// the previous frame as fallback
  kLocalMap,
};
bool parseTrackingReference(const std::string& text, TrackingReference* out);
const char* toString(TrackingReference reference);

struct TrackingOptions {
  TrackingReference reference = TrackingReference::kKeyframe;
  KeyframeOptions keyframe;
  LocalMapOptions local_map;  ///< reference: local_map
  /// Where the camera sits on the robot, for the body-frame odometry (odometry_t).
  BodyMountOptions body;
  estimator::MotionChainOptions tracker;  ///< tracker.estimator.use_* select the families
  features::PointMatchOptions point_matching;
  features::LineMatchOptions line_matching;
  geometry::PlaneMatchOptions plane_matching;
  /// Gate points around their position predicted by the constant-velocity model.
  bool predict_point_positions = true;
  /// Move the previous planes by the predicted motion before the plane gate.
  bool predict_plane_positions = true;
  /// Gate lines around the projection of their 3D segment under the predicted motion
  /// (reference lines without 3D keep their own 2D equation).
  bool predict_line_positions = true;
  /// Add to the published motion's covariance the error of the current frame's depth moved to
  /// its colour instant (the depth filter's time alignment; docs/estimator.md). The poses do
  /// not depend on it.
  bool depth_alignment_error = true;
  /// Read the colour camera's rolling-shutter readout from the frames when the calibration
  /// gives none (readout_estimator.h; reference: keyframe or local_map, against the newest
  /// keyframe), and compensate with it once it stands clear of zero.
  bool readout_from_frames = true;
};

/// Schema of TrackingOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, TrackingOptions& o) {
  v.field("reference", o.reference,
          "what a frame is tracked against: frame (the previous one, as in the paper), "
          "keyframe (the active keyframe, the previous frame as fallback) or local_map (the "
          "landmarks of the keyframes around it, adjusted together; docs/estimator.md)");
  v.section("keyframe", "When a new keyframe is taken (reference: keyframe, local_map)",
            [&] { visit(v, o.keyframe); });
  v.section("local_map", "The windowed local map and its bundle adjustment (reference: local_map)",
            [&] { visit(v, o.local_map); });
  v.section("body",
            "The camera's mounting on the robot (camera_link in base_link, REP-103 axes), for "
            "the body-frame odometry on PPLVO_ODOMETRY; zero: camera at the body origin, "
            "looking along x",
            [&] { visit(v, o.body); });
  v.section("tracker", "Frame-to-frame tracking, pose estimation and window uncertainty",
            [&] { visit(v, o.tracker); });
  v.section("point_matching", "Point matching (Sec. 4.5)", [&] { visit(v, o.point_matching); });
  v.section("line_matching", "Line matching (Sec. 4.5)", [&] { visit(v, o.line_matching); });
  v.section("plane_matching", "Plane matching (Sec. 4.5)", [&] { visit(v, o.plane_matching); });
  v.field("predict_point_positions", o.predict_point_positions,
          "gate points around their position predicted by the constant-velocity model");
  v.field("predict_plane_positions", o.predict_plane_positions,
          "move the previous planes by the predicted motion before the plane gate");
  v.field("predict_line_positions", o.predict_line_positions,
          "gate lines around the projection of their 3D segment under the predicted motion");
  v.field("depth_alignment_error", o.depth_alignment_error,
          "add to the published motion covariance the error of the current frame's depth moved "
          "to its colour instant (scale^2 times the covariance of the motion it was moved by, "
          "through the share of the pose its planes carry); the poses do not depend on it");
  v.field("readout_from_frames", o.readout_from_frames,
          "read the colour camera's rolling-shutter readout from the frames when the "
          "calibration gives none (reference: keyframe or local_map; docs/estimator.md), and "
          "compensate with it once it stands five standard errors clear of zero");
}

/// What happened to one frame.
struct TrackingStats {
  int point_matches = 0, line_matches = 0, plane_matches = 0;
  bool reinitialised = false;  ///< no usable reference: tracking restarted at this frame
  /// The frame whose 3D features the pose was estimated from (unset: none).
  std::optional<int64_t> reference_seq;
  bool keyframe_fallback = false;  ///< the keyframe estimate failed; the previous frame served
  bool new_keyframe = false;       ///< this frame becomes the next frame's keyframe
  /// An earlier keyframe became active again instead of a new one (keyframe.retired_keyframes):
  /// its sequence number; this frame's world pose is the one measured against it.
  std::optional<int64_t> reused_keyframe;
  KeyframeReason keyframe_reason = KeyframeReason::kNone;  ///< why, if new_keyframe
};

/// The result of FrameTracker::step(): a pose, or the frame whose 3D stage it needs first.
struct TrackingStep {
  std::optional<estimator::MotionChainOutput> pose;
  TrackingStats stats;
  /// Set when no pose was given: step() again after handing in this frame's 3D stage.
  std::optional<int64_t> awaiting_lifted;
  bool posed() const { return pose.has_value(); }
};

class FrameTracker {
 public:
  explicit FrameTracker(const TrackingOptions& options = {});

  /// Starts (or restarts) tracking at `first`: FIRST_FRAME with T_w_c = identity.
  estimator::MotionChainOutput initialise(const FrameFeatures& first);

  /// Restarts tracking at `current` without a motion estimate: the last pose is held and the
  /// status is REINITIALISED (e.g. the reference never arrived).
  estimator::MotionChainOutput restart(const FrameFeatures& current);

  /// Hands in the 3D stage of a posed frame, which a later step() may need. False (nothing
  /// kept) when no later frame can use it: not the frame posed last, nor one whose landmark
  /// fusion is due.
  /// A rolling-shutter frame (camera.readout_s > 0) is first moved to its stamp with the
  /// velocity of the frames posed before it (rolling_shutter.h).
  bool addLifted(FrameFeatures lifted);
  /// Whether addLifted() would keep the 3D stage of frame `seq` (checked before decoding).
  bool wantsLifted(int64_t seq) const { return lifted_.wants(seq); }

  /// Poses `current` (its 2D stage) when the 3D stages it needs are in; otherwise says which
  /// frame's it waits for and changes nothing (step again after addLifted()). With keyframes a
  /// frame is posed against the keyframe without the previous frame's 3D stage, unless that
  /// frame is the next keyframe or the estimate is rejected (the previous frame then serves).
  /// Landmark fusion runs one frame behind: the 3D stage of frame k refines the keyframe
  /// before frame k+2 is posed, so that frame k+1 never waits for it; the result is the same
  /// whatever the order of arrival (docs/estimator.md, "Poses ahead of the fused depth").
  /// A rolling-shutter frame is first moved to its stamp with the predicted angular velocity
  /// (rolling_shutter.h).
  TrackingStep step(const FrameFeatures& current);

  /// For callers that have every frame's 3D stage before the next frame: hands in
  /// `reference` (the 3D stage of the frame posed last) and poses `current`. When `reference`
  /// is not that frame (frames lost in between, or the stream restarted), tracking restarts
  /// at `current` and stats->reinitialised is set.
  estimator::MotionChainOutput track(const FrameFeatures& reference, const FrameFeatures& current,
                                     TrackingStats* stats = nullptr);

  /// Sequence number of the last frame given a pose, if any.
  std::optional<int64_t> lastPosed() const { return lifted_.lastPosed(); }
  /// Whether later frames will be tracked against the 3D features of `seq`, the frame given a
  /// pose last: kReference for a new keyframe and for every frame when tracking frame to
  /// frame, kFallbackOnly for the others (only a keyframe fallback would use them).
  ReferenceRole referenceRole(int64_t seq) const;

  const KeyframeStore& keyframes() const { return keyframes_; }
  const LocalMapper& localMapper() const { return mapper_; }
  const estimator::MotionChain& tracker() const { return tracker_; }
  const TrackingOptions& options() const { return options_; }
  const StageTimings& timings() const { return timings_; }
  /// The readout read from the frames (options().readout_from_frames).
  const ReadoutEstimator& readoutEstimator() const { return readout_; }

 private:
  /// A frame chosen to become the next keyframe once its 3D stage is in.
  struct PendingKeyframe {
    int64_t seq;
    KeyframeReason reason;
  };

  /// The velocity a rolling-shutter frame `seq` is compensated with: the mean of the last
  /// kVelocityFrames posed before it. nullopt before any frame was posed.
  std::optional<CameraVelocity> smoothedVelocity(int64_t seq) const;
  /// Whether the 3D stage of `seq` (a recent frame) was moved to its stamp.
  bool recentlyCompensated(int64_t seq) const;
  /// Whether the reference the next frame is tracked against was moved to its stamp.
  bool referenceCompensated() const;
  static constexpr int kVelocityFrames = 4;
  /// The velocity of frame `seq` as it moved: the mean of its motion in and the next frame's
  /// (centred on it); nullopt until the next frame was posed.
  std::optional<CameraVelocity> centredVelocity(int64_t seq) const;
  /// The readout that frames of `camera` are compensated with: the calibration's, else the
  /// one read from the frames, else 0 (as read).
  double readoutOf(const PinholeCamera& camera) const;
  /// Whether frames of `camera` are read for their readout.
  bool readsReadout(const PinholeCamera& camera) const;
  /// Reads the readout of `current` (tracked against `keyframe` at T_curr_kf, the previous
  /// frame at T_prev_kf) from both frames as read, into pending_reading_. `matches` are the
  /// tracking's, used when it tracked against the keyframe's own features.
  void readReadoutAgainst(const Keyframe& keyframe, const FrameFeatures& current,
                          const Pose3& T_curr_kf, const Pose3& T_prev_kf,
                          const FeatureMatches& matches);
  /// step() on a frame at its stamp (rolling shutter compensated).
  TrackingStep stepAtStamp(const FrameFeatures& current);
  /// The matches of a reference and a current frame, gated around their positions predicted
  /// by T_curr_ref, of the families `use` selects.
  FeatureMatches match(const FrameFeatures& reference, const FrameFeatures& current,
                       const Pose3& T_curr_ref, const estimator::PoseEstimatorOptions& use);
  /// Keeps tracked_from_keyframe_ up to date after frame `seq` was posed (local map only).
  void followFromKeyframe(int64_t seq, int64_t previous_seq,
                          const estimator::MotionChainOutput& pose,
                          const estimator::PoseEstimate* through_keyframe);
  /// The correspondences of `current` with `reference` (buildCorrespondences), its 2D
  /// observations moved by the readout's translation when it is the frame of
  /// readout_translation_, at the depths the predicted pose T_curr_ref gives.
  estimator::Correspondences correspondences(const FrameFeatures& reference,
                                             const FrameFeatures& current,
                                             const FeatureMatches& matches,
                                             const Pose3& T_curr_ref_predicted) const;
  /// Matches `current` against a keyframe's `landmarks` (gates around T_curr_kf_predicted)
  /// into `matches` and estimates T_curr_kf from them.
  estimator::PoseEstimate estimateAgainst(const FrameFeatures& landmarks,
                                          const FrameFeatures& current,
                                          const Pose3& T_curr_kf_predicted,
                                          FeatureMatches& matches);
  /// Frame `seq`, estimated against the active keyframe, as an observation of its landmarks,
  /// fused once the frame's 3D stage is in (keyframe.fuse_landmarks).
  void observeKeyframe(int64_t seq, const estimator::PoseEstimate& against_keyframe,
                       const FeatureMatches& matches);
  /// The estimate of T_curr_prev through the active keyframe, or nullopt when rejected.
  std::optional<estimator::PoseEstimate> estimateFromKeyframe(const FrameFeatures& current,
                                                              TrackingStats& stats);
  /// step() before the depth's alignment error is added to the published motion.
  TrackingStep stepCompensatingReadout(const FrameFeatures& current);
  /// Adds to `pose` (this frame's published motion) the error of the current frame's depth
  /// moved to its colour instant: scale^2 times the published covariance of the motion it was
  /// moved by, through the share of the solution the frame's planes carry.
  void addDepthAlignmentError(const FrameFeatures& current, estimator::MotionChainOutput& pose);
  /// Tracks `current` against `reference`, the previous frame's 3D stage.
  estimator::MotionChainOutput trackFromPrevious(const FrameFeatures& reference,
                                                 const FrameFeatures& current,
                                                 TrackingStats& stats);
  /// The pose of `lifted` (the next keyframe) relative to the active keyframe from lines and
  /// planes alone, for the local map's bundle adjustment; nullopt when they do not give one.
  std::optional<MapRelativePose> structureMotion(const FrameFeatures& lifted);
  /// When `current` (just posed, tracking) exhausted the active keyframe: the nearest retired
  /// keyframe that still serves it becomes active instead of a new keyframe, and the world
  /// pose becomes the one measured against it. False (nothing changed) when none serves.
  bool reuseRetiredKeyframe(const FrameFeatures& current, TrackingStats& stats);
  /// Fuses the observations whose 3D stage is due; the frame it waits for otherwise.
  std::optional<int64_t> fuseDueObservations();
  /// No active keyframe; with keyframes, `next` becomes one once its 3D stage is in.
  void resetKeyframes(int64_t next, KeyframeReason reason);
  /// Forgets the buffered 3D stages, observations and a rejected estimate.
  void forgetPending();
  /// Marks `current` posed and settles what it leaves for the next frame.
  void finishStep(const FrameFeatures& current, TrackingStats& stats);

  TrackingOptions options_;
  estimator::MotionChain tracker_;
  estimator::PoseEstimator estimator_;
  estimator::PoseEstimator structure_estimator_;  ///< lines and planes only
  /// The last estimate against the active keyframe: the frame's seq, the measurement.
  std::optional<std::pair<int64_t, MapRelativePose>> keyframe_estimate_;
  /// The last posed frame's pose relative to the active keyframe as tracking measured it, with
  /// its covariance, the keyframe's shared error in it (local map: a residual of the adjustment
  /// if the frame becomes a keyframe).
  std::optional<std::pair<int64_t, MapRelativePose>> tracked_from_keyframe_;
  /// The last frames' published motions (seq, covariance of xi(T_prev_curr)): the depth
  /// filter moves a frame's depth by one of them.
  std::deque<std::pair<int64_t, Matrix6d>> published_motions_;
  /// The last posed frame and the keyframe its pose was measured against (through the
  /// keyframe, or from the keyframe's own frame): the next motion through that keyframe is the
  /// difference of two estimates against it (the shared-error estimate reads it so).
  std::optional<std::pair<int64_t, int64_t>> measured_against_keyframe_;
  /// Whether frames are tracked against keyframes (kKeyframe or kLocalMap).
  bool usesKeyframes() const { return options_.reference != TrackingReference::kFrame; }

  KeyframeStore keyframes_;
  LocalMapper mapper_;
  /// Whether the local map's keyframes were lifted at their stamps (the rolling shutter
  /// compensated) or as read; unset while the map is empty.
  std::optional<bool> map_at_stamp_;
  LiftedStageBuffer lifted_;
  std::optional<PendingKeyframe> pending_keyframe_;
  /// The frame whose estimate against the keyframe was rejected while it waited for the
  /// previous frame's 3D stage (the fallback): not estimated twice.
  std::optional<int64_t> keyframe_rejected_seq_;
  StageTimings timings_;
  /// Velocity (camera frame) of the recently posed frames, for the rolling-shutter
  /// compensation of their 3D stages (oldest first).
  std::deque<std::pair<int64_t, CameraVelocity>> velocity_;
  /// The frame being tracked, when its 2D stage (no depth) was turned to its stamp, and the
  /// linear velocity its correspondences are moved by (compensateReadoutTranslation).
  struct ReadoutTranslation {
    int64_t seq = -1;
    Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
    double readout_s = 0;
  };
  std::optional<ReadoutTranslation> readout_translation_;
  /// Time between consecutive frames (s), from their stamps; 0 until two frames were posed.
  double frame_interval_s_ = 0;
  std::optional<std::pair<int64_t, int64_t>> last_posed_stamp_;  ///< (seq, utime)
  /// The recent frames whose 3D stage was moved to its stamp (a keyframe says so itself,
  /// Keyframe::at_stamp): a frame is compensated only against a compensated reference.
  std::deque<int64_t> compensated_lifted_;
  /// The readout read from the frames, and what it is read from: the last 3D stages as they
  /// arrived (one of them becomes the keyframe), the active keyframe's as read, its centred
  /// velocity, the frame being stepped as read (set during step() only) and its reading, added
  /// once the frame keeps tracking.
  ReadoutEstimator readout_;
  std::deque<FrameFeatures> lifted_as_read_;
  std::optional<FrameFeatures> keyframe_as_read_;
  std::optional<CameraVelocity> keyframe_velocity_;
  const FrameFeatures* current_as_read_ = nullptr;
  std::optional<std::pair<int64_t, ReadoutReading>> pending_reading_;
};

}  // namespace pplvo::tracking

namespace pplvo::config {
template <>
struct EnumText<tracking::TrackingReference> {
  static bool parse(const std::string& s, tracking::TrackingReference* out) {
    return tracking::parseTrackingReference(s, out);
  }
  static std::string name(tracking::TrackingReference r) { return tracking::toString(r); }
  static const char* choices() { return "frame, keyframe, local_map"; }
};
}  // namespace pplvo::config
