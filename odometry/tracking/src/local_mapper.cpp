#include "pplvo/tracking/local_mapper.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::tracking {

namespace {

/// Landmark ids observed by the keyframes `seqs`, each once, in id order.
std::vector<int64_t> observedBy(const LocalMap& map, const std::vector<int64_t>& seqs) {
  std::vector<int64_t> ids;
  for (const int64_t seq : seqs) {
    if (const MapKeyframe* kf = map.keyframe(seq)) {
      ids.insert(ids.end(), kf->point_ids.begin(), kf->point_ids.end());
    }
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

/// Landmarks seen from a keyframe: in its camera frame, where they project.
struct ProjectedLandmarks {
  std::vector<int64_t> ids;
  std::vector<PointFeature> points;
  cv::Mat descriptors;
};

ProjectedLandmarks project(const LocalMap& map, const std::vector<int64_t>& ids,
                           const Pose3& T_w_kf, const PinholeCamera& camera, double margin_px) {
  ProjectedLandmarks out;
  const Pose3 T_kf_w = T_w_kf.inverse();
  const Eigen::Matrix3d R = T_kf_w.linear();
  for (const int64_t id : ids) {
    const MapPoint& p = map.points().at(id);
    const Eigen::Vector3d X = T_kf_w * p.p_w;
    if (!(X.z() > 0.05)) continue;
    const Eigen::Vector2d px = camera.project(X);
    if (!camera.inImage(px, margin_px)) continue;
    PointFeature f;
    f.px = px;
    f.has_3d = true;
    f.point.p = X;
    f.point.cov = R * p.cov_w * R.transpose();
    out.ids.push_back(id);
    out.points.push_back(f);
    out.descriptors.push_back(p.descriptor);
  }
  return out;
}

/// Every keyframe reachable from keyframe `seq` along the chain of measured relative poses
/// (tracking's, else lines' and planes' alone), with the covariance of xi(T_seq_i): how
/// uncertain keyframe i's pose is relative to `seq` (zero for `seq` itself).
std::map<int64_t, Matrix6d> chainedPoseCovariances(const LocalMap& map, int64_t seq) {
  std::map<int64_t, Matrix6d> out;
  Pose3 T_seq_m = Pose3::Identity();
  Matrix6d cov = Matrix6d::Zero();
  out.emplace(seq, cov);
  for (const MapKeyframe* m = map.keyframe(seq); m != nullptr;) {
    const std::optional<MapRelativePose>& link = m->tracked ? m->tracked : m->from_previous;
    if (!link || link->from_seq >= m->seq) break;
    const MapKeyframe* from = map.keyframe(link->from_seq);
    if (from == nullptr) break;
    cov = propagateCompositionCovariance(link->T_this_from, link->covariance, T_seq_m, cov);
    T_seq_m = T_seq_m * link->T_this_from;
    out.emplace(from->seq, cov);
    m = from;
  }
  return out;
}

/// A keyframe on the chain back from keyframe k: its pose in k and that pose's covariance.
struct CarriedKeyframe {
  Pose3 T_k_i = Pose3::Identity();
  Eigen::Vector3d q_xyz = Eigen::Vector3d::Zero();  ///< of xi(T_k_i)
  Matrix6d cov = Matrix6d::Zero();
};

/// The keyframes of `chained` (chainedPoseCovariances) as seen from keyframe k at T_k_w.
std::map<int64_t, CarriedKeyframe> carriedInto(const LocalMap& map, const Pose3& T_k_w,
                                               const std::map<int64_t, Matrix6d>& chained) {
  std::map<int64_t, CarriedKeyframe> out;
  for (const auto& [seq, cov] : chained) {
    const MapKeyframe* kf = map.keyframe(seq);
    if (kf == nullptr) continue;
    const Pose3 T_k_i = T_k_w * kf->T_w_kf;
    out.emplace(seq, CarriedKeyframe{T_k_i, poseToXi(T_k_i).tail<3>(), cov});
  }
  return out;
}

/// The covariance of landmark `p` in keyframe k's camera frame: the information of its
/// observations, each carried into k with its keyframe's uncertainty relative to k
/// (`carried`). Without the latter, a landmark measured by earlier keyframes would claim their
/// precision in k as if their poses relative to k were known. Observations by keyframes off the
/// chain carry nothing; nullopt when none is on it.
std::optional<Eigen::Matrix3d> covarianceIn(const MapPoint& p,
                                            const std::map<int64_t, CarriedKeyframe>& carried) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  for (const MapObservation& o : p.observations) {
    const auto kf = carried.find(o.keyframe_seq);
    if (kf == carried.end()) continue;
    const CarriedKeyframe& c = kf->second;
    const Eigen::Matrix3d cov =
        transformedPointCovariance(c.T_k_i.linear(), c.q_xyz, c.cov, o.p_kf, o.cov_kf);
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(cov);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0)) continue;
    information += ldlt.solve(Eigen::Matrix3d::Identity());
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(information);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0)) return std::nullopt;
  const Eigen::Matrix3d cov = ldlt.solve(Eigen::Matrix3d::Identity());
  if (!cov.allFinite()) return std::nullopt;
  return Eigen::Matrix3d(0.5 * (cov + cov.transpose()));
}

