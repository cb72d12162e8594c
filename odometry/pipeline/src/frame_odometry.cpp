#include "pplvo/pipeline/frame_odometry.h"

#include <cmath>
#include <limits>

#include "pplvo/core/enum_names.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/features/line_extractor.h"

namespace pplvo::pipeline {

namespace {

/// A variance of an estimate without its frame's measured image noise: the covariance counts
/// the robust scale s^2 on the point and line terms (pose_estimator.h), which is the same for
/// an estimate against the keyframe and one against any other frame; the keyframe rule
/// compares what the geometry (overlap, parallax, depth of the landmarks) does to it.
double geometricVariance(const PoseEstimate& estimate, double variance) {
  const double s = std::max(1.0, estimate.robust_scale);
  return variance / (s * s);
}

constexpr EnumName<TrackingReference> kTrackingReferenceNames[] = {
    {TrackingReference::kFrame, "frame"}, {TrackingReference::kKeyframe, "keyframe"}};

constexpr EnumName<KeyframeReason> kKeyframeReasonNames[] = {
    {KeyframeReason::kNone, "none"},
    {KeyframeReason::kStart, "start"},
    {KeyframeReason::kFallback, "fallback"},
    {KeyframeReason::kOverlap, "overlap"},
    {KeyframeReason::kUncertainty, "uncertainty"},
    {KeyframeReason::kMotion, "motion"}};

}  // namespace

bool parseTrackingReference(const std::string& text, TrackingReference* out) {
  return parseEnum(kTrackingReferenceNames, text, out);
}

const char* toString(KeyframeReason reason) { return enumName(kKeyframeReasonNames, reason); }

const char* toString(TrackingReference reference) {
  return enumName(kTrackingReferenceNames, reference);
}

FrameOdometry::FrameOdometry(const FrameOdometryOptions& options)
    : options_(options), tracker_(options.tracker) {}

void FrameOdometry::setFamilies(const FeatureFamilies& families) {
  options_.tracker.estimator.use_points = families.points;
  options_.tracker.estimator.use_lines = families.lines;
  options_.tracker.estimator.use_planes = families.planes;
  tracker_ = OdometryTracker(options_.tracker);
  last_seq_ = -1;
  keyframe_.reset();
  pending_keyframe_seq_ = -1;
  keyframe_count_ = 0;
  forgetPending();
}

void FrameOdometry::forgetPending() {
  pending_fusions_.clear();
  lifted_.clear();
  keyframe_rejected_seq_ = -1;
}

void FrameOdometry::resetKeyframes(int64_t next_keyframe_seq, KeyframeReason reason) {
  keyframe_.reset();
  pending_keyframe_covariance_.reset();
  pending_fusions_.clear();  // they would refine the keyframe dropped here
  const bool keyframes = options_.reference == TrackingReference::kKeyframe;
  pending_keyframe_seq_ = keyframes ? next_keyframe_seq : -1;
  pending_reason_ = keyframes ? reason : KeyframeReason::kNone;
}

TrackerOutput FrameOdometry::initialise(const FrameFeatures& first) {
  forgetPending();
  last_seq_ = first.seq;
  resetKeyframes(first.seq, KeyframeReason::kStart);
  return tracker_.initialise(first.seq);
}

TrackerOutput FrameOdometry::restart(const FrameFeatures& current) {
  const Pose3 T_w_c = tracker_.T_w_c();
  forgetPending();
  last_seq_ = current.seq;
  resetKeyframes(current.seq, KeyframeReason::kStart);
  TrackerOutput out = tracker_.initialise(current.seq, T_w_c);
  out.status = TrackingStatus::kReinitialised;
  return out;
}

FeatureMatches FrameOdometry::match(const FrameFeatures& reference, const FrameFeatures& current,
                                    const Pose3& T_curr_ref) {
  const PoseEstimatorOptions& use = options_.tracker.estimator;
  FeatureMatches m;
  if (use.use_points && !reference.points.empty() && !current.points.empty()) {
    ScopedStageTimer t(timings_, "match_points");
    // Where the previous 3D point should appear under the predicted motion: the gate is then
    // centred there (tight), which keeps fast rotations matchable.
    std::vector<Eigen::Vector2d> predicted;
    if (options_.predict_point_positions) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      predicted.assign(reference.points.size(), Eigen::Vector2d(nan, nan));
      for (size_t i = 0; i < reference.points.size(); ++i) {
        const PointFeature& p = reference.points[i];
        if (!p.has_3d) continue;
        const Eigen::Vector3d X = T_curr_ref * p.point.p;
        if (X.z() > 1e-3) predicted[i] = current.camera.project(X);
      }
    }
    m.points = features::matchPoints(reference, current, options_.point_matching, predicted).pairs;
  }
  if (use.use_lines && !reference.lines.empty() && !current.lines.empty()) {
    ScopedStageTimer t(timings_, "match_lines");
    if (options_.predict_line_positions) {
      // The reference lines' 2D equations moved to where their 3D segments project under the
      // predicted motion, so the gate is centred there (as for points).
      std::vector<LineFeature> predicted = reference.lines;
      for (LineFeature& l : predicted) {
        if (!l.has_3d) continue;
        const Eigen::Vector3d a = T_curr_ref * l.line.p1, b = T_curr_ref * l.line.p2;
        if (a.z() <= 1e-3 || b.z() <= 1e-3) continue;
        const Eigen::Vector3d eq =
            features::lineEquation(current.camera.project(a), current.camera.project(b));
        if (eq.allFinite()) l.eq = eq;
      }
      m.lines = features::matchLines(predicted, reference.line_descriptors, current.lines,
                                     current.line_descriptors, options_.line_matching)
                    .pairs;
    } else {
      m.lines = features::matchLines(reference, current, options_.line_matching).pairs;
    }
  }
  if (use.use_planes && !reference.planes.empty() && !current.planes.empty()) {
    ScopedStageTimer t(timings_, "match_planes");
    std::optional<Pose3> prediction;
    if (options_.predict_plane_positions) prediction = T_curr_ref;
    m.planes =
        geometry::matchPlanesWithStats(reference, current, options_.plane_matching, prediction)
            .matches;
  }
  return m;
}

