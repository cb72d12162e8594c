#include "pplvo/tracking/frame_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pplvo/core/enum_names.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/features/line_extractor.h"

namespace pplvo::tracking {

namespace {

constexpr EnumName<TrackingReference> kTrackingReferenceNames[] = {
    {TrackingReference::kFrame, "frame"},
    {TrackingReference::kKeyframe, "keyframe"},
    {TrackingReference::kLocalMap, "local_map"}};

void countMatches(const FeatureMatches& m, TrackingStats& s) {
  s.point_matches = static_cast<int>(m.points.size());
  s.line_matches = static_cast<int>(m.lines.size());
  s.plane_matches = static_cast<int>(m.planes.size());
}

estimator::PoseEstimatorOptions structureOnly(estimator::PoseEstimatorOptions o) {
  o.use_points = false;
  return o;
}

/// An estimate a pose can be built on: accepted, a valid rigid motion, a finite covariance.
bool usable(const estimator::PoseEstimate& est) {
  return est.accepted() && isValidPose(est.T_curr_prev, 1e-6) && est.covariance.allFinite();
}

}  // namespace

bool parseTrackingReference(const std::string& text, TrackingReference* out) {
  return parseEnum(kTrackingReferenceNames, text, out);
}

const char* toString(TrackingReference reference) {
  return enumName(kTrackingReferenceNames, reference);
}

FrameTracker::FrameTracker(const TrackingOptions& options)
    : options_(options),
      tracker_(options.tracker),
      estimator_(options.tracker.estimator),
      structure_estimator_(structureOnly(options.tracker.estimator)),
      keyframes_(options.reference == TrackingReference::kKeyframe
                     ? options.keyframe.retired_keyframes
                     : 0),
      mapper_(options.local_map, options.point_matching, options.tracker.estimator) {}

void FrameTracker::forgetPending() {
  lifted_.clearStages();
  keyframe_rejected_seq_.reset();
}

void FrameTracker::resetKeyframes(int64_t next, KeyframeReason reason) {
  keyframes_.clear();
  lifted_.dropObservations();  // they would refine the keyframe dropped here
  pending_keyframe_.reset();
  if (usesKeyframes()) pending_keyframe_ = {next, reason};
}

estimator::MotionChainOutput FrameTracker::initialise(const FrameFeatures& first) {
  tracker_.setFrameTime(first.utime);
  forgetPending();
  lifted_.setLastPosed(first.seq);
  resetKeyframes(first.seq, KeyframeReason::kStart);
  keyframes_.forgetRetired();
  mapper_.reset();
  map_at_stamp_.reset();
  tracked_from_keyframe_.reset();
  last_posed_stamp_ = {first.seq, first.utime};
  return tracker_.initialise(first.seq);
}

estimator::MotionChainOutput FrameTracker::restart(const FrameFeatures& current) {
  const Pose3 T_w_c = tracker_.T_w_c();
  tracker_.setFrameTime(current.utime);
  forgetPending();
  lifted_.setLastPosed(current.seq);
  resetKeyframes(current.seq, KeyframeReason::kStart);
  keyframes_.forgetRetired();
  mapper_.reset();  // its landmarks are not related to the frames after a restart
  map_at_stamp_.reset();
  tracked_from_keyframe_.reset();
  last_posed_stamp_ = {current.seq, current.utime};
  estimator::MotionChainOutput out = tracker_.initialise(current.seq, T_w_c);
  out.status = TrackingStatus::kReinitialised;
  return out;
}

FeatureMatches FrameTracker::match(const FrameFeatures& reference, const FrameFeatures& current,
                                   const Pose3& T_curr_ref,
                                   const estimator::PoseEstimatorOptions& use) {
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

estimator::MotionChainOutput FrameTracker::track(const FrameFeatures& reference,
                                                 const FrameFeatures& current,
                                                 TrackingStats* stats) {
  TrackingStats local;
  TrackingStats& s = stats ? *stats : local;
  s = TrackingStats{};
  const std::optional<int64_t> last = lifted_.lastPosed();
  if (!last || reference.seq != *last) {
    // The reference is not the frame tracked last (frames were lost in between or the stream
    // restarted): a motion from it would not chain onto T_w_c. Restart at this frame.
    s.reinitialised = true;
    return last ? restart(current) : initialise(current);
  }
  addLifted(reference);
  TrackingStep step_result = step(current);
  s = step_result.stats;
  if (step_result.pose) return *step_result.pose;
  // Only an observation's fusion can wait for a 3D stage other than `reference`; a caller of
  // this form handed it in with the previous call, so this is a frame whose 3D stage was
  // skipped.
  s = TrackingStats{};
  s.reinitialised = true;
  return restart(current);
}

std::optional<MapRelativePose> FrameTracker::structureMotion(const FrameFeatures& lifted) {
  const Keyframe* keyframe = keyframes_.active();
  const estimator::PoseEstimatorOptions& use = options_.tracker.estimator;
  if (keyframe == nullptr || !(use.use_lines || use.use_planes) ||
      lifted.camera != keyframe->landmarks.camera) {
    return std::nullopt;
  }
  const Pose3 T_new_kf_predicted = tracker_.T_w_c().inverse() * keyframe->T_w_kf;
  const FeatureMatches matches =
      match(keyframe->landmarks, lifted, T_new_kf_predicted, structure_estimator_.options());
  if (matches.lines.empty() && matches.planes.empty()) return std::nullopt;
  const estimator::PoseEstimate est = structure_estimator_.estimate(
      estimator::buildCorrespondences(keyframe->landmarks, lifted, matches,
                                      structure_estimator_.options()),
      lifted.camera, T_new_kf_predicted);
  if (!usable(est)) return std::nullopt;
  return MapRelativePose{keyframe->seq(), est.T_curr_prev, est.covariance};
}

bool FrameTracker::reuseRetiredKeyframe(const FrameFeatures& current, TrackingStats& stats) {
  const Keyframe* active = keyframes_.active();
  if (active == nullptr || keyframes_.retired().empty()) return false;
  // The nearest retired keyframe within the motion bounds of the keyframe rule (farther ones
  // could not serve), nearness as the larger of the two fractions of those bounds.
  const KeyframeOptions& rule = options_.keyframe;
  const Pose3 T_c_w = tracker_.T_w_c().inverse();
  const Keyframe* nearest = nullptr;
  double nearest_fraction = 1.0;
  for (const Keyframe& k : keyframes_.retired()) {
    if (k.at_stamp != active->at_stamp || k.landmarks.camera != current.camera) continue;
    const Pose3 T_c_k = T_c_w * k.T_w_kf;
    const double angle_deg = Eigen::AngleAxisd(T_c_k.linear()).angle() * 180.0 / M_PI;
    const double fraction = std::max(T_c_k.translation().norm() / rule.max_translation_m,
                                     angle_deg / rule.max_rotation_deg);
    if (fraction < nearest_fraction) {
      nearest = &k;
      nearest_fraction = fraction;
    }
  }
  if (nearest == nullptr || !nearest->baseline) return false;
  FeatureMatches matches;
  const estimator::PoseEstimate est =
      estimateAgainst(nearest->landmarks, current, T_c_w * nearest->T_w_kf, matches);
  // It must serve as well as the keyframe rule asks of the active one.
  if (!usable(est) ||
      keyframeExhausted(rule, *nearest->baseline, est, est.T_curr_prev) != KeyframeReason::kNone) {
    return false;
  }
  const int64_t seq = nearest->seq();
  const Pose3 T_w_k = nearest->T_w_kf;
  keyframes_.reactivate(seq);
  pending_keyframe_.reset();
  lifted_.dropObservations();  // they refine the keyframe retired here
  observeKeyframe(current.seq, est, matches);
  tracker_.correctPose(T_w_k * est.T_curr_prev.inverse());
  measured_against_keyframe_ = {current.seq, seq};
  stats.reused_keyframe = seq;
  return true;
}

std::optional<int64_t> FrameTracker::fuseDueObservations() {
  // Landmark fusion one frame behind: the frames posed before the previous one refine the
  // keyframe now (their order of arrival does not matter, the result is the same).
  while (const KeyframeObservation* due = lifted_.dueObservation()) {
    const FrameFeatures* observed = lifted_.find(due->seq);
    if (observed == nullptr) return due->seq;
    if (keyframes_.active()) {
      ScopedStageTimer t(timings_, "landmark_fusion");
      keyframes_.fuse(*due, *observed, options_.keyframe.fusion_gate_chi2);
    }
    lifted_.popObservation();
  }
  return std::nullopt;
}

std::optional<CameraVelocity> FrameTracker::smoothedVelocity(int64_t seq) const {
  // The mean over the frames posed before `seq`, at most kVelocityFrames: the estimate of one
  // frame feeds the compensation of the next, and a single frame's error would be fed back at
  // full gain (an oscillation that grows); the mean damps it, and a hand-held camera's
  // velocity changes little over a few frames.
  CameraVelocity sum;
  int n = 0;
  for (auto it = velocity_.rbegin(); it != velocity_.rend(); ++it) {
    if (it->first >= seq) continue;
    if (n == kVelocityFrames) break;
    sum.angular += it->second.angular;
    sum.linear += it->second.linear;
    ++n;
  }
  if (n == 0) return std::nullopt;
  return CameraVelocity{sum.angular / n, sum.linear / n};
}

bool FrameTracker::recentlyCompensated(int64_t seq) const {
  return std::find(compensated_lifted_.begin(), compensated_lifted_.end(), seq) !=
         compensated_lifted_.end();
}

std::optional<CameraVelocity> FrameTracker::centredVelocity(int64_t seq) const {
  for (size_t i = 0; i + 1 < velocity_.size(); ++i) {
    if (velocity_[i].first != seq) continue;
    const CameraVelocity& in = velocity_[i].second;
    const CameraVelocity& out = velocity_[i + 1].second;
    return CameraVelocity{0.5 * (in.angular + out.angular), 0.5 * (in.linear + out.linear)};
  }
  return std::nullopt;
}

double FrameTracker::readoutOf(const PinholeCamera& camera) const {
  if (camera.readout_s > 0) return camera.readout_s;
  return readout_.readout_s().value_or(0.0);
}

bool FrameTracker::readsReadout(const PinholeCamera& camera) const {
  // Against a keyframe as it arrived (the local map's newest keyframe too). Not frame to frame:
  // consecutive frames move nearly alike and are sheared nearly alike, and only the change of
  // the velocity between them would show.
  return options_.readout_from_frames && !(camera.readout_s > 0) &&
         options_.reference != TrackingReference::kFrame;
}

void FrameTracker::readReadoutAgainst(const Keyframe& keyframe, const FrameFeatures& current,
                                      const Pose3& T_curr_kf, const Pose3& T_prev_kf,
                                      const FeatureMatches& matches) {
  pending_reading_.reset();
  // The local map's reference holds the landmarks of several keyframes: the frame is matched
  // again against its newest keyframe's own features, at the tracked pose. The keyframe
  // default tracks against those very features, and its matches serve.
  const bool tracked_against_own_features = options_.reference == TrackingReference::kKeyframe;
  if (current_as_read_ == nullptr || current_as_read_->seq != current.seq ||
      !readsReadout(current.camera) || !keyframe_as_read_ ||
      keyframe_as_read_->seq != keyframe.seq() ||
      (tracked_against_own_features &&
       (keyframe_as_read_->points.size() != keyframe.landmarks.points.size() ||
        keyframe_as_read_->lines.size() != keyframe.landmarks.lines.size())) ||
      !last_posed_stamp_) {
    return;
  }
  if (!keyframe_velocity_) keyframe_velocity_ = centredVelocity(keyframe.seq());
  const double interval_s = 1e-6 * static_cast<double>(current.utime - last_posed_stamp_->second);
  if (!keyframe_velocity_ || !(interval_s > 0)) return;
  // The current frame's velocity as it moved: its motion from the previous frame (the
  // smoothed one the compensation uses lags, and its lag would be read as readout).
  const CameraVelocity current_velocity =
      cameraVelocity(T_curr_kf * T_prev_kf.inverse(), interval_s);
  const FeatureMatches own_matches =
      tracked_against_own_features
          ? matches
          : match(*keyframe_as_read_, *current_as_read_, T_curr_kf, options_.tracker.estimator);
  if (const std::optional<ReadoutReading> reading =
          readReadout(*keyframe_as_read_, *current_as_read_, own_matches, T_curr_kf,
                      *keyframe_velocity_, current_velocity)) {
    pending_reading_ = {current.seq, *reading};
  }
}

bool FrameTracker::addLifted(FrameFeatures lifted) {
  if (!lifted_.wants(lifted.seq)) return false;  // not compensated for nothing
  if (readsReadout(lifted.camera)) {
    // As read, for the readout's reading if it becomes the keyframe.
    lifted_as_read_.push_back(lifted);
    while (lifted_as_read_.size() > 3) lifted_as_read_.pop_front();
  }
  if (const double readout = readoutOf(lifted.camera); readout > 0) {
    if (const std::optional<CameraVelocity> velocity = smoothedVelocity(lifted.seq)) {
      compensateRollingShutter(lifted, *velocity, readout);
      compensated_lifted_.push_back(lifted.seq);
      while (compensated_lifted_.size() > 64) compensated_lifted_.pop_front();
    }
  }
  return lifted_.add(std::move(lifted));
}

bool FrameTracker::referenceCompensated() const {
  const std::optional<int64_t> last = lifted_.lastPosed();
  if (!last) return false;
  const bool keyframe_serves = usesKeyframes() && keyframes_.active() &&
                               !(pending_keyframe_ && pending_keyframe_->seq == *last);
  return keyframe_serves ? keyframes_.active()->at_stamp : recentlyCompensated(*last);
}

TrackingStep FrameTracker::step(const FrameFeatures& current) {
  current_as_read_ = &current;  // the readout's reading needs the frame before compensation
  TrackingStep out = stepCompensatingReadout(current);
  current_as_read_ = nullptr;
  if (out.pose) addDepthAlignmentError(current, *out.pose);
  return out;
}

void FrameTracker::addDepthAlignmentError(const FrameFeatures& current,
                                          estimator::MotionChainOutput& pose) {
  // A new start, or a stream that restarted its seqs: the motions kept are not this stream's.
  if (pose.status == TrackingStatus::kFirstFrame ||
      (!published_motions_.empty() && pose.seq <= published_motions_.back().first)) {
    published_motions_.clear();
  }
  pose.depth_alignment_covariance.setZero();
  const DepthTimeAlignment& alignment = current.depth_time_alignment;
  const bool measured =
      pose.status == TrackingStatus::kTracking || pose.status == TrackingStatus::kReinitialised;
  if (options_.depth_alignment_error && measured && alignment.moved()) {
    const auto motion =
        std::find_if(published_motions_.begin(), published_motions_.end(),
                     [&](const auto& m) { return m.first == alignment.motion_seq; });
    if (motion != published_motions_.end()) {
      // The depth was moved by scale x (that motion): its error is scale x that motion's, as
      // a rigid transform of the current camera, to first order in the (small) motion.
      const Matrix6d depth_error = alignment.scale * alignment.scale * motion->second;
      const Matrix6d& A = pose.current_depth_sensitivity;
      const Matrix6d in_curr_prev = A * depth_error * A.transpose();
      const Matrix6d in_prev_curr = invertedPoseCovariance(pose.T_curr_prev, in_curr_prev);
      if (in_prev_curr.allFinite()) {
        pose.depth_alignment_covariance = 0.5 * (in_prev_curr + in_prev_curr.transpose());
        pose.covariance_prev_curr += pose.depth_alignment_covariance;
      }
    }
  }
  published_motions_.emplace_back(pose.seq, pose.covariance_prev_curr);
  constexpr size_t kKept = 16;  // the depth filter uses a motion two or three frames back
  while (published_motions_.size() > kKept) published_motions_.pop_front();
}

TrackingStep FrameTracker::stepCompensatingReadout(const FrameFeatures& current) {
  const double readout = readoutOf(current.camera);
  if (!(readout > 0)) return stepAtStamp(current);
  const std::optional<CameraVelocity> velocity = smoothedVelocity(current.seq);
  if (!velocity) return stepAtStamp(current);  // no velocity yet (first frames): as read
  if (!referenceCompensated()) {
    // The reference was lifted before any velocity was known: a frame is matched against it
    // as read (both sheared alike), and becomes the keyframe, lifted with the velocity, that
    // the next frames are compensated against.
    TrackingStep out = stepAtStamp(current);
    if (out.posed() && usesKeyframes() && !pending_keyframe_) {
      pending_keyframe_ = {current.seq, KeyframeReason::kStart};
      out.stats.new_keyframe = true;
      out.stats.keyframe_reason = KeyframeReason::kStart;
    }
    return out;
  }
  FrameFeatures at_stamp = current;
  compensateRollingShutter(at_stamp, *velocity, readout);
  // Features without depth were only turned: their correspondences take the translation, at
  // the depths of what they match (the pipeline's 2D stage has no depth at all).
  const bool has_depth = std::any_of(current.points.begin(), current.points.end(),
                                     [](const PointFeature& p) { return p.has_3d; }) ||
                         std::any_of(current.lines.begin(), current.lines.end(),
                                     [](const LineFeature& l) { return l.has_3d; });
  if (!has_depth) {
    readout_translation_ = ReadoutTranslation{current.seq, velocity->linear, readout};
  }
  TrackingStep out = stepAtStamp(at_stamp);
  readout_translation_.reset();
  return out;
}

TrackingStep FrameTracker::stepAtStamp(const FrameFeatures& current) {
  // The prediction covers the time since the last frame (dropped frames, a lower rate).
  tracker_.setFrameTime(current.utime);
  TrackingStep out;
  TrackingStats& s = out.stats;
  const std::optional<int64_t> last = lifted_.lastPosed();
  if (!last) {
    out.pose = initialise(current);
    return out;
  }
  if (current.seq <= *last) {
    // The stream restarted: a motion to an older frame would not chain onto T_w_c.
    s.reinitialised = true;
    out.pose = restart(current);
    return out;
  }
  const bool keyframes = usesKeyframes();
  if (const std::optional<int64_t> awaited = fuseDueObservations()) {
    out.awaiting_lifted = awaited;
    return out;
  }
  const FrameFeatures* previous = lifted_.find(*last);
  auto restartOnOtherCamera = [&] {
    s = TrackingStats{};
    s.reinitialised = true;
    out.pose = restart(current);
    return out;
  };
  if (keyframes && pending_keyframe_ && pending_keyframe_->seq == *last) {
    if (previous == nullptr) {
      out.awaiting_lifted = *last;
      return out;
    }
    if (current.camera != previous->camera) return restartOnOtherCamera();
    // The previous frame was chosen as keyframe: its 3D features (lifted on its fused depth)
    // are the keyframe's landmarks, its pose is the tracker's current one.
    const bool at_stamp = recentlyCompensated(previous->seq);
    if (options_.reference == TrackingReference::kLocalMap) {
      ScopedStageTimer t(timings_, "local_map");
      std::optional<MapRelativePose> tracked;
      if (tracked_from_keyframe_ && tracked_from_keyframe_->first == previous->seq) {
        tracked = tracked_from_keyframe_->second;
        tracked->covariance += estimator::frameErrorCovariance(tracker_.frameError());
      }
      if (map_at_stamp_ && *map_at_stamp_ != at_stamp) {
        // The compensation switched on (the first velocity, or a readout read from the
        // frames): landmarks lifted as read are sheared where these are not, and associating
        // and adjusting the two together moves the keyframe by the shear. The map starts again.
        mapper_.reset();
        tracked.reset();
      }
      map_at_stamp_ = at_stamp;
      KeyframeInsertion inserted =
          mapper_.insert(*previous, tracker_.T_w_c(), structureMotion(*previous), tracked);
      // The adjustment moved the keyframe, which is the last posed frame: the next motion is
      // measured from its corrected pose (a jump in that motion would reach the velocity, the
      // rolling-shutter model and the shared-error estimate).
      tracker_.correctPose(inserted.T_w_kf);
      keyframes_.insert(std::move(inserted.reference), inserted.T_w_kf, at_stamp);
    } else {
      keyframes_.insert(*previous, tracker_.T_w_c(), at_stamp);
    }
    keyframe_as_read_.reset();
    keyframe_velocity_.reset();
    for (const FrameFeatures& as_read : lifted_as_read_) {
      if (as_read.seq == previous->seq) keyframe_as_read_ = as_read;
    }
    pending_keyframe_.reset();
    lifted_.dropObservations();  // they refine the keyframe replaced here
  }
  const Keyframe* keyframe = keyframes_.active();
  if (keyframes && keyframe && keyframe->seq() != *last && keyframe_rejected_seq_ != current.seq) {
    if (std::optional<estimator::PoseEstimate> through_keyframe =
            estimateFromKeyframe(current, s)) {
      const int64_t keyframe_seq = keyframe->seq();
      const bool previous_against_it = measured_against_keyframe_ &&
                                       measured_against_keyframe_->first == *last &&
                                       measured_against_keyframe_->second == keyframe_seq;
      out.pose = tracker_.update(current.seq, *through_keyframe,
                                 previous_against_it ? std::optional<int64_t>(keyframe_seq)
                                                     : std::nullopt);
      measured_against_keyframe_.reset();
      if (out.pose->status == TrackingStatus::kTracking) {
        if (pending_reading_ && pending_reading_->first == current.seq) {
          readout_.add(current.seq, keyframe_seq, pending_reading_->second);
        }
        measured_against_keyframe_ = {current.seq, keyframe_seq};
        if (pending_keyframe_ && pending_keyframe_->seq == current.seq &&
            reuseRetiredKeyframe(current, s)) {
          // Published with the pose measured against the earlier keyframe; the motion stays
          // the one measured against the active keyframe (as a local map's correction).
          out.pose->T_w_c = tracker_.T_w_c();
        }
      }
      followFromKeyframe(current.seq, *last, *out.pose, &*through_keyframe);
      if (out.pose->status != TrackingStatus::kTracking) {
        resetKeyframes(current.seq, KeyframeReason::kStart);
      }
      finishStep(current, s);
      return out;
    }
    // The keyframe failed (matches lost, degenerate or too uncertain): the previous frame
    // serves, and this frame starts a new keyframe.
    keyframe_rejected_seq_ = current.seq;
  }
  if (previous == nullptr) {
    out.awaiting_lifted = *last;
    return out;
  }
  if (current.camera != previous->camera) return restartOnOtherCamera();
  s = TrackingStats{};
  s.keyframe_fallback = keyframe_rejected_seq_ == current.seq;
  keyframe_rejected_seq_.reset();
  out.pose = trackFromPrevious(*previous, current, s);
  followFromKeyframe(current.seq, previous->seq, *out.pose, nullptr);
  const bool first_against_keyframe = keyframes && keyframe && keyframe->seq() == previous->seq;
  measured_against_keyframe_.reset();
  if (first_against_keyframe && out.pose->status == TrackingStatus::kTracking) {
    measured_against_keyframe_ = {current.seq, keyframe->seq()};
  }
  if (keyframes) {
    if (first_against_keyframe && out.pose->estimate.accepted() &&
        out.pose->status == TrackingStatus::kTracking) {
      // The keyframe's reference quality: what the next frames are compared with.
      keyframes_.setBaseline(keyframeBaseline(out.pose->estimate));
    } else {
      resetKeyframes(current.seq,
                     s.keyframe_fallback ? KeyframeReason::kFallback : KeyframeReason::kStart);
    }
  }
  finishStep(current, s);
  return out;
}

void FrameTracker::finishStep(const FrameFeatures& current, TrackingStats& stats) {
  if (usesKeyframes()) {
    stats.new_keyframe = pending_keyframe_ && pending_keyframe_->seq == current.seq;
    if (stats.new_keyframe) stats.keyframe_reason = pending_keyframe_->reason;
  }
  lifted_.setLastPosed(current.seq);
  lifted_.prune();
  // The frame interval and this frame's velocity, for the rolling-shutter model.
  if (last_posed_stamp_ && current.seq > last_posed_stamp_->first &&
      current.utime > last_posed_stamp_->second) {
    // Per stream period, as the velocity model's motion is (frames lost on the way or left
    // out by the source both count).
    const int64_t periods =
        std::max<int64_t>(current.seq - last_posed_stamp_->first, tracker_.lastMotionPeriods());
    frame_interval_s_ = 1e-6 * static_cast<double>(current.utime - last_posed_stamp_->second) /
                        static_cast<double>(periods);
  }
  last_posed_stamp_ = {current.seq, current.utime};
  velocity_.emplace_back(current.seq,
                         cameraVelocity(tracker_.predictedMotion(), frame_interval_s_));
  while (velocity_.size() > 64) velocity_.pop_front();
}

estimator::MotionChainOutput FrameTracker::trackFromPrevious(const FrameFeatures& reference,
                                                             const FrameFeatures& current,
                                                             TrackingStats& stats) {
  const Pose3 T_curr_prev_predicted = tracker_.predictedMotion();
  const FeatureMatches matches =
      match(reference, current, T_curr_prev_predicted, options_.tracker.estimator);
  countMatches(matches, stats);
  stats.reference_seq = reference.seq;
  ScopedStageTimer t(timings_, "pose");
  // The chain solves from its prediction (and a weak estimate once more with it as a prior).
  return tracker_.track(current.seq,
                        correspondences(reference, current, matches, T_curr_prev_predicted),
                        current.camera);
}

ReferenceRole FrameTracker::referenceRole(int64_t seq) const {
  if (!usesKeyframes()) return ReferenceRole::kReference;
  return pending_keyframe_ && pending_keyframe_->seq == seq ? ReferenceRole::kReference
                                                            : ReferenceRole::kFallbackOnly;
}

void FrameTracker::followFromKeyframe(int64_t seq, int64_t previous_seq,
                                      const estimator::MotionChainOutput& pose,
                                      const estimator::PoseEstimate* through_keyframe) {
  if (options_.reference != TrackingReference::kLocalMap) return;
  const Keyframe* keyframe = keyframes_.active();
  const bool posed =
      pose.status == TrackingStatus::kTracking || pose.status == TrackingStatus::kVelocityModel;
  if (keyframe == nullptr || !posed) {
    tracked_from_keyframe_.reset();
    return;
  }
  // The shared errors of the frames between cancel along the chain (each is in the motion into
  // and out of its frame); the keyframe's is in here, this frame's is added when it is used.
  const Matrix6d shared = estimator::frameErrorCovariance(tracker_.frameError());
  if (through_keyframe != nullptr && keyframe_estimate_ && keyframe_estimate_->first == seq &&
      pose.T_curr_prev.matrix() == through_keyframe->T_curr_prev.matrix()) {
    // Measured against the keyframe and used as it was.
    MapRelativePose direct = keyframe_estimate_->second;
    direct.covariance += shared;
    tracked_from_keyframe_ = {seq, direct};
    return;
  }
  MapRelativePose chained{keyframe->seq(), Pose3::Identity(), Matrix6d::Zero()};
  if (previous_seq == keyframe->seq()) {
    chained.covariance = shared;
  } else if (tracked_from_keyframe_ && tracked_from_keyframe_->first == previous_seq &&
             tracked_from_keyframe_->second.from_seq == keyframe->seq()) {
    chained = tracked_from_keyframe_->second;
  } else {
    tracked_from_keyframe_.reset();
    return;
  }
  chained.covariance = propagateCompositionCovariance(chained.T_this_from, chained.covariance,
                                                      pose.T_curr_prev, pose.covariance);
  chained.T_this_from = pose.T_curr_prev * chained.T_this_from;
  tracked_from_keyframe_ = {seq, chained};
}

estimator::PoseEstimate FrameTracker::estimateAgainst(const FrameFeatures& landmarks,
                                                      const FrameFeatures& current,
                                                      const Pose3& T_curr_kf_predicted,
                                                      FeatureMatches& matches) {
  matches = match(landmarks, current, T_curr_kf_predicted, options_.tracker.estimator);
  ScopedStageTimer t(timings_, "pose");
  return estimator_.estimate(correspondences(landmarks, current, matches, T_curr_kf_predicted),
                             current.camera, T_curr_kf_predicted);
}

estimator::Correspondences FrameTracker::correspondences(const FrameFeatures& reference,
                                                         const FrameFeatures& current,
                                                         const FeatureMatches& matches,
                                                         const Pose3& T_curr_ref_predicted) const {
  estimator::Correspondences c =
      estimator::buildCorrespondences(reference, current, matches, options_.tracker.estimator);
  if (readout_translation_ && readout_translation_->seq == current.seq) {
    PinholeCamera camera = current.camera;
    camera.readout_s = readout_translation_->readout_s;
    compensateReadoutTranslation(c, camera, T_curr_ref_predicted,
                                 readout_translation_->linear_velocity);
  }
  return c;
}

void FrameTracker::observeKeyframe(int64_t seq, const estimator::PoseEstimate& against_keyframe,
                                   const FeatureMatches& matches) {
  if (!options_.keyframe.fuse_landmarks) return;
  const Pose3& T_curr_kf = against_keyframe.T_curr_prev;
  lifted_.addObservation({seq, T_curr_kf.inverse(),
                          invertedPoseCovariance(T_curr_kf, against_keyframe.covariance),
                          matches.points});
}

std::optional<estimator::PoseEstimate> FrameTracker::estimateFromKeyframe(
    const FrameFeatures& current, TrackingStats& stats) {
  const Keyframe& keyframe = *keyframes_.active();
  if (current.camera != keyframe.landmarks.camera) return std::nullopt;
  // The tracker's pose is the previous frame's: T_prev_kf chains the prediction.
  const Pose3 T_prev_kf = tracker_.T_w_c().inverse() * keyframe.T_w_kf;
  const Pose3 T_curr_kf_predicted = tracker_.predictedMotion() * T_prev_kf;
  FeatureMatches matches;
  estimator::PoseEstimate est =
      estimateAgainst(keyframe.landmarks, current, T_curr_kf_predicted, matches);
  countMatches(matches, stats);
  stats.reference_seq = keyframe.seq();
  if (!usable(est)) return std::nullopt;
  const Pose3 T_curr_kf = est.T_curr_prev;
  readReadoutAgainst(keyframe, current, T_curr_kf, T_prev_kf, matches);
  keyframe_estimate_ = {current.seq, MapRelativePose{keyframe.seq(), T_curr_kf, est.covariance}};
  observeKeyframe(current.seq, est, matches);
  const KeyframeReason exhausted = keyframeExhausted(
      options_.keyframe, keyframe.baseline.value_or(KeyframeBaseline{}), est, T_curr_kf);
  if (exhausted != KeyframeReason::kNone) pending_keyframe_ = {current.seq, exhausted};
  // The motion from the previous frame, T_curr_prev = T_curr_kf * T_kf_prev, with the
  // previous frame's pose relative to the keyframe held fixed: its covariance is that of the
  // estimate against the keyframe (conservative: the two frames' errors relative to the same
  // keyframe are positively correlated, so their difference varies less).
  const Pose3 T_kf_prev = T_prev_kf.inverse();
  est.T_curr_prev = T_curr_kf * T_kf_prev;
  est.covariance =
      propagateCompositionCovariance(T_kf_prev, Matrix6d::Zero(), T_curr_kf, est.covariance);
  if (est.covariance_at_measured_spread) {
    est.covariance_at_measured_spread = propagateCompositionCovariance(
        T_kf_prev, Matrix6d::Zero(), T_curr_kf, *est.covariance_at_measured_spread);
  }
  est.max_translation_variance_m2 = maxTranslationVariance(est.covariance);
  est.max_rotation_variance = maxRotationVariance(est.covariance);
  return est;
}

}  // namespace pplvo::tracking
