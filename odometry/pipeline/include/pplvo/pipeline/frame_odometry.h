#pragma once
/// Visual odometry as one object (paper Sec. "Matching" and "Pose Estimation"): the current
/// frame's 2D features (points, lines, C-GM planes) are matched against 3D features lifted on
/// fused depth, either the previous frame's (the paper) or an active keyframe's
/// (docs/estimator.md, "Keyframes"), and the tracker estimates the motion, its covariance and
/// the window uncertainties the depth filter needs. No LCM.
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/estimator/odometry_tracker.h"
#include "pplvo/features/matching.h"
#include "pplvo/geometry/plane_matching.h"
#include "pplvo/pipeline/frontend.h"

namespace pplvo::pipeline {

/// What the current frame's 2D features are matched against.
enum class TrackingReference {
  kFrame,     ///< the previous frame (the paper)
  kKeyframe,  ///< the active keyframe, the previous frame as fallback
};
bool parseTrackingReference(const std::string& text, TrackingReference* out);
const char* toString(TrackingReference reference);

/// When a new keyframe is taken (docs/estimator.md, "Keyframes"). The current frame becomes
/// the keyframe of the next one when any of these holds.
struct KeyframeOptions {
  /// Feature overlap: the estimate against the keyframe kept fewer inlier residual rows than
  /// this fraction of the rows the first frame tracked against it kept (the keyframe's view
  /// is leaving the image, or its features no longer match).
  double min_inlier_fraction = 0.5;
  /// Uncertainty: the largest eigenvalue of the translation (or q_xyz) block of the pose
  /// covariance relative to the keyframe grew beyond this factor of the first frame's; a
  /// new keyframe then restarts from the smaller frame-to-frame uncertainty.
  double max_variance_growth = 2.0;
  /// Parallax bound: translation (m) and rotation (deg) from the keyframe; beyond either,
  /// depth errors of the keyframe's primitives weigh more than a keyframe change costs.
  double max_translation_m = 0.3;
  double max_rotation_deg = 20.0;
  /// The keyframe's 3D points are refined by every later frame tracked against it: the
  /// frame's own 3D point (lifted on its fused depth), moved into the keyframe by the
  /// estimated pose (its covariance included), is fused by information weighting when it
  /// passes the chi-square gate below (docs/estimator.md, "Keyframe landmarks").
  bool fuse_landmarks = true;
  /// Gate on the squared Mahalanobis distance between the keyframe point and the moved
  /// observation (3 dof; 7.81 = 95 %).
  double fusion_gate_chi2 = 7.81;
  /// With fuse_landmarks: the pose covariance of an estimate against the keyframe propagates
  /// each landmark's covariance from before fusion (its weight still uses the fused one).
  /// The observations fused into a landmark were moved into the keyframe by poses estimated
  /// from the landmarks themselves, so they carry the landmarks' error: to first order, fusion
  /// does not reduce the error an estimate against them inherits (docs/estimator.md,
  /// "Keyframe landmarks"). false (default): the fused covariance. With the per-family robust
  /// scales (estimator.family_robust_scales) the points' measured spread already inflates the
  /// covariance enough on the benchmark's sequences, and this on top makes the rendered ones
  /// conservative beyond the band (share inside 0.99-1.00); it stays for points-only tracking.
  bool unfused_landmark_covariance = false;
  /// Local map: the 3D points and lines of up to this many earlier keyframes, moved into the
  /// active keyframe by the chain of keyframe poses (their covariance added), are matched and
  /// used together with the active keyframe's (0: the active keyframe alone). The chain
  /// restarts when a keyframe is taken after a fallback or a restart.
  int local_map_keyframes = 0;
};

/// Schema of KeyframeOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, KeyframeOptions& o) {
  v.field("min_inlier_fraction", o.min_inlier_fraction,
          "new keyframe when the inlier rows against it fall below this fraction of the first "
          "frame's (feature overlap)",
          config::between(0, 1));
  v.field("max_variance_growth", o.max_variance_growth,
          "new keyframe when the pose variance relative to it grows beyond this factor of the "
          "first frame's (largest eigenvalue, translation or rotation block)",
          config::atLeast(1));
  v.field("max_translation_m", o.max_translation_m, "new keyframe beyond this translation (m)",
          config::positive());
  v.field("max_rotation_deg", o.max_rotation_deg, "new keyframe beyond this rotation (deg)",
          config::openClosed(0, 180));
  v.field("fuse_landmarks", o.fuse_landmarks,
          "refine the keyframe's 3D points with every frame tracked against it (information "
          "weighting, chi-square gate)");
  v.field("local_map_keyframes", o.local_map_keyframes,
          "earlier keyframes whose 3D points and lines are matched with the active one's "
          "(0: the active keyframe alone)",
          config::between(0, 10));
  v.field("fusion_gate_chi2", o.fusion_gate_chi2,
          "gate on the squared Mahalanobis distance of an observation (3 dof; 7.81 = 95 %)",
          config::positive());
  v.field("unfused_landmark_covariance", o.unfused_landmark_covariance,
          "the pose covariance against the keyframe propagates each fused landmark's covariance "
          "from before fusion (the observations were registered to the landmarks, so fusion "
          "does not reduce the error the pose inherits); its weight uses the fused one. Off: with "
          "the per-family robust scales it makes the rendered sequences over-conservative "
          "(docs/estimator.md)");
}