TrackerOutput FrameOdometry::track(const FrameFeatures& reference, const FrameFeatures& current,
                                   FrameOdometryStats* stats) {
  FrameOdometryStats local;
  FrameOdometryStats& s = stats ? *stats : local;
  s = FrameOdometryStats{};
  if (last_seq_ < 0 || reference.seq != last_seq_) {
    // The reference is not the frame tracked last (frames were lost in between or the stream
    // restarted): a motion from it would not chain onto T_w_c. Restart at this frame.
    s.reinitialised = true;
    return last_seq_ < 0 ? initialise(current) : restart(current);
  }
  addLifted(reference);
  if (std::optional<TrackerOutput> out = tryTrack(current, &s)) return *out;
  // Only a pending fusion can wait for a 3D stage other than `reference`; a caller of this
  // form handed it in with the previous call, so this is a frame whose 3D stage was skipped.
  s = FrameOdometryStats{};
  s.reinitialised = true;
  return restart(current);
}

bool FrameOdometry::wantsLifted(int64_t seq) const {
  if (last_seq_ < 0 || seq < 0) return false;
  if (seq == last_seq_) return true;
  for (const PendingFusion& f : pending_fusions_) {
    if (f.seq == seq) return true;
  }
  return false;
}

bool FrameOdometry::addLifted(FrameFeatures lifted) {
  if (!wantsLifted(lifted.seq)) return false;
  auto it = lifted_.begin();
  while (it != lifted_.end() && it->seq < lifted.seq) ++it;
  if (it != lifted_.end() && it->seq == lifted.seq) {
    *it = std::move(lifted);  // the same frame again: the newer message serves
  } else {
    lifted_.insert(it, std::move(lifted));
  }
  return true;
}

const FrameFeatures* FrameOdometry::lifted(int64_t seq) const {
  for (const FrameFeatures& f : lifted_) {
    if (f.seq == seq) return &f;
  }
  return nullptr;
}