/// A keyframe's measured poses relative to earlier keyframes (residuals of the adjustment).
constexpr std::optional<MapRelativePose> MapKeyframe::*kRelativePoses[] = {
    &MapKeyframe::from_previous, &MapKeyframe::tracked};

}  // namespace

LocalMapper::LocalMapper(const LocalMapOptions& options,
                         const features::PointMatchOptions& matching,
                         const estimator::PoseEstimatorOptions& pixel)
    : options_(options), matching_(matching), pixel_(pixel) {}

std::vector<int64_t> LocalMapper::window(const Pose3& T_w_kf) const {
  const auto& kfs = map_.keyframes();
  const int n = static_cast<int>(kfs.size());
  const int recent_begin = std::max(0, n - options_.track_keyframes);
  std::vector<int64_t> seqs;
  for (int k = recent_begin; k < n; ++k) seqs.push_back(kfs[k].seq);
  // A return to an earlier place: older keyframes looking at the same part of the scene.
  const double cos_angle = std::cos(options_.nearby_angle_deg * M_PI / 180.0);
  const Eigen::Vector3d axis = T_w_kf.linear().col(2);
  int nearby = 0;
  for (int k = recent_begin - 1; k >= 0 && nearby < options_.nearby_keyframes; --k) {
    const Pose3& T = kfs[k].T_w_kf;
    if ((T.translation() - T_w_kf.translation()).norm() > options_.nearby_distance_m) continue;
    if (T.linear().col(2).dot(axis) < cos_angle) continue;
    seqs.push_back(kfs[k].seq);
    ++nearby;
  }
  std::sort(seqs.begin(), seqs.end());
  return seqs;
}

