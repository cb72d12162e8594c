#pragma once
/// Frame-to-frame odometry as one object (paper Sec. "Matching" and "Pose Estimation"): the
/// current frame's 2D features (points, lines, C-GM planes) are matched against the previous
/// frame's 3D features (lifted on its fused depth), and the tracker estimates the motion,
/// its covariance and the window uncertainties the depth filter needs. No LCM.
#include <cstdint>

#include "pplvo/core/features.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/estimator/odometry_tracker.h"
#include "pplvo/features/matching.h"
#include "pplvo/geometry/plane_matching.h"
#include "pplvo/pipeline/frontend.h"

namespace pplvo::pipeline {

struct FrameOdometryOptions {
  OdometryTrackerOptions tracker;  ///< tracker.estimator.use_* select the families
  features::PointMatchOptions point_matching;
  features::LineMatchOptions line_matching;
  geometry::PlaneMatchOptions plane_matching;
  /// Gate points around their position predicted by the constant-velocity model.
  bool predict_point_positions = true;
  /// Move the previous planes by the predicted motion before the plane gate.
  bool predict_plane_positions = true;
};

struct FrameOdometryStats {
  int point_matches = 0, line_matches = 0, plane_matches = 0;
  bool reinitialised = false;  ///< no usable reference: tracking restarted at this frame
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
  TrackerOutput track(const FrameFeatures& reference, const FrameFeatures& current,
                      FrameOdometryStats* stats = nullptr);

  /// Sequence number of the last frame given a pose (-1 before the first).
  int64_t lastSeq() const { return last_seq_; }
  const OdometryTracker& tracker() const { return tracker_; }
  const FrameOdometryOptions& options() const { return options_; }
  const StageTimings& timings() const { return timings_; }

  /// The matches of a reference and a current frame with the given prediction of
  /// T_curr_ref (exposed for tests and tools).
  FeatureMatches match(const FrameFeatures& reference, const FrameFeatures& current,
                       const Pose3& T_curr_ref_predicted);

 private:
  FrameOdometryOptions options_;
  OdometryTracker tracker_;
  int64_t last_seq_ = -1;
  StageTimings timings_;
};

}  // namespace pplvo::pipeline