void FrameOdometry::pruneLifted() {
  for (auto it = lifted_.begin(); it != lifted_.end();) {
    it = wantsLifted(it->seq) ? it + 1 : lifted_.erase(it);
  }
}

std::optional<TrackerOutput> FrameOdometry::tryTrack(const FrameFeatures& current,
                                                     FrameOdometryStats* stats) {
  FrameOdometryStats local;
  FrameOdometryStats& s = stats ? *stats : local;
  s = FrameOdometryStats{};
  awaited_lifted_ = -1;
  if (last_seq_ < 0) return initialise(current);
  if (current.seq <= last_seq_) {
    // The stream restarted: a motion to an older frame would not chain onto T_w_c.
    s.reinitialised = true;
    return restart(current);
  }
  const bool keyframes = options_.reference == TrackingReference::kKeyframe;
  // Landmark fusion one frame behind: the frames posed before the previous one refine the
  // keyframe now (their order of arrival does not matter, the result is the same).
  while (!pending_fusions_.empty() && pending_fusions_.front().seq < last_seq_) {
    const FrameFeatures* observed = lifted(pending_fusions_.front().seq);
    if (observed == nullptr) {
      awaited_lifted_ = pending_fusions_.front().seq;
      return std::nullopt;
    }
    if (keyframe_) {
      ScopedStageTimer t(timings_, "landmark_fusion");
      fuseIntoKeyframe(*observed, pending_fusions_.front());
    }
    pending_fusions_.pop_front();
  }
  const FrameFeatures* previous = lifted(last_seq_);
  auto restartOnOtherCamera = [&]() -> std::optional<TrackerOutput> {
    s = FrameOdometryStats{};
    s.reinitialised = true;
    return restart(current);
  };
  if (keyframes && pending_keyframe_seq_ == last_seq_) {
    if (previous == nullptr) {
      awaited_lifted_ = last_seq_;
      return std::nullopt;
    }
    if (current.camera != previous->camera) return restartOnOtherCamera();
    takeKeyframe(*previous);
  }
  if (keyframes && keyframe_ && keyframe_->seq != last_seq_ &&
      keyframe_rejected_seq_ != current.seq) {
    std::optional<PoseEstimate> through_keyframe = estimateFromKeyframe(current, &s);
    if (through_keyframe) {
      TrackerOutput out = tracker_.update(current.seq, *through_keyframe);
      last_seq_ = current.seq;
      if (out.status != TrackingStatus::kTracking) {
        resetKeyframes(current.seq, KeyframeReason::kStart);
      }
      s.new_keyframe = pending_keyframe_seq_ == current.seq;
      if (s.new_keyframe) s.keyframe_reason = pending_reason_;
      pruneLifted();
      return out;
    }
    // The keyframe failed (matches lost, degenerate or too uncertain): the previous frame
    // serves, and this frame starts a new keyframe.
    keyframe_rejected_seq_ = current.seq;
  }
  if (previous == nullptr) {
    awaited_lifted_ = last_seq_;
    return std::nullopt;
  }
  const FrameFeatures& reference = *previous;
  if (current.camera != reference.camera) return restartOnOtherCamera();
  s = FrameOdometryStats{};
  s.keyframe_fallback = keyframe_rejected_seq_ == current.seq;
  keyframe_rejected_seq_ = -1;
  const FeatureMatches matches = match(reference, current, tracker_.predictedMotion());
  s.point_matches = static_cast<int>(matches.points.size());
  s.line_matches = static_cast<int>(matches.lines.size());
  s.plane_matches = static_cast<int>(matches.planes.size());
  s.reference_seq = reference.seq;
  TrackerOutput out;
  {
    ScopedStageTimer t(timings_, "pose");
    out = tracker_.track(reference, current, matches);
  }
  if (keyframes) {
    const bool first_against_keyframe = keyframe_ && keyframe_->seq == reference.seq;
    if (first_against_keyframe && out.estimate.accepted() &&
        out.status == TrackingStatus::kTracking) {
      // The keyframe's reference quality: what the next frames are compared with.
      keyframe_first_rows_ = out.estimate.n_residuals;
      keyframe_first_var_t_ =
          geometricVariance(out.estimate, out.estimate.max_translation_variance_m2);
      keyframe_first_var_q_ = geometricVariance(out.estimate, out.estimate.max_rotation_variance);
    } else {
      resetKeyframes(current.seq,
                     s.keyframe_fallback ? KeyframeReason::kFallback : KeyframeReason::kStart);
    }
    s.new_keyframe = pending_keyframe_seq_ == current.seq;
    if (s.new_keyframe) s.keyframe_reason = pending_reason_;
  }
  last_seq_ = current.seq;
  pruneLifted();
  return out;
}