KeyframeInsertion LocalMapper::insert(const FrameFeatures& lifted, const Pose3& T_w_kf,
                                      const std::optional<MapRelativePose>& from_previous,
                                      const std::optional<MapRelativePose>& tracked) {
  KeyframeInsertion out;
  out.T_w_kf = T_w_kf;
  camera_ = lifted.camera;
  const std::vector<int64_t> before = window(T_w_kf);

  // Associate the keyframe's points with the landmarks projected into it: descriptor match in
  // a tight gate around each projection.
  std::vector<int64_t> landmark_of(lifted.points.size(), -1);
  if (!lifted.points.empty() && !lifted.point_descriptors.empty()) {
    const ProjectedLandmarks seen =
        project(map_, observedBy(map_, before), T_w_kf, lifted.camera, 0.0);
    if (!seen.points.empty() && seen.descriptors.type() == lifted.point_descriptors.type() &&
        seen.descriptors.cols == lifted.point_descriptors.cols) {
      std::vector<Eigen::Vector2d> predicted;
      for (const PointFeature& f : seen.points) predicted.push_back(f.px);
      features::PointMatchOptions gate = matching_;
      gate.predicted_max_px_distance = options_.association_px;
      const features::MatchResult m = features::matchPoints(
          seen.points, seen.descriptors, lifted.points, lifted.point_descriptors, gate, predicted);
      for (const auto& [i, j] : m.pairs) landmark_of[j] = seen.ids[i];
    }
  }

  map_.addKeyframe(lifted.seq, T_w_kf, from_previous, tracked);
  for (size_t j = 0; j < lifted.points.size(); ++j) {
    const PointFeature& f = lifted.points[j];
    if (!f.has_3d || !f.point.p.allFinite() || !f.point.cov.allFinite()) continue;
    const cv::Mat descriptor = lifted.point_descriptors.empty()
                                   ? cv::Mat()
                                   : lifted.point_descriptors.row(static_cast<int>(j));
    const MapObservation observation{
        lifted.seq, f.point.p, f.point.cov,
        pixel_.point_sigma_px * std::pow(pixel_.octave_sigma_scale, std::max(0, f.octave))};
    if (landmark_of[j] >= 0 && map_.addObservation(landmark_of[j], observation, descriptor)) {
      ++out.associated;
    } else {
      map_.addPoint(observation, descriptor);
      ++out.new_points;
    }
  }

  adjust(out);
  while (static_cast<int>(map_.keyframes().size()) > options_.max_keyframes) {
    map_.eraseOldestKeyframe();
  }
  out.T_w_kf = map_.keyframe(lifted.seq)->T_w_kf;
  const std::vector<int64_t> after = window(out.T_w_kf);
  out.window_keyframes = static_cast<int>(after.size());
  out.reference = render(lifted, out.T_w_kf, after);
  return out;
}

