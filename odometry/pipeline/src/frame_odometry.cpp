#include "pplvo/pipeline/frame_odometry.h"

#include <cmath>
#include <limits>

namespace pplvo::pipeline {

FrameOdometry::FrameOdometry(const FrameOdometryOptions& options)
    : options_(options), tracker_(options.tracker) {}

void FrameOdometry::setFamilies(const FeatureFamilies& families) {
  options_.tracker.estimator.use_points = families.points;
  options_.tracker.estimator.use_lines = families.lines;
  options_.tracker.estimator.use_planes = families.planes;
  tracker_ = OdometryTracker(options_.tracker);
  last_seq_ = -1;
}

TrackerOutput FrameOdometry::initialise(const FrameFeatures& first) {
  last_seq_ = first.seq;
  return tracker_.initialise(first.seq);
}

TrackerOutput FrameOdometry::restart(const FrameFeatures& current) {
  const Pose3 T_w_c = tracker_.T_w_c();
  last_seq_ = current.seq;
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
    m.lines = features::matchLines(reference, current, options_.line_matching).pairs;
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
  if (last_seq_ < 0 || reference.seq != last_seq_ || current.seq <= reference.seq ||
      current.camera != reference.camera) {
    // The reference is not the frame tracked last (frames were lost in between or the stream
    // restarted): a motion from it would not chain onto T_w_c. Restart at this frame.
    s.reinitialised = true;
    return last_seq_ < 0 ? initialise(current) : restart(current);
  }
  const FeatureMatches matches = match(reference, current, tracker_.predictedMotion());
  s.point_matches = static_cast<int>(matches.points.size());
  s.line_matches = static_cast<int>(matches.lines.size());
  s.plane_matches = static_cast<int>(matches.planes.size());
  TrackerOutput out;
  {
    ScopedStageTimer t(timings_, "pose");
    out = tracker_.track(reference, current, matches);
  }
  last_seq_ = current.seq;
  return out;
}

}  // namespace pplvo::pipeline