ReferenceRole FrameOdometry::referenceRole(int64_t seq) const {
  if (options_.reference != TrackingReference::kKeyframe) return ReferenceRole::kReference;
  return pending_keyframe_seq_ == seq ? ReferenceRole::kReference : ReferenceRole::kFallbackOnly;
}

std::optional<PoseEstimate> FrameOdometry::estimateFromKeyframe(const FrameFeatures& current,
                                                                FrameOdometryStats* stats) {
  if (current.camera != keyframe_->camera) return std::nullopt;
  // Indices of the active keyframe's features come first in the local map.
  const FrameFeatures keyframe_or_map = map_.empty() ? FrameFeatures() : localMap();
  const FrameFeatures& keyframe = map_.empty() ? *keyframe_ : keyframe_or_map;
  // The tracker's pose is the previous frame's: T_prev_kf chains the prediction.
  const Pose3 T_prev_kf = tracker_.T_w_c().inverse() * T_w_kf_;
  const Pose3 T_curr_kf_predicted = tracker_.predictedMotion() * T_prev_kf;
  const FeatureMatches matches = match(keyframe, current, T_curr_kf_predicted);
  stats->point_matches = static_cast<int>(matches.points.size());
  stats->line_matches = static_cast<int>(matches.lines.size());
  stats->plane_matches = static_cast<int>(matches.planes.size());
  stats->reference_seq = keyframe.seq;
  PoseEstimate est;
  {
    ScopedStageTimer t(timings_, "pose");
    const PoseEstimator estimator(options_.tracker.estimator);
    // Fused landmarks weigh by their fused covariance; the pose covariance propagates their
    // covariance from before fusion (docs/estimator.md, "Keyframe landmarks").
    const bool unfused =
        options_.keyframe.fuse_landmarks && options_.keyframe.unfused_landmark_covariance;
    est = estimator.estimate(
        buildCorrespondences(keyframe, current, matches, options_.tracker.estimator,
                             unfused ? &keyframe_point_error_cov_ : nullptr),
        current.camera, T_curr_kf_predicted);
  }
  if (!est.accepted() || !isValidPose(est.T_curr_prev, 1e-6) || !est.covariance.allFinite()) {
    return std::nullopt;
  }
  const Pose3 T_curr_kf = est.T_curr_prev;
  if (options_.keyframe.fuse_landmarks) {
    PendingFusion& fusion = pending_fusions_.emplace_back();
    fusion.seq = current.seq;
    fusion.T_kf_frame = T_curr_kf.inverse();
    fusion.covariance = invertedPoseCovariance(T_curr_kf, est.covariance);
    fusion.points = matches.points;
  }
  const KeyframeReason exhausted = keyframeExhausted(est, T_curr_kf);
  if (exhausted != KeyframeReason::kNone) {
    pending_keyframe_seq_ = current.seq;
    pending_reason_ = exhausted;
    pending_keyframe_covariance_ = est.covariance;  // of xi(T_curr_kf)
  }
  // The motion from the previous frame, T_curr_prev = T_curr_kf * T_kf_prev, with the
  // previous frame's pose relative to the keyframe held fixed: its covariance is that of the
  // estimate against the keyframe (conservative: the two frames' errors relative to the same
  // keyframe are positively correlated, so their difference varies less).
  const Pose3 T_kf_prev = T_prev_kf.inverse();
  est.T_curr_prev = T_curr_kf * T_kf_prev;
  est.covariance =
      propagateCompositionCovariance(T_kf_prev, Matrix6d::Zero(), T_curr_kf, est.covariance);
  est.max_translation_variance_m2 = maxTranslationVariance(est.covariance);
  est.max_rotation_variance = maxRotationVariance(est.covariance);
  return est;
}