struct FrameOdometryOptions {
  TrackingReference reference = TrackingReference::kKeyframe;
  KeyframeOptions keyframe;
  OdometryTrackerOptions tracker;  ///< tracker.estimator.use_* select the families
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
};

/// Schema of FrameOdometryOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, FrameOdometryOptions& o) {
  v.field("reference", o.reference,
          "what a frame is tracked against: frame (the previous one, as in the paper) or "
          "keyframe (the active keyframe, the previous frame as fallback; docs/estimator.md)");
  v.section("keyframe", "When a new keyframe is taken (reference: keyframe)",
            [&] { visit(v, o.keyframe); });
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
}

/// Why a frame was chosen as the next keyframe.
enum class KeyframeReason : int8_t {
  kNone = 0,
  kStart,        ///< first frame, or tracking restarted / not tracking
  kFallback,     ///< the keyframe's estimate failed
  kOverlap,      ///< inlier rows below min_inlier_fraction of the first frame's
  kUncertainty,  ///< pose variance grew beyond max_variance_growth
  kMotion,       ///< translation or rotation bound
};
constexpr int kKeyframeReasons = 6;
const char* toString(KeyframeReason reason);

struct FrameOdometryStats {
  int point_matches = 0, line_matches = 0, plane_matches = 0;
  bool reinitialised = false;      ///< no usable reference: tracking restarted at this frame
  int64_t reference_seq = -1;      ///< the frame whose 3D features the pose was estimated from
  bool keyframe_fallback = false;  ///< the keyframe estimate failed; the previous frame served
  bool new_keyframe = false;       ///< this frame becomes the next frame's keyframe
  KeyframeReason keyframe_reason = KeyframeReason::kNone;  ///< why, if new_keyframe
};

class FrameOdometry {
 public:
  explicit FrameOdometry(const FrameOdometryOptions& options = {});

  /// Sets the families used for matching and estimation (frontend and estimator agree).
  void setFamilies(const FeatureFamilies& families);

  /// Starts (or restarts) tracking at `first`: FIRST_FRAME with T_w_c = identity.
  TrackerOutput initialise(const FrameFeatures& first);

  /// Restarts tracking at `current` without a motion estimate: the last pose is held and the
  /// status is REINITIALISED (e.g. the reference never arrived).
  TrackerOutput restart(const FrameFeatures& current);

  /// Estimates the pose of `current` (2D stage) from `reference`, the 3D stage of the frame
  /// tracked last. `reference.seq` must be that frame; otherwise (frames lost in between)
  /// tracking restarts at `current` (see restart()) and stats->reinitialised is set.
  /// With TrackingReference::kKeyframe, `reference` is kept as the keyframe when the last
  /// call chose it, and `current` is matched against the active keyframe (falling back to
  /// `reference` when that estimate is rejected). The same as addLifted(reference) followed
  /// by tryTrack(current), for callers that have every frame's 3D stage before the next one.
  TrackerOutput track(const FrameFeatures& reference, const FrameFeatures& current,
                      FrameOdometryStats* stats = nullptr);

  /// The pipelined form (docs/estimator.md, "Poses ahead of the fused depth"): hands in the
  /// 3D stage of a posed frame, which tracking may need later. False (nothing kept) when no
  /// later frame can use it: not the frame posed last, nor one whose landmark fusion is due.
  bool addLifted(FrameFeatures lifted);
  /// Whether addLifted() would keep the 3D stage of frame `seq` (checked before decoding).
  bool wantsLifted(int64_t seq) const;
  /// Poses `current` when the 3D stages it needs are in, else returns nullopt and
  /// awaitedLifted() names the frame it waits for (nothing changed: call again after
  /// addLifted()). With keyframes, a frame is posed against the keyframe and the local map
  /// without the previous frame's 3D stage, unless that frame is the next keyframe or the
  /// estimate is rejected (the previous frame then serves). Landmark fusion is one frame
  /// behind: the 3D stage of frame k refines the keyframe before frame k+2 is posed, so that
  /// frame k+1 never waits for it; the result is the same whatever the order of arrival.
  std::optional<TrackerOutput> tryTrack(const FrameFeatures& current,
                                        FrameOdometryStats* stats = nullptr);
  /// The frame whose 3D stage the last tryTrack() waited for (-1: it did not wait).
  int64_t awaitedLifted() const { return awaited_lifted_; }

  /// Sequence number of the last frame given a pose (-1 before the first).
  int64_t lastSeq() const { return last_seq_; }
  /// The active keyframe's sequence number (-1: none yet, or frame-to-frame tracking).
  int64_t keyframeSeq() const { return keyframe_ ? keyframe_->seq : -1; }
  /// Whether later frames will be tracked against the 3D features of `seq`, the frame given a
  /// pose last: kReference for a new keyframe and for every frame when tracking frame to
  /// frame, kFallbackOnly for the others (only a keyframe fallback would use them).
  ReferenceRole referenceRole(int64_t seq) const;
  /// Keyframes taken since construction (or setFamilies()).
  int64_t keyframeCount() const { return keyframe_count_; }
  const OdometryTracker& tracker() const { return tracker_; }
  const FrameOdometryOptions& options() const { return options_; }
  const StageTimings& timings() const { return timings_; }

