#pragma once
/// The local map's data: keyframe poses and the point landmarks they observed, each landmark
/// with every keyframe's measurement of it (docs/estimator.md, "Local map"). The policy that
/// fills and adjusts it is the LocalMapper (local_mapper.h).
///
/// A keyframe keeps its pose and the ids of the landmarks it observed (its covisibility);
/// a landmark keeps its world position and covariance, the descriptor of its latest
/// observation (the appearance closest to the next frames') and each observation as the 3D
/// point measured in that keyframe with its covariance, which is all local bundle adjustment
/// needs. No images, lines or planes are stored: a few tens of kB per keyframe.
///
/// Iteration order is the order of ids (std::map), so everything built from the map is
/// deterministic. Thread safety: none; one owner.
#include <cstdint>
#include <deque>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "pplvo/core/geometry.h"

namespace pplvo::tracking {

struct MapObservation {
  int64_t keyframe_seq = -1;
  Eigen::Vector3d p_kf = Eigen::Vector3d::Zero();  ///< measured in the keyframe's camera frame
  Eigen::Matrix3d cov_kf = Eigen::Matrix3d::Zero();
  double sigma_px = 1.0;  ///< of its pixel (keypoint scale)
};

struct MapPoint {
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov_w = Eigen::Matrix3d::Identity();
  cv::Mat descriptor;                        ///< one row
  std::vector<MapObservation> observations;  ///< in order of keyframes
};

/// A keyframe's pose relative to an earlier one as a measurement gave it.
struct MapRelativePose {
  int64_t from_seq = -1;
  Pose3 T_this_from = Pose3::Identity();
  Matrix6d covariance = Matrix6d::Identity();  ///< of xi(T_this_from)
};

struct MapKeyframe {
  int64_t seq = -1;
  Pose3 T_w_kf = Pose3::Identity();
  std::vector<int64_t> point_ids;  ///< the landmarks it observed
  /// Relative to an earlier keyframe as its lines and planes alone measured it (a residual of
  /// the adjustment, which adjusts points).
  std::optional<MapRelativePose> from_previous;
  /// Relative to the keyframe it was tracked against, as tracking measured it (every feature,
  /// with both frames' shared error): a residual of the adjustment too.
  std::optional<MapRelativePose> tracked;
};

class LocalMap {
 public:
  /// Appends a keyframe (sequence numbers increase); it observes nothing yet.
  void addKeyframe(int64_t seq, const Pose3& T_w_kf,
                   const std::optional<MapRelativePose>& from_previous = std::nullopt,
                   const std::optional<MapRelativePose>& tracked = std::nullopt);
  /// A new landmark first measured by keyframe observation.keyframe_seq (which must be in the
  /// map); its id, -1 if the keyframe is unknown.
  int64_t addPoint(const MapObservation& observation, const cv::Mat& descriptor);
  /// Keyframe observation.keyframe_seq measured landmark `id` too. False when either is unknown
  /// or it already did.
  bool addObservation(int64_t id, const MapObservation& observation, const cv::Mat& descriptor);
  /// Forgets keyframe `seq`'s observation of `id`, and the landmark when no observation is left.
  void removeObservation(int64_t id, int64_t seq);
  /// Drops the oldest keyframe with its observations (landmarks left unobserved go too).
  void eraseOldestKeyframe();
  void reset();

  const std::deque<MapKeyframe>& keyframes() const { return keyframes_; }
  MapKeyframe* keyframe(int64_t seq);
  const MapKeyframe* keyframe(int64_t seq) const;
  const std::map<int64_t, MapPoint>& points() const { return points_; }
  MapPoint* point(int64_t id);

  /// Re-derives a landmark's covariance from its observations with the keyframe poses taken
  /// as known: the information of the measurements, summed in the world frame.
  void updatePointCovariance(int64_t id);

 private:
  std::deque<MapKeyframe> keyframes_;  ///< in order of sequence numbers
  std::map<int64_t, MapPoint> points_;
  int64_t next_point_id_ = 0;
};

}  // namespace pplvo::tracking