void FrameOdometry::takeKeyframe(const FrameFeatures& reference) {
  // The previous frame was chosen as keyframe: its 3D features (lifted on its fused depth)
  // are the keyframe's landmarks, its pose is the tracker's current one.
  const int max_map = std::max(0, options_.keyframe.local_map_keyframes);
  if (max_map > 0 && keyframe_ && pending_keyframe_covariance_) {
    const Pose3 T_new_old = tracker_.T_w_c().inverse() * T_w_kf_;
    const Matrix6d& cov = *pending_keyframe_covariance_;
    for (MapKeyframe& e : map_) {
      e.covariance = propagateCompositionCovariance(e.T_kf_this, e.covariance, T_new_old, cov);
      e.T_kf_this = T_new_old * e.T_kf_this;
    }
    map_.push_back({std::move(*keyframe_), T_new_old, cov});
    while (static_cast<int>(map_.size()) > max_map) map_.pop_front();
  } else {
    map_.clear();
  }
  keyframe_ = reference;
  keyframe_point_error_cov_.clear();
  for (const PointFeature& f : keyframe_->points) keyframe_point_error_cov_.push_back(f.point.cov);
  T_w_kf_ = tracker_.T_w_c();
  pending_keyframe_seq_ = -1;
  pending_keyframe_covariance_.reset();
  keyframe_first_rows_ = 0;
  ++keyframe_count_;
  pending_fusions_.clear();  // they refine the keyframe replaced here
  // The map's features in the new keyframe, the relative pose's uncertainty added to each.
  map_points_.clear();
  map_lines_.clear();
  std::vector<int> point_rows, line_rows;
  std::vector<const cv::Mat*> point_desc, line_desc;
  map_point_descriptors_ = cv::Mat();
  map_line_descriptors_ = cv::Mat();
  for (const MapKeyframe& e : map_) {
    const Eigen::Matrix3d R = e.T_kf_this.linear();
    const Eigen::Vector3d q_xyz = poseToXi(e.T_kf_this).tail<3>();
    auto moved = [&](const Eigen::Vector3d& p, const Eigen::Matrix3d& cov, Eigen::Vector3d* p_out,
                     Eigen::Matrix3d* cov_out) {
      Eigen::Matrix<double, 3, 6> J;
      J.leftCols<3>().setIdentity();
      J.rightCols<3>() = rotatedPointJacobian(q_xyz, p);
      *p_out = e.T_kf_this * p;
      *cov_out = R * cov * R.transpose() + J * e.covariance * J.transpose();
    };
    for (size_t i = 0; i < e.features.points.size(); ++i) {
      PointFeature f = e.features.points[i];
      if (!f.has_3d || static_cast<int>(i) >= e.features.point_descriptors.rows) continue;
      moved(f.point.p, f.point.cov, &f.point.p, &f.point.cov);
      map_points_.push_back(f);
      map_point_descriptors_.push_back(e.features.point_descriptors.row(static_cast<int>(i)));
    }
    if (!options_.predict_line_positions) continue;  // old 2D lines say nothing here
    for (size_t i = 0; i < e.features.lines.size(); ++i) {
      LineFeature l = e.features.lines[i];
      if (!l.has_3d || static_cast<int>(i) >= e.features.line_descriptors.rows) continue;
      moved(l.line.p1, l.line.cov1, &l.line.p1, &l.line.cov1);
      moved(l.line.p2, l.line.cov2, &l.line.p2, &l.line.cov2);
      map_lines_.push_back(l);
      map_line_descriptors_.push_back(e.features.line_descriptors.row(static_cast<int>(i)));
    }
  }
}