  /// The matches of a reference and a current frame with the given prediction of
  /// T_curr_ref (exposed for tests and tools).
  FeatureMatches match(const FrameFeatures& reference, const FrameFeatures& current,
                       const Pose3& T_curr_ref_predicted);

 private:
  /// The estimate of T_curr_prev through the keyframe, or nullopt when it was rejected.
  std::optional<PoseEstimate> estimateFromKeyframe(const FrameFeatures& current,
                                                   FrameOdometryStats* stats);
  /// Applies the keyframe rule to an accepted estimate against the keyframe.
  KeyframeReason keyframeExhausted(const PoseEstimate& against_keyframe, const Pose3& T_curr_kf);
  void resetKeyframes(int64_t next_keyframe_seq, KeyframeReason reason);
  struct PendingFusion;
  /// Fuses the 3D points of `observed` (a frame tracked against the keyframe) into the
  /// keyframe's points they were matched to.
  void fuseIntoKeyframe(const FrameFeatures& observed, const PendingFusion& fusion);
  /// The kept 3D stage of frame `seq`, or nullptr.
  const FrameFeatures* lifted(int64_t seq) const;
  /// Drops the kept state of earlier frames: pending fusions, 3D stages, a rejected estimate.
  void forgetPending();
  /// Drops the 3D stages no later frame can use.
  void pruneLifted();
  /// Takes `reference` as the active keyframe; the one it replaces joins the local map when
  /// the new one was chosen through it.
  void takeKeyframe(const FrameFeatures& reference);
  /// The active keyframe with the local map's points and lines appended (in its frame).
  FrameFeatures localMap() const;

  FrameOdometryOptions options_;
  OdometryTracker tracker_;
  int64_t last_seq_ = -1;
  StageTimings timings_;

  // Keyframe state (bounded: one keyframe's features).
  std::optional<FrameFeatures> keyframe_;
  /// The keyframe's own point covariances, before any fusion (by point index).
  std::vector<Eigen::Matrix3d> keyframe_point_error_cov_;
  Pose3 T_w_kf_ = Pose3::Identity();
  int64_t pending_keyframe_seq_ = -1;  ///< the frame whose 3D features become the keyframe
  KeyframeReason pending_reason_ = KeyframeReason::kNone;
  int keyframe_first_rows_ = 0;  ///< inlier rows of the first frame tracked against it
  double keyframe_first_var_t_ = 0, keyframe_first_var_q_ = 0;
  int64_t keyframe_count_ = 0;
  /// A frame tracked against the keyframe, waiting for its 3D features to refine the
  /// keyframe's points: its pose in the keyframe and the point matches (keyframe, frame).
  struct PendingFusion {
    int64_t seq = -1;
    Pose3 T_kf_frame = Pose3::Identity();
    Matrix6d covariance = Matrix6d::Zero();  ///< of xi(T_kf_frame)
    std::vector<std::pair<int, int>> points;
  };
  /// Oldest first; at most the last two posed frames (fusion is one frame behind).
  std::deque<PendingFusion> pending_fusions_;
  /// 3D stages handed in that later frames may need (the last posed frame's, and those of
  /// pending fusions), oldest first.
  std::deque<FrameFeatures> lifted_;
  /// The frame whose estimate against the keyframe was rejected while it waited for the
  /// previous frame's 3D stage (the fallback): not estimated twice.
  int64_t keyframe_rejected_seq_ = -1;
  int64_t awaited_lifted_ = -1;
  /// Covariance of xi(T_pending_kf), the pending keyframe's pose in the active keyframe,
  /// when it was chosen through an estimate against the active keyframe.
  std::optional<Matrix6d> pending_keyframe_covariance_;
  /// Earlier keyframes of the local map, oldest first, with their pose in the active
  /// keyframe and its covariance; `map_points_`/`map_lines_` hold their 3D features moved
  /// into the active keyframe (with descriptors), rebuilt at each keyframe.
  struct MapKeyframe {
    FrameFeatures features;
    Pose3 T_kf_this = Pose3::Identity();
    Matrix6d covariance = Matrix6d::Zero();
  };
  std::deque<MapKeyframe> map_;
  std::vector<PointFeature> map_points_;
  cv::Mat map_point_descriptors_;
  std::vector<LineFeature> map_lines_;
  cv::Mat map_line_descriptors_;
};

}  // namespace pplvo::pipeline

namespace pplvo::config {
template <>
struct EnumText<pipeline::TrackingReference> {
  static bool parse(const std::string& s, pipeline::TrackingReference* out) {
    return pipeline::parseTrackingReference(s, out);
  }
  static std::string name(pipeline::TrackingReference r) { return pipeline::toString(r); }
  static const char* choices() { return "frame, keyframe"; }
};
}  // namespace pplvo::config