void LocalMapper::adjust(KeyframeInsertion& out) {
  if (options_.adjust_keyframes <= 0) return;
  const auto& kfs = map_.keyframes();
  const int n = static_cast<int>(kfs.size());
  if (n < 2) return;
  std::vector<int64_t> free_seqs;
  for (int k = std::max(0, n - options_.adjust_keyframes); k < n; ++k) {
    free_seqs.push_back(kfs[k].seq);
  }
  // Landmarks the free keyframes observed, measured at least twice (once constrains nothing).
  std::vector<int64_t> ids;
  for (const int64_t id : observedBy(map_, free_seqs)) {
    if (map_.points().at(id).observations.size() >= 2) ids.push_back(id);
  }
  // Every keyframe that measured them, and the keyframes the free ones were measured from by
  // lines and planes; those outside the free ones are held fixed.
  std::map<int64_t, int> index_of;
  estimator::BundleProblem problem;
  problem.camera = camera_;
  const std::set<int64_t> free_set(free_seqs.begin(), free_seqs.end());
  std::set<int64_t> involved;
  for (const int64_t id : ids) {
    for (const MapObservation& o : map_.points().at(id).observations)
      involved.insert(o.keyframe_seq);
  }
  for (const auto relative : kRelativePoses) {
    for (const int64_t seq : free_seqs) {
      const std::optional<MapRelativePose>& rel = map_.keyframe(seq)->*relative;
      if (rel && map_.keyframe(rel->from_seq)) {
        involved.insert(seq);
        involved.insert(rel->from_seq);
      }
    }
  }
  if (involved.size() < 2) return;
  bool any_fixed = false;
  for (const int64_t seq : involved) any_fixed |= free_set.count(seq) == 0;
  for (const int64_t seq : involved) {
    index_of[seq] = static_cast<int>(problem.keyframes.size());
    // Without an older keyframe in the problem the oldest free one is the gauge.
    const bool fixed = free_set.count(seq) == 0 || (!any_fixed && seq == *involved.begin());
    problem.keyframes.push_back({map_.keyframe(seq)->T_w_kf, fixed});
    (fixed ? out.fixed_keyframes : out.adjusted_keyframes)++;
  }
  std::vector<std::pair<int64_t, int64_t>> observation_of;  // (landmark id, keyframe seq)
  for (size_t l = 0; l < ids.size(); ++l) {
    const MapPoint& p = map_.points().at(ids[l]);
    problem.landmarks_w.push_back(p.p_w);
    bool first = true;
    for (const MapObservation& o : p.observations) {
      // The first observation places the landmark in depth; the others are pixels (their
      // depth, lifted on depth fused with the same poses, is not an independent measurement).
      const bool use_depth = first;
      first = false;
      problem.observations.push_back({index_of.at(o.keyframe_seq), static_cast<int>(l), o.p_kf,
                                      o.cov_kf, use_depth, o.sigma_px});
      observation_of.emplace_back(ids[l], o.keyframe_seq);
    }
  }
  // Lines and planes alone, and what tracking measured (every feature): the window's points
  // refine the keyframes but cannot carry one where tracking says it is not (few points on
  // plain surfaces moved whole windows by a metre). Points and lines/planes then each enter
  // twice (as observations or their own relative pose, and in tracking's), which scales the
  // information without moving its minimum.
  for (const auto relative : kRelativePoses) {
    for (const int64_t seq : free_seqs) {
      const std::optional<MapRelativePose>& rel = map_.keyframe(seq)->*relative;
      if (!rel || index_of.count(rel->from_seq) == 0 || index_of.count(seq) == 0) continue;
      problem.relative_poses.push_back(
          {index_of.at(rel->from_seq), index_of.at(seq), rel->T_this_from, rel->covariance});
    }
  }
  estimator::BundleOptions bundle;
  bundle.max_iterations = options_.adjust_iterations;
  const estimator::BundleResult result = estimator::adjustLocalBundle(problem, bundle);
  if (!result.solved) return;
  out.adjusted = true;
  for (const auto& [seq, k] : index_of) {
    if (!problem.keyframes[k].fixed) map_.keyframe(seq)->T_w_kf = result.T_w_kf[k];
  }
  for (size_t l = 0; l < ids.size(); ++l) {
    if (MapPoint* p = map_.point(ids[l])) p->p_w = result.landmarks_w[l];
  }
  for (size_t i = 0; i < observation_of.size(); ++i) {
    if (result.inlier[i]) continue;
    map_.removeObservation(observation_of[i].first, observation_of[i].second);
    ++out.outliers_removed;
  }
  for (const int64_t id : ids) map_.updatePointCovariance(id);
}

FrameFeatures LocalMapper::render(const FrameFeatures& lifted, const Pose3& T_w_kf,
                                  const std::vector<int64_t>& window) const {
  FrameFeatures reference = lifted;
  // Landmarks a little outside the keyframe's view too: the next frames move away from it.
  const double margin = -0.25 * lifted.camera.width;
  ProjectedLandmarks seen = project(map_, observedBy(map_, window), T_w_kf, lifted.camera, margin);
  if (!options_.landmark_pose_uncertainty) {
    reference.points = std::move(seen.points);
    reference.point_descriptors = seen.descriptors;
    return reference;
  }
  const std::map<int64_t, CarriedKeyframe> carried =
      carriedInto(map_, T_w_kf.inverse(), chainedPoseCovariances(map_, lifted.seq));
  reference.points.clear();
  reference.point_descriptors = cv::Mat();
  for (size_t l = 0; l < seen.ids.size(); ++l) {
    const std::optional<Eigen::Matrix3d> cov = covarianceIn(map_.points().at(seen.ids[l]), carried);
    if (!cov) continue;
    reference.points.push_back(seen.points[l]);
    reference.points.back().point.cov = *cov;
    reference.point_descriptors.push_back(seen.descriptors.row(static_cast<int>(l)));
  }
  return reference;
}

}  // namespace pplvo::tracking