FrameFeatures FrameOdometry::localMap() const {
  FrameFeatures map = *keyframe_;
  if (!map_points_.empty() && map.point_descriptors.type() == map_point_descriptors_.type() &&
      map.point_descriptors.cols == map_point_descriptors_.cols) {
    map.points.insert(map.points.end(), map_points_.begin(), map_points_.end());
    cv::vconcat(keyframe_->point_descriptors, map_point_descriptors_, map.point_descriptors);
  }
  if (!map_lines_.empty() && map.line_descriptors.type() == map_line_descriptors_.type() &&
      map.line_descriptors.cols == map_line_descriptors_.cols) {
    map.lines.insert(map.lines.end(), map_lines_.begin(), map_lines_.end());
    cv::vconcat(keyframe_->line_descriptors, map_line_descriptors_, map.line_descriptors);
  }
  return map;
}

void FrameOdometry::fuseIntoKeyframe(const FrameFeatures& observed, const PendingFusion& fusion) {
  std::vector<PointFeature>& landmarks = keyframe_->points;
  const Pose3& T = fusion.T_kf_frame;
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d q_xyz = poseToXi(T).tail<3>();
  for (const auto& [i, j] : fusion.points) {
    if (i < 0 || j < 0 || i >= static_cast<int>(landmarks.size()) ||
        j >= static_cast<int>(observed.points.size())) {
      continue;
    }
    PointFeature& landmark = landmarks[i];
    const PointFeature& seen = observed.points[j];
    if (!landmark.has_3d || !seen.has_3d) continue;
    // The observation in the keyframe, with the pose's uncertainty (first order in xi).
    const Eigen::Vector3d p = T * seen.point.p;
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>().setIdentity();
    J.rightCols<3>() = rotatedPointJacobian(q_xyz, seen.point.p);
    const Eigen::Matrix3d C =
        R * seen.point.cov * R.transpose() + J * fusion.covariance * J.transpose();
    const Eigen::Vector3d d = p - landmark.point.p;
    const Eigen::Matrix3d S = landmark.point.cov + C;
    const Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
    if (S_ldlt.info() != Eigen::Success || !(S_ldlt.vectorD().minCoeff() > 0)) continue;
    const double chi2 = d.dot(S_ldlt.solve(d));
    if (!(chi2 < options_.keyframe.fusion_gate_chi2)) continue;
    // Information-weighted mean, in the update form that needs only S^-1:
    // p' = p_L + C_L S^-1 d, C' = C_L - C_L S^-1 C_L.
    const Eigen::Matrix3d K = S_ldlt.solve(landmark.point.cov).transpose();
    const Eigen::Vector3d fused_p = landmark.point.p + K * d;
    Eigen::Matrix3d fused_cov = landmark.point.cov - K * landmark.point.cov;
    fused_cov = 0.5 * (fused_cov + fused_cov.transpose());
    if (!fused_p.allFinite() || !fused_cov.allFinite()) continue;
    landmark.point.p = fused_p;
    landmark.point.cov = fused_cov;
  }
}

KeyframeReason FrameOdometry::keyframeExhausted(const PoseEstimate& against_keyframe,
                                                const Pose3& T_curr_kf) {
  const KeyframeOptions& k = options_.keyframe;
  if (against_keyframe.n_residuals < k.min_inlier_fraction * keyframe_first_rows_) {
    return KeyframeReason::kOverlap;
  }
  // The covariance the weights state (with fused landmarks, without their error from before
  // fusion): the rule's factor g was set with it, and the decisions stay those measured
  // (docs/estimator.md, "Keyframe landmarks").
  const Matrix6d& cov = against_keyframe.covariance_weighted;
  const double var_t = geometricVariance(against_keyframe, maxTranslationVariance(cov));
  const double var_q = geometricVariance(against_keyframe, maxRotationVariance(cov));
  if (var_t > k.max_variance_growth * keyframe_first_var_t_ ||
      var_q > k.max_variance_growth * keyframe_first_var_q_) {
    return KeyframeReason::kUncertainty;
  }
  const double angle_deg = Eigen::AngleAxisd(T_curr_kf.linear()).angle() * 180.0 / M_PI;
  if (T_curr_kf.translation().norm() > k.max_translation_m || angle_deg > k.max_rotation_deg) {
    return KeyframeReason::kMotion;
  }
  return KeyframeReason::kNone;
}

}  // namespace pplvo::pipeline
